// reefgen model: look into and repackage generator files (docs/MODEL.md).
// `pack` stores the weights as float16 with their SHA-256 (how the shipped
// model is made); `info` loads a file, which verifies it, and prints what it is.
#include <cstdio>

#include "app.hpp"
#include "reefgen/cpu.hpp"
#include "reefgen/files.hpp"
#include "reefgen/model/dnnl_conv.hpp"
#include "reefgen/model/fast_unet.hpp"
#include "reefgen/model/generator_file.hpp"
#include "reefgen/model/onnx_export.hpp"
#include "reefgen/model/shipped.hpp"

namespace reefgen {

using nlohmann::json;

Command add_model_command(CLI::App& app, const GlobalOptions&) {
  auto* sub = app.add_subcommand(
      "model",
      "Inspect or repackage generator files\n\n"
      "Examples:\n"
      "  reefgen model info                                  # the shipped model: verified, described\n"
      "  reefgen model info runs/try/generator.pt\n"
      "  reefgen model pack runs/try/generator.pt -o models/reef-256.pt --storage float16\n"
      "  reefgen model cpu                                   # what this CPU runs: class, flags, auto's choice\n"
      "  reefgen model export --onnx out/reef-256.onnx       # the shipped model for ONNX runtimes (Sentis, NNE, ORT)\n");
  sub->require_subcommand(1);
  struct Args {
    std::string in, out, storage = "float16", onnx;
    int size_px = 0;
    bool running_stats = false;
  };
  auto a = std::make_shared<Args>();
  auto* info = sub->add_subcommand("info", "Load (and so verify) a generator file; print its options, size and checksum");
  info->add_option("generator", a->in, "Generator file (default: the shipped model)");
  auto* pack = sub->add_subcommand("pack", "Rewrite a generator file with float16 or float32 weights and a SHA-256");
  pack->add_option("generator", a->in, "Generator exported by `reefgen train`")->required();
  pack->add_option("-o,--out,--output", a->out, "Output file (not the input)")->required();
  pack->add_option("--storage", a->storage, "float16 (half the size; computes in float32) or float32")
      ->capture_default_str();
  auto* exp = sub->add_subcommand(
      "export", "Write a generator as an ONNX graph (opset 13) that answers metres (docs/ENGINES.md)");
  exp->add_option("generator", a->in, "Generator file (default: the shipped model)");
  exp->add_option("--onnx", a->onnx, "The ONNX file to write")->required();
  exp->add_option("--size", a->size_px, "Input side in pixels (default: the side it was trained at)")
      ->check(CLI::Range(32, 4096));
  exp->add_flag("--running-stats", a->running_stats,
                "BatchNorm from its running averages, as infer --running-stats (default: each sample's own statistics)");
  auto* cpu = sub->add_subcommand(
      "cpu", "Print this CPU's class and flags, and what --precision auto and the vector loops choose here (JSON)");
  return {sub, [a, info, pack, exp, cpu]() -> int {
            if (cpu->parsed()) {
              const CpuFeatures& c = cpu_features();
              const json j = {{"cpu", c.model},
                              {"class", cpu_class()},
                              {"summary", cpu_summary()},
                              {"flags",
                               {{"avx2", c.avx2},
                                {"fma", c.fma},
                                {"avx512f", c.avx512f},
                                {"avx512bw", c.avx512bw},
                                {"avx512_bf16", c.avx512_bf16},
                                {"amx_bf16", c.amx_bf16}}},
                              {"bf16_hidden", cpu_bf16_hidden()},
                              {"bf16_convolutions", model::bf16_convolution_available()},
                              {"native_bf16", model::cpu_has_native_bf16()},
                              {"auto_precision", model::cpu_has_native_bf16() ? "bf16" : "fp32"},
                              {"vector_path", to_string(cpu_path())},
                              {"winograd_gemm", model::winograd_gemm_name()}};
              std::printf("%s\n", j.dump(1).c_str());
              return 0;
            }
            const fs::path in = model::resolve_model_path(a->in);
            model::GeneratorFile f = model::load_generator(in);
            const auto& o = f.g->options();
            if (info->parsed()) {
              const json j = {{"path", in.string()},
                              {"bytes", fs::file_size(in)},
                              {"weights", f.storage == model::WeightStorage::Float16 ? "float16" : "float32"},
                              {"weights_sha256", f.weights_sha256.empty() ? json(nullptr) : json(f.weights_sha256)},
                              {"parameters", model::count_parameters(*f.g)},
                              {"ngf", o.ngf},
                              {"depth", o.depth},
                              {"norm", model::to_string(o.norm)},
                              {"upsample", model::to_string(o.upsample)},
                              {"size_px", f.size_px},
                              {"height_range_m", {f.range.lo_m, f.range.hi_m}},
                              {"train_step", f.train_step},
                              {"reefgen_version", f.reefgen_version}};
              std::printf("%s\n", j.dump(1, ' ', false, nlohmann::json::error_handler_t::replace).c_str());
              return 0;
            }
            if (exp->parsed()) {
              std::error_code ec;
              if (fs::exists(a->onnx) && fs::equivalent(in, a->onnx, ec))
                throw Error(a->onnx + ": is the input; write the ONNX file elsewhere");
              model::OnnxExportOptions eo;
              eo.size_px = a->size_px > 0 ? a->size_px : f.size_px;
              eo.running_stats = a->running_stats;
              const fs::path parent = fs::path(a->onnx).parent_path();
              ensure_writable_dir(parent.empty() ? fs::path(".") : parent);
              model::write_generator_onnx(a->onnx, *f.g, f.range, eo);
              std::printf("%s\n", a->onnx.c_str());
              return 0;
            }
            if (a->storage != "float16" && a->storage != "float32")
              throw Error("--storage " + a->storage + ": use float16 or float32");
            std::error_code ec;
            if (fs::exists(a->out) && fs::equivalent(in, a->out, ec))
              throw Error(a->out + ": is the input; write the packed file elsewhere");
            model::save_generator(a->out, f.g, f.range, f.size_px, f.train_step,
                                  a->storage == "float16" ? model::WeightStorage::Float16 : model::WeightStorage::Float32);
            model::load_generator(a->out);  // read back: the checksum holds
            std::printf("%s\n", a->out.c_str());
            return 0;
          }};
}

}  // namespace reefgen
