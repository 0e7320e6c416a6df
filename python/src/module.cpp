// reefgen's C++ core for Python (pybind11): islands, dataset pairs and the
// realism statistics as numpy arrays (docs/PYTHON.md). The arrays own the
// OpenCV buffers the C++ code wrote (no copy); the GIL is released while
// C++ works; reefgen::Error becomes reefgen.Error with the same one line.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cmath>
#include <map>
#include <string>

#include <opencv2/imgproc.hpp>

#include "reefgen/augment/dataset.hpp"
#include "reefgen/augment/manifest.hpp"
#include "reefgen/constants.hpp"
#include "reefgen/files.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/presets.hpp"
#include "reefgen/procgen/generator.hpp"
#include "reefgen/procgen/spec.hpp"
#include "reefgen/terrain/realism.hpp"
#include "reefgen/version.hpp"
#include "interrupt_hook.hpp"
#include "numpy_mat.hpp"

namespace py = pybind11;

namespace reefgen {
const std::map<std::string, std::string>& builtin_presets();  // cli/CMakeLists.txt's generated presets.cpp
}

namespace {

using namespace reefgen;
using python::to_numpy;

// One past the last pair index: DatasetParams::count's upper bound (1e8).
constexpr int64_t kMaxPairIndex = 100000000;

// The label map as its PNG holds it, in RGB (what PIL and torchvision read).
cv::Mat3b rgb_of(const cv::Mat3b& bgr) {
  cv::Mat3b rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  return rgb;
}

augment::DatasetParams dataset_params(const std::string& config_json) {
  if (config_json.empty()) return {};
  return augment::dataset_params_from_json(parse_json_checked(config_json, "dataset config"), "dataset config");
}

// A pair does not depend on the dataset's count: index i is the pair any
// dataset of more than i pairs holds, up to the largest count allowed.
void check_pair_index(int64_t index) {
  if (index < 0 || index >= kMaxPairIndex)
    throw Error("pair index " + std::to_string(index) + " is outside [0, " + std::to_string(kMaxPairIndex) +
                "), the pairs a dataset can hold");
}

// A pair's conditioning as a dict: index, configuration, level, subsidence, split, seed, age_myr
// (NaN when the dataset draws no age), maturity, ruggedness (style, 1 = rugged).
py::dict conditioning(const augment::PairInfo& info) {
  py::dict d;
  d["index"] = info.index;
  d["configuration"] = info.configuration;
  d["level"] = info.level;
  d["subsidence"] = info.subsidence;
  d["split"] = augment::split_name(info.split);
  // The seed as a decimal string: a 64-bit seed is beyond a tensor's int64,
  // and the DataLoader collates strings into lists. No age: NaN (a float
  // batch collates; None does not).
  d["seed"] = std::to_string(info.seed);
  d["age_myr"] = info.age_myr < 0 ? std::nan("") : info.age_myr;
  d["maturity"] = info.maturity;
  d["ruggedness"] = info.ruggedness;
  return d;
}

// `reefgen dataset build`'s pair `index` for (config, seed): heights in
// metres and the label map, the same numbers as its files hold.
// with_info: also its conditioning (index, configuration, level, subsidence,
// split; PairStream's with_conditioning), known once the pair is made.
py::tuple pair(const std::string& config_json, uint64_t seed, int64_t index, bool with_info) {
  const augment::DatasetParams p = dataset_params(config_json);
  check_pair_index(index);
  cv::Mat1f height;
  cv::Mat3b label;
  augment::PairInfo info;
  {
    py::gil_scoped_release free_python;
    const augment::Pair pr = augment::make_pair(seed, index, p, &info);
    height = pr.height_m;
    label = rgb_of(encode_labels(pr.label, pr.subsidence));
  }
  if (!with_info) return py::make_tuple(to_numpy<float>(height), to_numpy<uint8_t>(label));
  return py::make_tuple(to_numpy<float>(height), to_numpy<uint8_t>(label), conditioning(info));
}

// A painted or generated label map -> (regions, subsidence, ruggedness): the
// decoding `infer` applies (labels.hpp), as uint8 ids 0..4, float32 λ and
// uint8 style (255 rugged).
py::tuple decode_labels(const py::array& image) {
  const cv::Mat bgr = python::bgr_of(image, "decode_labels");
  DecodedSketch d;
  {
    py::gil_scoped_release free_python;
    d = decode_sketch(bgr, "decode_labels");
  }
  return py::make_tuple(to_numpy<uint8_t>(d.label), to_numpy<float>(d.subsidence), to_numpy<uint8_t>(d.ruggedness));
}

py::dict pair_info(const std::string& config_json, uint64_t seed, int64_t index) {
  check_pair_index(index);
  const augment::DatasetParams p = dataset_params(config_json);
  // The augmentation record is known only once the pair is made (how many
  // islands a paste placed, whether a translation was skipped): made here as
  // `dataset build` makes it, so the record is the manifest's.
  augment::PairInfo info;
  {
    py::gil_scoped_release free_python;
    augment::make_pair(seed, index, p, &info);
  }
  py::dict d = conditioning(info);
  d["augmentation"] = info.augmentation.dump();
  return d;
}

// The splits of pairs start … start + count − 1, one letter each ('t'
// train, 'v' val, 's' test), without making any pair: PairStream's filter.
std::string pair_splits(const std::string& config_json, uint64_t seed, int64_t start, int64_t count) {
  if (count < 0) throw Error("pair_splits: count must be >= 0");
  check_pair_index(start);
  if (count > 0) check_pair_index(start + count - 1);
  const augment::DatasetParams p = dataset_params(config_json);
  static constexpr char kLetter[3] = {'t', 'v', 's'};
  std::string out(size_t(count), 't');
  for (int64_t k = 0; k < count; ++k) out[size_t(k)] = kLetter[int(augment::pair_info(seed, start + k, p).split)];
  return out;
}

// A preset or spec JSON, with age_myr and maturity (NaN: the spec's own)
// written into it before it is read, as the CLI's flags.
procgen::IslandSpec spec_of(const std::string& preset, const std::string& spec_json, double age_myr = NAN,
                            double maturity = NAN) {
  nlohmann::json j = parse_json_checked(spec_json.empty() ? preset_text(builtin_presets(), preset) : spec_json, "spec");
  if (!std::isnan(age_myr)) j["age_myr"] = age_myr;
  if (!std::isnan(maturity)) j["maturity"] = maturity;
  return procgen::spec_from_json(j, spec_json.empty() ? "preset " + preset : "spec");
}

// `reefgen generate --preset NAME` (or a spec) at `size`: heights and labels.
py::tuple generate(const std::string& preset, const std::string& spec_json, int size, py::object seed,
                   double subsidence, double age_myr, double maturity) {
  procgen::IslandSpec spec = spec_of(preset, spec_json, age_myr, maturity);
  if (!seed.is_none()) spec.noise.seed = seed.cast<uint64_t>();
  if (!std::isnan(subsidence)) spec.subsidence = subsidence;
  procgen::RenderOptions opt;
  opt.size_px = size;
  cv::Mat1f height;
  cv::Mat3b label;
  {
    py::gil_scoped_release free_python;
    const procgen::IslandFields f = procgen::generate(spec, opt);
    height = f.height_m;
    label = rgb_of(encode_labels(f.label, spec.subsidence));
  }
  return py::make_tuple(to_numpy<float>(height), to_numpy<uint8_t>(label));
}

py::dict realism(py::array_t<float, py::array::c_style | py::array::forcecast> heights, double metres_per_px) {
  if (heights.ndim() != 2) throw Error("realism: heights must be a 2-D array (H, W) of metres");
  const cv::Mat1f h(int(heights.shape(0)), int(heights.shape(1)), const_cast<float*>(heights.data()));
  terrain::RealismStats s;
  {
    py::gil_scoped_release free_python;
    s = terrain::realism_stats(h, metres_per_px);
  }
  py::dict d;
  const nlohmann::json j = s;
  for (const auto& [key, value] : j.items()) {
    if (value.is_number_integer()) d[key.c_str()] = value.get<int64_t>();
    else d[key.c_str()] = value.get<double>();
  }
  return d;
}

// One split of a built dataset: its manifest records (JSON text), read and
// checked by the reader `reefgen train` uses (reefgen's layout, paths inside
// the folder, each index once and, with `verify`, every file's checksum).
py::list manifest_records(const std::string& root, const std::string& split, bool verify) {
  std::vector<augment::ManifestPair> pairs;
  {
    py::gil_scoped_release free_python;
    augment::ManifestCheck check;
    check.verify_checksums = verify;
    pairs = augment::read_manifest(root, check);
  }
  py::list records;
  for (const auto& p : pairs)
    if (p.split == split) records.append(p.record.dump());
  return records;
}

py::list presets() {
  py::list names;
  for (const auto& [k, v] : builtin_presets()) names.append(k);
  return names;
}

}  // namespace

