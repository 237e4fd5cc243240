// The photometric encode (tracer/module_encoder.h): its fast path gives exactly the bytes of
// the definition (nearest code in light after matrix, lift, gain and black), an identity
// correction with an sRGB response gives Frame::toSrgb8's bytes, and the gain map brightens
// exactly where it says.

#include "tracer/module_encoder.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace parallax {
namespace {

Frame randomFrame(int width, int height, std::uint32_t seed) {
  Frame frame(width, height);
  std::mt19937 random(seed);
  std::uniform_real_distribution<float> value(-0.1f, 1.3f);
  std::uniform_real_distribution<float> dark(0.0f, 0.002f);
  for (size_t i = 0; i < frame.pixels.size(); ++i) {
    // A tenth of the pixels near black, where a gamma curve's codes crowd.
    frame.pixels[i] = i % 10 == 0 ? Rgb(dark(random), dark(random), dark(random))
                                  : Rgb(value(random), value(random), value(random));
  }
  frame.pixels[0] = Rgb(std::numeric_limits<float>::quiet_NaN(), 0.5f, 0.5f);
  frame.pixels[1] = Rgb(std::numeric_limits<float>::infinity(), 0.0f, 0.0f);
  return frame;
}

ModuleColourCorrection exampleCorrection(float gamma) {
  ModuleColourCorrection c;
  c.driveFromContent << 0.82f, 0.07f, -0.03f, 0.04f, 0.71f, 0.05f, -0.02f, 0.09f, 0.88f;
  c.lift = Eigen::Vector3f(0.003f, 0.006f, 0.002f);
  c.blackDrive = Eigen::Vector3f(0.001f, 0.004f, 0.002f);
  c.gainWidth = 7;
  c.gainHeight = 5;
  c.gain.clear();
  for (int j = 0; j < 5; ++j)
    for (int i = 0; i < 7; ++i) c.gain.push_back(1.0f + 0.05f * static_cast<float>(i + 2 * j));
  for (int ch = 0; ch < 3; ++ch) {
    auto& r = c.response[static_cast<size_t>(ch)];
    for (int k = 0; k < 256; ++k)
      r[static_cast<size_t>(k)] = std::pow(k / 255.0f, gamma + 0.2f * static_cast<float>(ch));
    r[255] = 1.0f;
  }
  return c;
}

TEST(ModuleEncoder, FastPathGivesTheDefinitionsBytes) {
  for (float gamma : {1.8f, 2.2f, 2.6f})
    for (bool avx2 : {false, true}) {
      // An odd width: the SIMD blocks end in a scalar tail on every row.
      const Frame frame = randomFrame(203, 37, 11);
      const ModuleEncoder encoder(exampleCorrection(gamma), frame.width, frame.height, avx2);
      const std::vector<std::uint8_t> fast = encoder.encode(frame),
                                      slow = encoder.encodeReference(frame);
      ASSERT_EQ(fast.size(), slow.size());
      size_t differing = 0;
      for (size_t i = 0; i < fast.size(); ++i) differing += fast[i] != slow[i];
      EXPECT_EQ(differing, 0u) << "gamma " << gamma << (avx2 ? " (AVX2)" : " (SSE2)");
    }
}

TEST(ModuleEncoder, IdentityCorrectionIsTheSrgbEncode) {
  const Frame frame = randomFrame(128, 16, 3);
  const ModuleEncoder encoder(ModuleColourCorrection::srgbIdentity(), frame.width, frame.height);
  const std::vector<std::uint8_t> got = encoder.encode(frame), want = frame.toSrgb8();
  size_t differing = 0;
  for (size_t i = 0; i < got.size(); ++i) differing += got[i] != want[i];
  // toSrgb8 rounds in the encoded domain, the encoder to the nearest code in light: the two
  // part only right at a code boundary.
  EXPECT_LE(differing, got.size() / 200);
}

TEST(ModuleEncoder, GainMapBrightensWhereItSays) {
  ModuleColourCorrection c = ModuleColourCorrection::srgbIdentity();
  c.gainWidth = 2;
  c.gainHeight = 1;
  c.gain = {1.0f, 2.0f};  // the right edge twice the left
  Frame frame(64, 2);
  for (Rgb& p : frame.pixels) p = Rgb(0.25f, 0.25f, 0.25f);
  const ModuleEncoder encoder(c, frame.width, frame.height);
  const std::vector<std::uint8_t> bytes = encoder.encode(frame);
  const float left = linearFromSrgb(bytes[0] / 255.0f);
  const float right = linearFromSrgb(bytes[3 * 63] / 255.0f);
  const float middle = linearFromSrgb(bytes[3 * 32] / 255.0f);
  EXPECT_NEAR(left, 0.25f, 0.01f);
  EXPECT_NEAR(right, 0.5f, 0.01f);
  EXPECT_NEAR(middle, 0.25f * (1.0f + 32.0f / 63.0f), 0.01f);
}

// The daemon's views of a corrected module: decoding the bytes gives the content back, within
// what 8-bit codes resolve (content the drive clamps, below 0 or above full, is left out).
TEST(ModuleEncoder, DecodeGivesTheContentBack) {
  const ModuleEncoder encoder(exampleCorrection(2.2f), 64, 48);
  Frame frame(64, 48);
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 64; ++x)
      frame.at(x, y) = Rgb(0.1f + 0.4f * x / 64.0f, 0.2f + 0.3f * y / 48.0f, 0.35f);
  const Frame back = encoder.decode(encoder.encode(frame));
  double worst = 0.0;
  for (size_t i = 0; i < frame.pixels.size(); ++i)
    worst = std::max(worst, static_cast<double>((back.pixels[i] - frame.pixels[i])
                                                    .cwiseAbs()
                                                    .cwiseQuotient(frame.pixels[i])
                                                    .maxCoeff()));
  // A code step is ~2% of the light at these levels on a gamma 2.2–2.6 curve; half a step each
  // way, mixed by the matrix.
  EXPECT_LT(worst, 0.03);
  // The identity correction decodes as an sRGB module: Frame's own decode.
  const ModuleEncoder identity(ModuleColourCorrection::srgbIdentity(), 64, 48);
  const std::vector<std::uint8_t> bytes = frame.toSrgb8();
  const Frame plain = frameFromSrgb8(64, 48, bytes), decoded = identity.decode(bytes);
  for (size_t i = 0; i < frame.pixels.size(); ++i)
    ASSERT_TRUE(decoded.pixels[i].isApprox(plain.pixels[i], 1e-5f)) << i;
}

TEST(ModuleEncoder, RefusesAMalformedCorrection) {
  ModuleColourCorrection c = ModuleColourCorrection::srgbIdentity();
  c.response[1][100] = 0.9f;  // decreasing afterwards
  EXPECT_THROW(ModuleEncoder(c, 8, 8), std::exception);
  c = ModuleColourCorrection::srgbIdentity();
  c.gain = {0.5f};
  EXPECT_THROW(ModuleEncoder(c, 8, 8), std::exception);
}

}  // namespace
}  // namespace parallax
