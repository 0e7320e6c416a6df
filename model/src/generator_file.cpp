#include "reefgen/model/generator_file.hpp"

#include <nlohmann/json.hpp>

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

void save_generator(const std::filesystem::path& path, UNetGenerator& g, const HeightRange& range, int size_px,
                    int64_t train_step) {
  torch::serialize::OutputArchive a;
  a.write("format", c10::IValue(std::string(kGeneratorFormat)));
  a.write("format_version", c10::IValue(kGeneratorFormatVersion));
  a.write("reefgen_version", c10::IValue(std::string(kVersion)));
  a.write("options", c10::IValue(options_json(g->options()).dump()));
  a.write("height_range_m", c10::IValue(std::vector<double>{range.lo_m, range.hi_m}));
  a.write("size_px", c10::IValue(int64_t(size_px)));
  a.write("train_step", c10::IValue(train_step));
  torch::serialize::OutputArchive weights;
  g->save(weights);
  a.write("G", weights);
  save_archive_atomic(a, path);
}

GeneratorFile load_generator(const std::filesystem::path& path) {
  torch::serialize::InputArchive a;
  load_archive(a, path, "exported generator", "export one with `reefgen train` (RUN/generator.pt)");
  expect_format(a, path, kGeneratorFormat, kGeneratorFormatVersion,
                "a file exported by `reefgen train` (RUN/generator.pt), not a checkpoint or another tool's model");
  GeneratorFile f;
  UNetOptions o;
  try {
    const auto j = nlohmann::json::parse(read_string(a, "options"));
    o.in_channels = j.at("in_channels");
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
    torch::serialize::InputArchive weights;
    a.read("G", weights);
    f.g->load(weights);
  } catch (const std::exception& e) {
    throw std::runtime_error(path.string() + ": not a usable reefgen generator (" + first_line(e.what()) +
                             "); re-export it with this version of reefgen");
  }
  return f;
}

}  // namespace reefgen::model
