// Frame::toSrgb8 encodes through a table; it must give exactly the bytes of the formula
// (srgb8FromLinear) for every input a frame can hold, out-of-range and NaN included.

#include "tracer/frame.h"

#include <gtest/gtest.h>

#include <bit>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <vector>

namespace parallax {
namespace {

// Encodes `values` (packed three to a pixel) and compares every byte with the formula.
void expectEncodedExactly(const std::vector<float>& values) {
  std::vector<float> padded = values;
  while (padded.size() % 3 != 0) padded.push_back(0.0f);
  Frame frame(static_cast<int>(padded.size() / 3), 1);
  for (size_t i = 0; i < padded.size(); ++i)
    frame.pixels[i / 3][static_cast<int>(i % 3)] = padded[i];
  const std::vector<std::uint8_t> bytes = frame.toSrgb8();
  ASSERT_EQ(bytes.size(), padded.size());
  int mismatches = 0;
  for (size_t i = 0; i < padded.size(); ++i) {
    if (bytes[i] != srgb8FromLinear(padded[i]) && ++mismatches <= 5) {
      ADD_FAILURE() << "linear " << padded[i] << " (bits 0x" << std::hex
                    << std::bit_cast<std::uint32_t>(padded[i]) << std::dec << "): table "
                    << int{bytes[i]} << ", formula " << int{srgb8FromLinear(padded[i])};
    }
  }
  EXPECT_EQ(mismatches, 0);
}

TEST(FrameEncode, SpecialValuesClampLikeTheFormula) {
  const float inf = std::numeric_limits<float>::infinity();
  const std::vector<float> values = {0.0f,
                                     -0.0f,
                                     1.0f,
                                     -1.0f,
                                     2.0f,
                                     1e30f,
                                     -1e30f,
                                     inf,
                                     -inf,
                                     std::numeric_limits<float>::quiet_NaN(),
                                     -std::numeric_limits<float>::quiet_NaN(),
                                     std::numeric_limits<float>::denorm_min(),
                                     std::numeric_limits<float>::min(),
                                     0.0031308f,
                                     std::nextafter(1.0f, 0.0f),
                                     std::nextafter(1.0f, 2.0f)};
  expectEncodedExactly(values);
  Frame frame(4, 1);
  frame.pixels = {Rgb(0.0f, 1.0f, std::numeric_limits<float>::quiet_NaN()), Rgb(-1.0f, 2.0f, inf),
                  Rgb(-inf, 0.5f, 0.0031308f), Rgb(0.2159f, 0.0f, 0.0f)};
  const std::vector<std::uint8_t> bytes = frame.toSrgb8();
  // What a user sees: black below 0 and for NaN, white above 1, mid grey (128) for linear 0.2159.
  EXPECT_EQ(bytes, (std::vector<std::uint8_t>{0, 255, 0, 0, 255, 255, 0, 188, 10, 128, 0, 0}));
}

TEST(FrameEncode, DenseSweepMatchesTheFormula) {
  std::vector<float> values;
  // Every 61st float from 0 to just past 1 (17 M values, all exponents down to denormals)...
  for (std::uint32_t bits = 0; bits <= std::bit_cast<std::uint32_t>(1.0f) + 100; bits += 61) {
    values.push_back(std::bit_cast<float>(bits));
  }
  // ... and, around every code boundary, the 64 floats on either side, where a table could
  // round the wrong way.
  for (std::uint32_t bits = std::bit_cast<std::uint32_t>(1e-5f);
       bits < std::bit_cast<std::uint32_t>(1.0f);) {
    const std::uint8_t code = srgb8FromLinear(std::bit_cast<float>(bits));
    std::uint32_t step = 1u << 14;
    while (step > 1 && srgb8FromLinear(std::bit_cast<float>(bits + step)) != code) step /= 2;
    if (step > 1) {
      bits += step;
      continue;
    }
    for (std::uint32_t b = bits - 64; b <= bits + 64; ++b)
      values.push_back(std::bit_cast<float>(b));
    bits += 1;
  }
  // Negative inputs: a sweep of them too.
  for (std::uint32_t bits = std::bit_cast<std::uint32_t>(-0.0f);
       bits <= std::bit_cast<std::uint32_t>(-2.0f); bits += 1000003) {
    values.push_back(std::bit_cast<float>(bits));
  }
  expectEncodedExactly(values);
}

// What a module shows comes back to linear light (observer views of the daemon's frames): every
// code decodes to a value that encodes to the same code, and a wrong byte count is refused.
TEST(FrameDecode, EveryCodeRoundTripsThroughLinearLight) {
  std::vector<std::uint8_t> codes(256 * 3);
  for (size_t i = 0; i < codes.size(); ++i)
    codes[i] = static_cast<std::uint8_t>((i * 7 + i / 3) % 256);
  const Frame frame = frameFromSrgb8(256, 1, codes);
  EXPECT_EQ(frame.toSrgb8(), codes);
  EXPECT_FLOAT_EQ(frameFromSrgb8(1, 1, {0, 255, 0}).pixels[0][1], 1.0f);
  EXPECT_THROW(frameFromSrgb8(2, 2, codes), std::invalid_argument);
}

}  // namespace
}  // namespace parallax
