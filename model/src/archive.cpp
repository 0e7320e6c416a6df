#include "reefgen/model/archive.hpp"

#include <unistd.h>

namespace reefgen::model {

std::string first_line(const std::string& s) { return s.substr(0, s.find('\n')); }

void save_archive_atomic(torch::serialize::OutputArchive& a, const std::filesystem::path& path) {
  const std::filesystem::path tmp = path.string() + ".tmp-" + std::to_string(::getpid());
  try {
    a.save_to(tmp.string());
    std::filesystem::rename(tmp, path);
  } catch (const std::exception& e) {
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    throw std::runtime_error(path.string() + ": cannot write (" + first_line(e.what()) +
                             "); check free space and permissions");
  }
}

void load_archive(torch::serialize::InputArchive& a, const std::filesystem::path& path, const std::string& what,
                  const std::string& fix) {
  if (!std::filesystem::is_regular_file(path))
    throw std::runtime_error(path.string() + ": " + what + " not found; " + fix);
  try {
    a.load_from(path.string());
  } catch (const std::exception& e) {
    throw std::runtime_error(path.string() + ": truncated or not a LibTorch archive (" + first_line(e.what()) +
                             "); " + fix);
  }
}

std::string read_string(torch::serialize::InputArchive& a, const std::string& key) {
  c10::IValue v;
  if (!a.try_read(key, v) || !v.isString()) return {};
  return v.toStringRef();
}

void expect_format(torch::serialize::InputArchive& a, const std::filesystem::path& path, const std::string& format,
                   int64_t version, const std::string& expected_what) {
  const std::string got = read_string(a, "format");
  if (got != format)
    throw std::runtime_error(path.string() + ": " + (got.empty() ? "no reefgen format tag" : "a '" + got + "' file") +
                             "; expected " + expected_what);
  c10::IValue v;
  if (!a.try_read("format_version", v) || !v.isInt() || v.toInt() != version)
    throw std::runtime_error(path.string() + ": " + format + " format version " +
                             (v.isInt() ? std::to_string(v.toInt()) : "?") + ", this reefgen reads " +
                             std::to_string(version) + "; use the reefgen version that wrote it");
}

}  // namespace reefgen::model
