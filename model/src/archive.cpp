#include "reefgen/model/archive.hpp"

#include "reefgen/files.hpp"

#include <unistd.h>
#include <zlib.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <vector>

namespace reefgen::model {

namespace {

uint32_t le32(const unsigned char* p) { return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24; }
uint16_t le16(const unsigned char* p) { return uint16_t(p[0] | p[1] << 8); }
uint64_t le64(const unsigned char* p) { return uint64_t(le32(p)) | uint64_t(le32(p + 4)) << 32; }

}  // namespace

// LibTorch 1.13 neither checks the CRC-32s of its zip archives nor survives
// every corruption of their contents (a flipped byte in a type string
// segfaults its TorchScript type parser; found by tests/fuzz). So every entry
// is checked here first: stored (LibTorch never compresses), inside the file,
// and with its recorded CRC-32. Returns "" or what is wrong. Long: one
// pass over the central directory, each field checked where it is read.
std::string check_zip_integrity(const std::filesystem::path& path) {
  FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return "cannot open it";
  std::vector<unsigned char> b;
  unsigned char chunk[1 << 16];
  size_t n;
  while ((n = std::fread(chunk, 1, sizeof chunk, f)) > 0) b.insert(b.end(), chunk, chunk + n);
  std::fclose(f);
  const uint64_t size = b.size();
  if (size < 22) return "too short for a zip archive";
  // End of central directory: the last "PK\5\6" within 64 KiB + 22 of the end.
  int64_t eocd = -1;
  for (int64_t i = int64_t(size) - 22; i >= 0 && i >= int64_t(size) - 22 - 65535; --i)
    if (le32(&b[size_t(i)]) == 0x06054b50u) {
      eocd = i;
      break;
    }
  if (eocd < 0) return "no zip directory at its end (truncated?)";
  uint64_t entries = le16(&b[size_t(eocd) + 10]), cd_size = le32(&b[size_t(eocd) + 12]), cd_off = le32(&b[size_t(eocd) + 16]);
  if (entries == 0xffff || cd_off == 0xffffffffu || cd_size == 0xffffffffu) {  // zip64
    if (eocd < 20 || le32(&b[size_t(eocd) - 20]) != 0x07064b50u) return "a zip64 archive without its locator";
    const uint64_t z = le64(&b[size_t(eocd) - 12]);
    if (z + 56 > size || le32(&b[size_t(z)]) != 0x06064b50u) return "a damaged zip64 directory";
    entries = le64(&b[size_t(z) + 32]);
    cd_size = le64(&b[size_t(z) + 40]);
    cd_off = le64(&b[size_t(z) + 48]);
  }
  if (cd_off > size || cd_size > size - cd_off || entries > cd_size / 46) return "a zip directory outside the file";
  uint64_t p = cd_off;
  for (uint64_t e = 0; e < entries; ++e) {
    if (p + 46 > cd_off + cd_size || le32(&b[size_t(p)]) != 0x02014b50u) return "a damaged zip directory";
    const unsigned char* c = &b[size_t(p)];
    const uint16_t method = le16(c + 10), name_len = le16(c + 28), extra_len = le16(c + 30), comment_len = le16(c + 32);
    const uint32_t crc = le32(c + 16);
    uint64_t csize = le32(c + 20), usize = le32(c + 24), local = le32(c + 42);
    if (p + 46 + name_len + extra_len + comment_len > cd_off + cd_size) return "a damaged zip directory";
    const std::string name(reinterpret_cast<const char*>(c + 46), name_len);
    // zip64 extra field: the 0xffffffff fields, in the order usize, csize, local.
    for (uint64_t x = p + 46 + name_len; x + 4 <= p + 46 + name_len + extra_len;) {
      const uint16_t id = le16(&b[size_t(x)]), len = le16(&b[size_t(x) + 2]);
      if (x + 4 + len > p + 46 + name_len + extra_len) return "entry " + name + ": a damaged extra field";
      if (id == 0x0001) {
        uint64_t q = x + 4;
        auto next = [&](uint64_t& v) {
          if (q + 8 <= x + 4 + len) v = le64(&b[size_t(q)]), q += 8;
        };
        if (usize == 0xffffffffu) next(usize);
        if (csize == 0xffffffffu) next(csize);
        if (local == 0xffffffffu) next(local);
      }
      x += 4 + len;
    }
    if (method != 0 && method != 8) return "entry " + name + ": unknown zip compression " + std::to_string(method);
    if (method == 0 && csize != usize) return "entry " + name + ": stored sizes disagree";
    // Deflated entries (TorchScript code) are small; a claim of more is a bomb or damage.
    if (method == 8 && (usize > (64u << 20) || usize > 1032 * csize + 1024)) return "entry " + name + ": implausible size";
    if (local + 30 > size || le32(&b[size_t(local)]) != 0x04034b50u) return "entry " + name + ": damaged local header";
    const uint64_t data = local + 30 + le16(&b[size_t(local) + 26]) + le16(&b[size_t(local) + 28]);
    if (data > size || csize > size - data) return "entry " + name + " runs past the end of the file (truncated?)";
    uLong got = crc32(0L, Z_NULL, 0);
    if (method == 0) {
      for (uint64_t off = 0; off < usize;) {  // zlib's length is 32-bit
        const uInt len = uInt(std::min<uint64_t>(usize - off, 1u << 30));
        got = crc32(got, &b[size_t(data + off)], len);
        off += len;
      }
    } else {
      std::vector<unsigned char> out(size_t(usize) + 1);
      z_stream zs{};
      if (inflateInit2(&zs, -15) != Z_OK) return "zlib failed";
      zs.next_in = &b[size_t(data)];
      zs.avail_in = uInt(csize);
      zs.next_out = out.data();
      zs.avail_out = uInt(out.size());
      const int rc = inflate(&zs, Z_FINISH);
      const uint64_t produced = zs.total_out;
      inflateEnd(&zs);
      if (rc != Z_STREAM_END || produced != usize) return "entry " + name + " does not inflate to its size (damaged copy)";
      got = crc32(got, out.data(), uInt(usize));
    }
    if (uint32_t(got) != crc) return "entry " + name + " fails its CRC-32 (damaged copy)";
    p += 46 + uint64_t(name_len) + extra_len + comment_len;
  }
  return "";
}

std::string first_line(const std::string& s) { return s.substr(0, s.find('\n')); }

// LibTorch's file writer throws from its destructor when a write fails (a
// full disk): that is std::terminate. So the archive goes through a writer
// function of ours that never reports a short write to LibTorch (it would
// throw "unexpected pos" on the next record, again inside the destructor);
// it remembers the first error, stops writing, and the error is raised here,
// after LibTorch is done, with the temporary file removed.
void save_archive_atomic(torch::serialize::OutputArchive& a, const std::filesystem::path& path) {
  // The project's one temporary name (common/files.hpp): removed by a fatal
  // signal, and by remove_stale_temps after a kill -9.
  const std::filesystem::path tmp = reefgen::detail::temp_path_for(path);
  std::string failure;
  FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) failure = std::strerror(errno);
  if (f) {
    try {
      a.save_to([&](const void* data, size_t n) -> size_t {
        if (failure.empty() && n && std::fwrite(data, 1, n, f) != n)
          failure = std::strerror(errno ? errno : EIO);
        return n;
      });
    } catch (const std::exception& e) {
      if (failure.empty()) failure = first_line(e.what());
    }
    if (std::fflush(f) != 0 && failure.empty()) failure = std::strerror(errno);
    if (::fsync(::fileno(f)) != 0 && failure.empty()) failure = std::strerror(errno);
    if (std::fclose(f) != 0 && failure.empty()) failure = std::strerror(errno);
  }
  std::error_code ec;
  if (failure.empty()) {
    try {
      reefgen::detail::commit_temp(tmp, path);
    } catch (const std::exception& e) {
      failure = first_line(e.what());
    }
  }
  if (!failure.empty()) {
    std::filesystem::remove(tmp, ec);
    throw std::runtime_error(path.string() + ": cannot write (" + failure +
                             "); check free space and permissions");
  }
}

void load_archive(torch::serialize::InputArchive& a, const std::filesystem::path& path, const std::string& what,
                  const std::string& fix) {
  if (!std::filesystem::is_regular_file(path))
    throw std::runtime_error(path.string() + ": " + what + " not found; " + fix);
  if (const std::string bad = check_zip_integrity(path); !bad.empty())
    throw std::runtime_error(path.string() + ": damaged or not a LibTorch archive (" + bad + "); " + fix);
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
