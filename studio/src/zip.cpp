#include "reefgen/studio/zip.hpp"

#include <zlib.h>

#include <algorithm>
#include <cstdint>
#include <limits>

#include "reefgen/error.hpp"

namespace reefgen::studio {

namespace {

constexpr uint32_t kLocalHeader = 0x04034b50, kCentralHeader = 0x02014b50, kEnd = 0x06054b50;
constexpr uint16_t kVersion = 20;     // 2.0: what a stored file needs
constexpr uint16_t kUtf8Names = 0x0800;
constexpr uint16_t kDosDate1980 = 0x0021;  // 1980-01-01, the earliest DOS date

void u16(std::string& out, uint32_t v) { out += char(v & 0xff), out += char((v >> 8) & 0xff); }
void u32(std::string& out, uint32_t v) { u16(out, v & 0xffff), u16(out, v >> 16); }

// The fields a local and a central header share, from "version needed" to the name length.
void common_fields(std::string& out, uint32_t crc, uint32_t size, size_t name_len) {
  u16(out, kVersion);
  u16(out, kUtf8Names);
  u16(out, 0);  // stored
  u16(out, 0);  // time 00:00
  u16(out, kDosDate1980);
  u32(out, crc);
  u32(out, size);  // compressed = uncompressed
  u32(out, size);
  u16(out, uint32_t(name_len));
}

}  // namespace

std::string zip_stored(const std::vector<std::pair<std::string, std::string>>& files) {
  constexpr uint64_t kMax = std::numeric_limits<uint32_t>::max();
  if (files.size() >= 0xffff) throw Error("zip: too many files (" + std::to_string(files.size()) + ")");
  std::string out, central;
  for (const auto& [name, bytes] : files) {
    if (name.empty() || name.size() >= 0xffff) throw Error("zip: a file name must be 1..65534 bytes");
    if (out.size() + bytes.size() + name.size() + 30 > kMax) throw Error("zip: archive past 4 GiB (" + name + ")");
    // zlib's crc32 takes uInt lengths: large files go in pieces.
    uLong c = crc32(0L, Z_NULL, 0);
    for (size_t at = 0; at < bytes.size();) {
      const size_t n = std::min<size_t>(bytes.size() - at, size_t(1) << 30);
      c = crc32(c, reinterpret_cast<const Bytef*>(bytes.data() + at), uInt(n));
      at += n;
    }
    const uint32_t offset = uint32_t(out.size());
    u32(out, kLocalHeader);
    common_fields(out, uint32_t(c), uint32_t(bytes.size()), name.size());
    u16(out, 0);  // extra field length
    out += name;
    out += bytes;
    u32(central, kCentralHeader);
    u16(central, kVersion);  // made by: MS-DOS attributes, version 2.0
    common_fields(central, uint32_t(c), uint32_t(bytes.size()), name.size());
    u16(central, 0);  // extra
    u16(central, 0);  // comment
    u16(central, 0);  // disk
    u16(central, 0);  // internal attributes
    u32(central, 0);  // external attributes
    u32(central, offset);
    central += name;
  }
  if (out.size() + central.size() + 22 > kMax) throw Error("zip: archive past 4 GiB");
  const uint32_t central_at = uint32_t(out.size());
  out += central;
  u32(out, kEnd);
  u16(out, 0);  // this disk
  u16(out, 0);  // disk with the central directory
  u16(out, uint32_t(files.size()));
  u16(out, uint32_t(files.size()));
  u32(out, uint32_t(central.size()));
  u32(out, central_at);
  u16(out, 0);  // comment length
  return out;
}

}  // namespace reefgen::studio
