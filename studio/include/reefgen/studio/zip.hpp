#pragma once
// A ZIP archive of files kept as they are (method 0, "stored"): how the
// studio hands a bundle folder to the browser in one download. Every file
// dated 1980-01-01 00:00 (ZIP's epoch), so the same files give the same bytes.
#include <string>
#include <utility>
#include <vector>

namespace reefgen::studio {

// (name inside the archive, bytes) in order; names in UTF-8 (flag bit 11).
// Throws reefgen::Error past ZIP's 4 GiB / 65535-entry limits (no ZIP64).
std::string zip_stored(const std::vector<std::pair<std::string, std::string>>& files);

}  // namespace reefgen::studio
