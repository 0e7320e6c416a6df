#pragma once
// Building a training set on disk (docs/DATASET.md). Each function is what
// one `reefgen dataset` subcommand runs.
#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>

#include <nlohmann/json.hpp>

#include "reefgen/augment/dataset.hpp"
#include "reefgen/augment/formats.hpp"

namespace reefgen::augment {

// "I/N" (0 ≤ I < N ≤ 999999) -> {I, N}; throws reefgen::Error naming the text.
std::pair<int, int> parse_shard(const std::string& s);

struct BuildOptions {
  std::filesystem::path out;  // the dataset folder: new, empty, or this dataset's (resumed)
  uint64_t seed = 0;          // global seed: pair i is a pure function of (seed, i)
  int threads = 1;            // worker threads, [1, 256]; same bytes whatever the count
  std::string shard = "0/1";  // build only the pairs with index % N == I
  bool quiet = false;         // no progress on stderr
  bool layers = false;        // also each pair's layer files (docs/LAYERS.md), listed with checksums in the manifest
  DatasetLayout layout = DatasetLayout::Reefgen;  // the files' layout: reefgen's, or one other tools read
  int tar_mb = 1024;          // webdataset: a shard's size at most, MiB, [1, 65536] (WebDataset's advice: ~1 GB)
};
struct BuildResult {
  std::filesystem::path manifest;  // manifest.jsonl, or manifest.shard-I-of-N.jsonl
  size_t pairs = 0, reused = 0;    // pairs of this shard; of them, already on disk and verified
};
// Builds (or resumes) the dataset: dataset.json, the pairs, the manifest
// (written atomically once every pair is in place). Refuses a folder that is
// neither empty nor this dataset, and files of another dataset.
BuildResult build_dataset(const DatasetParams& p, const BuildOptions& o);

struct MergeResult {
  std::filesystem::path manifest;  // DIR/manifest.jsonl
  size_t shards = 0;
  int64_t pairs = 0;
};
// Joins the shard manifests of `dir` into manifest.jsonl, verifying every
// pair's checksums and that no file is foreign to the manifests.
MergeResult merge_dataset(const std::filesystem::path& dir);

// Pairs per split, region pixel fractions, subsidence histogram, height
// range; writes DIR/stats.json and DIR/contact_sheet.png (sheet_pairs pairs,
// [0, 1024]) and returns the stats.
// verify: the files against the manifest's checksums first (read_manifest).
nlohmann::json dataset_stats(const std::filesystem::path& dir, int sheet_pairs, bool quiet, bool verify = true);

}  // namespace reefgen::augment
