// libFuzzer target: the exported-generator loader (what `reefgen infer -m`
// reads). Any bytes: the only acceptable failure is std::runtime_error naming
// the file; crashes, sanitizer reports, other exceptions and huge allocations
// (libFuzzer's -rss_limit_mb) are findings.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <string>

#include "reefgen/model/generator_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string path =
      (std::filesystem::temp_directory_path() / ("reefgen-fuzz-" + std::to_string(::getpid()) + ".pt")).string();
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) return 0;
  std::fwrite(data, 1, size, f);
  std::fclose(f);
  try {
    (void)reefgen::model::load_generator(path);
  } catch (const std::runtime_error&) {
  }
  std::remove(path.c_str());
  return 0;
}
