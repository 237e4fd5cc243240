#pragma once
// Linear float channels to 8-bit sRGB codes, a SIMD vector at a time (Google Highway, the widest
// instruction set the CPU has, chosen at run time): what every module frame goes through before
// the link. Each lane clamps to [0, 1] (NaN to 0, as srgb8FromLinear does); its float bits'
// top bits pick a bin whose word holds the code of the bin's lowest input and where in the bin
// the next code starts. One table load (a gather) and one comparison: the bytes of
// srgb8FromLinear (frame.h) on every target.

#include <cstddef>
#include <cstdint>

namespace parallax {

struct SrgbTable {
  // An input c in [0, 1] is in bin bits(c) >> kShift.
  static constexpr int kShift = 16;
  // Per bin: the code of its lowest input << 24 | the low kShift bits of the smallest input
  // that gets the next code (2^kShift where no input of the bin does).
  const std::uint32_t* words = nullptr;
};

// out[i] = srgb8FromLinear(in[i]) for i in [0, n).
void encodeSrgbChannels(const float* in, size_t n, const SrgbTable& table, std::uint8_t* out);

}  // namespace parallax
