// reefgen dataset build|merge|stats: training sets from the generator +
// augmentation. Thin: flags -> augment's build library (docs/DATASET.md).
#include <cstdio>

#include "app.hpp"
#include "reefgen/augment/build.hpp"
#include "reefgen/files.hpp"

namespace reefgen {

using nlohmann::json;

namespace {

struct BuildArgs {
  std::string config;
  augment::BuildOptions o;
  int64_t count = -1;
  bool count_given = false;
  std::string format = "reefgen";
};

}  // namespace

// Long: the build and merge subcommands' flags, one per line; the work is
// augment/'s dataset builder.
Command add_dataset_command(CLI::App& app, const GlobalOptions& g) {
  auto* sub = app.add_subcommand("dataset", "Build training sets (generator + augmentation)\n\n"
                                            "Examples:\n"
                                            "  reefgen dataset build --config configs/dataset/paper.json --out data/paper\n"
                                            "  reefgen dataset build --count 200 --seed 1 --out data/small\n"
                                            "  reefgen dataset build --config configs/dataset/paper.json --out data/p --shard 0/2\n"
                                            "  reefgen dataset build --count 100 --out data/layers --layers\n"
                                            "  reefgen dataset build --count 1000 --out data/facades --format pix2pix   # junyanz's aligned A|B\n"
                                            "  reefgen dataset build --count 100000 --out data/wds --format webdataset # tar shards of ~1 GB\n"
                                            "  reefgen dataset build --count 1000 --out data/hf --format imagefolder    # Hugging Face datasets\n"
                                            "  reefgen dataset merge data/p\n"
                                            "  reefgen dataset stats data/p\n");
  sub->require_subcommand(1);
  auto a = std::make_shared<BuildArgs>();
  auto* build = sub->add_subcommand("build", "Build (or resume) a dataset into --out");
  build->add_option("--config", a->config, "Dataset config JSON (configs/dataset/*.json)");
  build->add_option("-o,--out,--output", a->o.out, "Dataset folder")->required();
  build->add_option("--count", a->count, "Override the number of pairs (1..100000000)")
      ->each([a](const std::string&) { a->count_given = true; });
  build->add_option("--seed", a->o.seed, "Global seed")->capture_default_str()->check(seed_value());
  a->o.threads = default_threads();
  build->add_option("--threads", a->o.threads, "Worker threads (default: all cores)");
  build->add_option("--shard", a->o.shard, "Build only slice I of N (pairs with index % N == I)")->capture_default_str();
  build->add_flag("--layers", a->o.layers,
                  "Also each pair's layers (docs/LAYERS.md): SPLIT/INDEX.flow.png, .slope.png, .splat0/1.png, ..., "
                  "listed with checksums in the manifest");
  build->add_option("--format", a->format,
                    "Files' layout: reefgen (what `reefgen train` reads), pix2pix (SPLIT/INDEX.png, A|B aligned), "
                    "webdataset (SPLIT-NNNNNN.tar shards + SPLIT.index.json), imagefolder (SPLIT/INDEX.png + "
                    ".height.npy + metadata.jsonl); docs/DATASET.md")
      ->capture_default_str();
  auto* tar_mb = build->add_option("--tar-mb", a->o.tar_mb, "webdataset: MiB a shard holds at most (1..65536)")->capture_default_str();
  auto merge_dir = std::make_shared<std::string>();
  auto* merge = sub->add_subcommand("merge", "Join shard manifests into manifest.jsonl, verifying checksums");
  merge->add_option("dir", *merge_dir, "Dataset folder")->required();
  auto stats_dir = std::make_shared<std::string>();
  auto sheet = std::make_shared<int>(16);
  auto* stats = sub->add_subcommand("stats", "Counts, region fractions, subsidence histogram, height range, contact sheet");
  stats->add_option("dir", *stats_dir, "Dataset folder")->required();
  stats->add_option("--sheet", *sheet, "Pairs on the contact sheet (DIR/contact_sheet.png)")->capture_default_str();
  auto no_verify = std::make_shared<bool>(false);
  stats->add_flag("--no-verify", *no_verify, "Skip checking the pair files against the manifest's checksums");
  return {sub, [a, merge_dir, build, merge, stats, stats_dir, sheet, no_verify, tar_mb, &g]() -> int {
            if (stats->parsed()) {
              const json st = augment::dataset_stats(*stats_dir, *sheet, g.quiet, !*no_verify);
              std::printf("%s\n", st.dump(2, ' ', false, json::error_handler_t::replace).c_str());
              return 0;
            }
            if (build->parsed()) {
              // The config file, then the flags over it.
              augment::DatasetParams p;
              if (!a->config.empty()) {
                if (!fs::exists(a->config)) throw Error("cannot read " + a->config + ": no such file");
                p = augment::dataset_params_from_json(read_json(a->config), a->config);
              }
              if (a->count_given) {
                if (a->count < 1 || a->count > 100'000'000)
                  throw Error("--count " + std::to_string(a->count) + ": the number of pairs must be in 1..100000000");
                p.count = a->count;
              }
              a->o.quiet = g.quiet;
              a->o.layout = augment::layout_from_string(a->format);
              if (tar_mb->count() > 0 && a->o.layout != augment::DatasetLayout::WebDataset)
                throw Error("--tar-mb sizes WebDataset shards; add --format webdataset or drop --tar-mb");
              const augment::BuildResult r = augment::build_dataset(p, a->o);
              if (!g.quiet)
                std::fprintf(stderr, "dataset: %zu pairs (%zu already there) in %s, manifest %s\n", r.pairs, r.reused,
                             a->o.out.c_str(), r.manifest.filename().c_str());
              std::printf("%s\n", r.manifest.c_str());
              return 0;
            }
            if (merge->parsed()) {
              const augment::MergeResult r = augment::merge_dataset(*merge_dir);
              if (!g.quiet)
                std::fprintf(stderr, "merged %zu shards, %lld pairs verified\n", r.shards, static_cast<long long>(r.pairs));
              std::printf("%s\n", r.manifest.c_str());
              return 0;
            }
            return 1;
          }};
}

}  // namespace reefgen
