#pragma once
// Linear float channels to 8-bit sRGB codes, a SIMD vector at a time (Google Highway, the widest
// instruction set the CPU has, chosen at run time): what every module frame goes through before
// the link. Each lane clamps to [0, 1] (NaN to 0, as srgb8FromLinear does) and rounds to the
// nearest of `steps` + 1 evenly spaced points: a bin, all of whose inputs map to one code or,
// above the bin's step, to the next (the curve climbs less than one code a bin). Two table
// loads (gathers) and one comparison: the bytes of srgb8FromLinear (frame.h) on every target.

#include <cstddef>
#include <cstdint>

namespace parallax {

struct SrgbTable {
  int steps = 0;
  // Per bin i (inputs c with trunc(c · steps + 0.5) = i): the code of its lowest input, and the
  // smallest input that gets the next code (+inf where none in the bin does).
  const std::int32_t* code = nullptr;
  const float* step = nullptr;
};

// out[i] = srgb8FromLinear(in[i]) for i in [0, n).
void encodeSrgbChannels(const float* in, size_t n, const SrgbTable& table, std::uint8_t* out);

}  // namespace parallax
