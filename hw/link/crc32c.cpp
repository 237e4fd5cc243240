#include "hw/link/crc32c.h"

#include <array>
#include <cstring>

#if defined(__x86_64__)
#include <nmmintrin.h>
#endif

namespace parallax::hw {
namespace {

constexpr uint32_t kPolynomial = 0x82F63B78u;  // reflected Castagnoli

constexpr std::array<uint32_t, 256> makeTable() {
  std::array<uint32_t, 256> table{};
  for (uint32_t i = 0; i < 256; ++i) {
    uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1u) ? (c >> 1) ^ kPolynomial : c >> 1;
    table[i] = c;
  }
  return table;
}
constexpr std::array<uint32_t, 256> kTable = makeTable();

// Polynomial arithmetic modulo P in the reflected representation: bit 31 is x^0.
// a·b mod P, shifting b by x for every bit of a.
uint32_t multiplyModP(uint32_t a, uint32_t b) {
  uint32_t product = 0;
  for (uint32_t m = 1u << 31; m != 0; m >>= 1) {
    if (a & m) {
      product ^= b;
      if ((a & (m - 1)) == 0) break;
    }
    b = (b & 1u) ? (b >> 1) ^ kPolynomial : b >> 1;
  }
  return product;
}

// x^(2^k) mod P for k = 0..63, by repeated squaring of x.
std::array<uint32_t, 64> makePowers() {
  std::array<uint32_t, 64> powers{};
  powers[0] = 1u << 30;  // x^1
  for (int k = 1; k < 64; ++k) powers[k] = multiplyModP(powers[k - 1], powers[k - 1]);
  return powers;
}
const std::array<uint32_t, 64> kPowers = makePowers();

// x^(8·bytes) mod P: the operator that appends `bytes` zero bytes to a raw CRC register.
uint32_t shiftOperator(uint64_t bytes) {
  uint32_t p = 1u << 31;  // x^0
  for (int k = 3; bytes != 0; bytes >>= 1, ++k) {
    if (bytes & 1u) p = multiplyModP(kPowers[k & 63], p);
  }
  return p;
}

uint32_t updatePortable(uint32_t reg, const uint8_t* p, size_t n) {
  while (n--) reg = kTable[(reg ^ *p++) & 0xFFu] ^ (reg >> 8);
  return reg;
}

#if defined(__x86_64__)
// Three independent lanes hide the 3-cycle latency of the crc32 instruction; the lanes of
// each block are merged with the shift operator (raw registers: merged = shift(a)·x^8L ^ b).
constexpr size_t kLaneBytes = 8192;

__attribute__((target("sse4.2"))) uint32_t updateHardware(uint32_t reg, const uint8_t* p,
                                                          size_t n) {
  static const uint32_t kLaneShift = shiftOperator(kLaneBytes);
  uint64_t c0 = reg;
  while (n >= 3 * kLaneBytes) {
    uint64_t c1 = 0, c2 = 0;
    const uint8_t* p1 = p + kLaneBytes;
    const uint8_t* p2 = p + 2 * kLaneBytes;
    for (size_t i = 0; i < kLaneBytes; i += 8) {
      uint64_t v0, v1, v2;
      std::memcpy(&v0, p + i, 8);
      std::memcpy(&v1, p1 + i, 8);
      std::memcpy(&v2, p2 + i, 8);
      c0 = _mm_crc32_u64(c0, v0);
      c1 = _mm_crc32_u64(c1, v1);
      c2 = _mm_crc32_u64(c2, v2);
    }
    uint32_t merged =
        multiplyModP(kLaneShift, static_cast<uint32_t>(c0)) ^ static_cast<uint32_t>(c1);
    merged = multiplyModP(kLaneShift, merged) ^ static_cast<uint32_t>(c2);
    c0 = merged;
    p += 3 * kLaneBytes;
    n -= 3 * kLaneBytes;
  }
  while (n >= 8) {
    uint64_t v;
    std::memcpy(&v, p, 8);
    c0 = _mm_crc32_u64(c0, v);
    p += 8;
    n -= 8;
  }
  uint32_t c = static_cast<uint32_t>(c0);
  while (n--) c = _mm_crc32_u8(c, *p++);
  return c;
}

bool hasHardwareCrc() {
  static const bool has = __builtin_cpu_supports("sse4.2");
  return has;
}
#endif

}  // namespace

uint32_t crc32cPortable(const void* data, size_t size, uint32_t previous) {
  return ~updatePortable(~previous, static_cast<const uint8_t*>(data), size);
}

uint32_t crc32c(const void* data, size_t size, uint32_t previous) {
#if defined(__x86_64__)
  if (hasHardwareCrc()) return ~updateHardware(~previous, static_cast<const uint8_t*>(data), size);
#endif
  return crc32cPortable(data, size, previous);
}

uint32_t crc32cCombine(uint32_t crcA, uint32_t crcB, uint64_t sizeB) {
  // The init/final XORs cancel out: crc(a||b) = crc(a)·x^(8|b|) ^ crc(b) (as zlib's combine).
  return multiplyModP(shiftOperator(sizeB), crcA) ^ crcB;
}

}  // namespace parallax::hw
