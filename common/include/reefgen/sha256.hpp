#pragma once
// SHA-256 (FIPS 180-4), incremental. For integrity checks of shipped model
// weights and checkpoints: no OpenSSL dependency for 100 lines of maths.
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

namespace reefgen {

class Sha256 {
 public:
  Sha256();
  void update(const void* data, size_t bytes);
  void update(const std::string& s) { update(s.data(), s.size()); }
  std::string hex();  // finishes: 64 lowercase hex digits; the object is spent afterwards

 private:
  void block(const uint8_t* p);
  std::array<uint32_t, 8> h_;
  std::array<uint8_t, 64> buf_{};
  size_t used_ = 0;
  uint64_t total_ = 0;
};

std::string sha256_hex(const void* data, size_t bytes);
// The file's SHA-256, read in blocks (any size); "" when it cannot be read.
std::string sha256_of_file(const std::string& path);

}  // namespace reefgen
