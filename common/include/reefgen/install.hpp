#pragma once
// Where an installed reefgen keeps its data (`cmake --install`): PREFIX/bin's
// programs find the shipped model and the studio page in
// PREFIX/share/reefgen. A build tree has no such folder; its programs use
// the source tree's models/ and the build's studio assets.
#include <filesystem>
#include <string>
#include <system_error>

namespace reefgen {

// PREFIX/share/reefgen/<sub> beside this program's bin/ when it exists, else "".
inline std::filesystem::path installed_data(const std::string& sub) {
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) return {};
  const std::filesystem::path d = exe.parent_path().parent_path() / "share" / "reefgen" / sub;
  return std::filesystem::is_directory(d, ec) ? d : std::filesystem::path();
}

}  // namespace reefgen
