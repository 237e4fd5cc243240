#pragma once
// The sRGB transfer function (IEC 61966-2-1), decoding direction: one definition for the
// tracer's frames and textures and the photometric correction's tables.

#include <cmath>

namespace parallax {

// Linear light of an sRGB-encoded value in [0, 1].
inline float linearFromSrgb(float encoded) {
  return encoded <= 0.04045f ? encoded / 12.92f : std::pow((encoded + 0.055f) / 1.055f, 2.4f);
}

}  // namespace parallax
