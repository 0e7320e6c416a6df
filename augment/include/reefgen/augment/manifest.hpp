#pragma once
// Reading a built dataset's manifest.jsonl, checked before anything trusts it:
// every record well-formed, every path inside the dataset folder,
// every pair index listed once, and each file's bytes equal to the FNV-64
// checksum the build recorded (labels swapped in from another dataset, a pair
// edited or truncated after the build). The check streams the files (one at a
// time per thread); its cost is in docs/BENCHMARKS.md.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace reefgen::augment {

struct ManifestPair {
  int64_t line = 0;   // 1-based line in manifest.jsonl
  int64_t index = 0;  // the pair's index in the recipe
  std::string split, label, height;  // split name; paths relative to the dataset folder
  nlohmann::json record;             // the whole line
};

struct ManifestCheck {
  bool verify_checksums = true;  // false: `--no-verify` (structure and paths are still checked)
  int threads = 1;               // checksum threads, [1, 256]
  bool quiet = true;             // progress on stderr
};

// Throws reefgen::Error naming the file (and the manifest line) and the fix.
std::vector<ManifestPair> read_manifest(const std::filesystem::path& dir, const ManifestCheck& check = {});

}  // namespace reefgen::augment