PYBIND11_MODULE(_reefgen, m) {
  m.doc() = "reefgen's C++ core: coral-reef islands, dataset pairs and realism statistics (docs/PYTHON.md)";
  py::register_exception<reefgen::Error>(m, "Error", PyExc_RuntimeError);
  // nlohmann's parse errors name the byte: the same one line as the CLI's.
  py::register_exception<nlohmann::json::exception>(m, "ConfigError", PyExc_ValueError);
  reefgen::python::install_interrupt_hook();
  m.attr("__version__") = reefgen::kVersion;
  // The range the networks map to [-1, 1] (m): to_tensors' height_range_m for reefgen's models.
  m.attr("HEIGHT_RANGE_M") = py::make_tuple(reefgen::kAbyssFloorM, reefgen::kHeightCeilingM);
  m.def("pair", &pair, py::arg("config_json"), py::arg("seed"), py::arg("index"), py::arg("with_info") = false);
  m.def("decode_labels", &decode_labels, py::arg("image"));
  m.def("pair_info", &pair_info, py::arg("config_json"), py::arg("seed"), py::arg("index"));
  m.def("pair_splits", &pair_splits, py::arg("config_json"), py::arg("seed"), py::arg("start"), py::arg("count"));
  m.def("generate", &generate, py::arg("preset"), py::arg("spec_json"), py::arg("size"), py::arg("seed"),
        py::arg("subsidence"), py::arg("age_myr"), py::arg("maturity"));
  m.def("realism", &realism, py::arg("heights"), py::arg("metres_per_px"));
  m.def("presets", &presets);
  m.def("manifest_records", &manifest_records, py::arg("root"), py::arg("split"), py::arg("verify"));
}
