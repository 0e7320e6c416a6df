#pragma once
// Helpers around LibTorch archives shared by generator files and training
// checkpoints: atomic save, loading with one-line errors, format checks.
#include <filesystem>
#include <string>

#include <torch/torch.h>

namespace reefgen::model {

// Every zip entry stored, inside the file and matching its CRC-32: "" or what
// is wrong (load_archive checks it before LibTorch parses anything).
std::string check_zip_integrity(const std::filesystem::path& path);

std::string first_line(const std::string& s);
// Saves to a temporary name beside PATH (fsync'd) then renames: a crash or a full disk never leaves a
// half-written file under the final name.
void save_archive_atomic(torch::serialize::OutputArchive& a, const std::filesystem::path& path);
// Throws std::runtime_error "PATH: missing / truncated or not a LibTorch archive; FIX".
void load_archive(torch::serialize::InputArchive& a, const std::filesystem::path& path, const std::string& what,
                  const std::string& fix);
std::string read_string(torch::serialize::InputArchive& a, const std::string& key);
// Throws unless the archive's "format" and "format_version" are the expected ones.
void expect_format(torch::serialize::InputArchive& a, const std::filesystem::path& path, const std::string& format,
                   int64_t version, const std::string& expected_what);

}  // namespace reefgen::model
