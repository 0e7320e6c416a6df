#pragma once
// Deterministic randomness. Every random choice in reefgen comes from an Rng
// seeded by hash(global seed, sample index, purpose), so a sample's bytes do
// not depend on which thread made it or in what order. std:: distributions are
// avoided on purpose: their algorithms differ between standard libraries.
#include <cstdint>
#include <string_view>

namespace reefgen {

// SplitMix64 finaliser: a good 64-bit mixer (Steele et al. 2014).
constexpr uint64_t mix64(uint64_t z) {
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// FNV-1a of a purpose tag, so call sites name what a stream is for.
constexpr uint64_t hash_tag(std::string_view tag) {
  uint64_t h = 0xCBF29CE484222325ull;
  for (char c : tag) { h ^= static_cast<unsigned char>(c); h *= 0x100000001B3ull; }
  return h;
}

constexpr uint64_t derive_seed(uint64_t seed, uint64_t index, std::string_view purpose) {
  return mix64(mix64(seed ^ mix64(index + 0x632BE59BD9B4E019ull)) ^ hash_tag(purpose));
}

// xoshiro256** (Blackman & Vigna), seeded through SplitMix64.
class Rng {
 public:
  explicit Rng(uint64_t seed) {
    // SplitMix64 stream: state word i = mix64(seed + i * golden ratio).
    for (int i = 0; i < 4; ++i) s_[i] = mix64(seed + static_cast<uint64_t>(i) * 0x9E3779B97F4A7C15ull);
  }
  Rng(uint64_t seed, uint64_t index, std::string_view purpose) : Rng(derive_seed(seed, index, purpose)) {}

  uint64_t next_u64() {
    const uint64_t result = rotl(s_[1] * 5, 7) * 9;
    const uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0]; s_[3] ^= s_[1]; s_[1] ^= s_[2]; s_[0] ^= s_[3];
    s_[2] ^= t; s_[3] = rotl(s_[3], 45);
    return result;
  }
  // Uniform in [0, 1) with 53 random bits.
  double uniform() { return static_cast<double>(next_u64() >> 11) * 0x1.0p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  // Uniform integer in [lo, hi] (inclusive). Modulo bias is < 2^-40 for our ranges.
  int64_t uniform_int(int64_t lo, int64_t hi) {
    const uint64_t span = static_cast<uint64_t>(hi - lo) + 1;
    return lo + static_cast<int64_t>(next_u64() % span);
  }

 private:
  static constexpr uint64_t rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  uint64_t s_[4];
};

}  // namespace reefgen
