#include "reefgen/model/generator_file.hpp"

#include <nlohmann/json.hpp>

#include "reefgen/files.hpp"
#include "reefgen/sha256.hpp"
#include "reefgen/version.hpp"
#include "reefgen/model/archive.hpp"

namespace reefgen::model {

namespace {
nlohmann::json options_json(const UNetOptions& o) {
  return {{"in_channels", o.in_channels}, {"out_channels", o.out_channels}, {"ngf", o.ngf},
          {"depth", o.depth}, {"norm", to_string(o.norm)}, {"dropout", o.dropout},
          {"upsample", to_string(o.upsample)}};
}
}  // namespace

std::string weights_sha256(torch::nn::Module& g) {
  Sha256 h;
  auto add = [&](const std::string& name, const torch::Tensor& t0) {
    const torch::Tensor t = t0.contiguous();
    h.update(name);
    h.update(std::string(c10::toString(t.scalar_type())));
    for (int64_t d : t.sizes()) h.update(&d, sizeof d);
    h.update(t.data_ptr(), t.numel() * t.element_size());
  };
  for (const auto& p : g.named_parameters(/*recurse=*/true)) add(p.key(), p.value());
  for (const auto& b : g.named_buffers(/*recurse=*/true)) add(b.key(), b.value());
  return h.hex();
}

void save_generator(const std::filesystem::path& path, UNetGenerator& g, const HeightRange& range, int size_px,
                    int64_t train_step, WeightStorage storage) {
  torch::serialize::OutputArchive a;
  a.write("format", c10::IValue(std::string(kGeneratorFormat)));
  a.write("format_version", c10::IValue(kGeneratorFormatVersion));
  a.write("reefgen_version", c10::IValue(std::string(kVersion)));
  a.write("options", c10::IValue(options_json(g->options()).dump()));
  a.write("height_range_m", c10::IValue(std::vector<double>{range.lo_m, range.hi_m}));
  a.write("size_px", c10::IValue(int64_t(size_px)));
  a.write("train_step", c10::IValue(train_step));
  // The stored copy: float16 halves the file (the shipped model, models/);
  // only floating-point tensors change type (BatchNorm's counter stays int64).
  UNetGenerator stored(g->options());
  {
    torch::NoGradGuard ng;
    const auto half = storage == WeightStorage::Float16;
    auto copy = [&](torch::OrderedDict<std::string, torch::Tensor> to, torch::OrderedDict<std::string, torch::Tensor> from) {
      for (auto& item : to) {
        const torch::Tensor& src = from[item.key()];
        item.value().set_data(half && src.is_floating_point() ? src.to(torch::kHalf) : src.clone());
      }
    };
    copy(stored->named_parameters(), g->named_parameters());
    copy(stored->named_buffers(), g->named_buffers());
  }
  a.write("weights_dtype", c10::IValue(std::string(storage == WeightStorage::Float16 ? "float16" : "float32")));
  a.write("weights_sha256", c10::IValue(weights_sha256(*stored)));
  torch::serialize::OutputArchive weights;
  stored->save(weights);
  a.write("G", weights);
  save_archive_atomic(a, path);
}

GeneratorFile load_generator(const std::filesystem::path& path) {
  torch::serialize::InputArchive a;
  load_archive(a, path, "exported generator", "export one with `reefgen train` (RUN/generator.pt)");
  int64_t version = 0;
  {
    c10::IValue v;
    if (a.try_read("format_version", v) && v.isInt()) version = v.toInt();
  }
  expect_format(a, path, kGeneratorFormat, version == 1 ? 1 : kGeneratorFormatVersion,
                "a file exported by `reefgen train` (RUN/generator.pt), not a checkpoint or another tool's model");
  GeneratorFile f;
  UNetOptions o;
  try {
    const auto j = parse_json_checked(read_string(a, "options"), path.string() + " (its options)");
    o.in_channels = j.at("in_channels");
    if (o.in_channels != kLabelChannels && o.in_channels != kLabelAndMaturityChannels)
      throw std::runtime_error("it reads " + std::to_string(o.in_channels) +
                               " input channels; reefgen feeds 3 (the label map) or 4 (the label map and the maturity)");
    o.out_channels = j.at("out_channels");
    o.ngf = j.at("ngf");
    o.depth = j.at("depth");
    o.norm = norm_from_string(j.at("norm"));
    o.dropout = j.at("dropout");
    o.upsample = upsample_from_string(j.value("upsample", "transpose"));  // files before it: pix2pix's
    c10::IValue v;
    a.read("height_range_m", v);
    const auto r = v.toDoubleVector();
    f.range = {r.at(0), r.at(1)};
    a.read("size_px", v);
    f.size_px = int(v.toInt());
    a.read("train_step", v);
    f.train_step = v.toInt();
    f.reefgen_version = read_string(a, "reefgen_version");
    f.g = UNetGenerator(o);
    if (version >= 2) {
      const std::string dtype = read_string(a, "weights_dtype");
      if (dtype != "float32" && dtype != "float16") throw std::runtime_error("unknown weights_dtype " + dtype);
      f.storage = dtype == "float16" ? WeightStorage::Float16 : WeightStorage::Float32;
      f.weights_sha256 = read_string(a, "weights_sha256");
    }
    if (f.storage == WeightStorage::Float16) {  // read into tensors of the stored type
      torch::NoGradGuard ng;
      for (auto& t : f.g->parameters()) t.set_data(t.to(torch::kHalf));
      for (auto& t : f.g->buffers())
        if (t.is_floating_point()) t.set_data(t.to(torch::kHalf));
    }
    torch::serialize::InputArchive weights;
    a.read("G", weights);
    f.g->load(weights);
  } catch (const std::exception& e) {
    throw std::runtime_error(path.string() + ": not a usable reefgen generator (" + first_line(e.what()) +
                             "); re-export it with this version of reefgen");
  }
  if (version >= 2) {
    const std::string got = weights_sha256(*f.g);
    if (got != f.weights_sha256)
      throw std::runtime_error(path.string() + ": the weights' SHA-256 does not match the one stored in the file "
                               "(corrupted copy); download or export it again");
  }
  {  // float16 storage computes in float32; integer buffers keep their type
    torch::NoGradGuard ng;
    for (auto& t : f.g->parameters()) t.set_data(t.to(torch::kFloat32));
    for (auto& t : f.g->buffers())
      if (t.is_floating_point()) t.set_data(t.to(torch::kFloat32));
  }
  return f;
}

}  // namespace reefgen::model
