#include "hw/link/content_hash.h"

#include <cstring>

namespace parallax::hw {
namespace {

constexpr uint64_t kPrime1 = 0x9E3779B185EBCA87ull;
constexpr uint64_t kPrime2 = 0xC2B2AE3D27D4EB4Full;
constexpr uint64_t kPrime3 = 0x165667B19E3779F9ull;
constexpr uint64_t kPrime4 = 0x85EBCA77C2B2AE63ull;

uint64_t rotl(uint64_t x, int r) { return (x << r) | (x >> (64 - r)); }

// One lane step: mixes a word in so that every input bit reaches the high bits.
uint64_t lane(uint64_t acc, uint64_t word) { return rotl(acc + word * kPrime2, 31) * kPrime1; }

uint64_t avalanche(uint64_t h) {
  h ^= h >> 33;
  h *= kPrime2;
  h ^= h >> 29;
  h *= kPrime3;
  h ^= h >> 32;
  return h;
}

}  // namespace

uint64_t contentHash64(const void* data, size_t size) {
  const auto* p = static_cast<const uint8_t*>(data);
  size_t n = size;
  uint64_t a = kPrime1 + kPrime2, b = kPrime2, c = 0, d = 0 - kPrime1;
  while (n >= 32) {
    uint64_t w[4];
    std::memcpy(w, p, 32);
    a = lane(a, w[0]);
    b = lane(b, w[1]);
    c = lane(c, w[2]);
    d = lane(d, w[3]);
    p += 32;
    n -= 32;
  }
  uint64_t h = rotl(a, 1) + rotl(b, 7) + rotl(c, 12) + rotl(d, 18) + size * kPrime4;
  while (n >= 8) {
    uint64_t w;
    std::memcpy(&w, p, 8);
    h = rotl(h ^ lane(0, w), 27) * kPrime1 + kPrime4;
    p += 8;
    n -= 8;
  }
  while (n--) h = rotl(h ^ (*p++ * kPrime3), 11) * kPrime1;
  return avalanche(h);
}

}  // namespace parallax::hw
