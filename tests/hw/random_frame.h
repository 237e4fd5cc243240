#pragma once
// A frame of seeded random bytes: incompressible, and any corruption on the way shows.

#include <cstdint>
#include <memory>
#include <random>

#include "hw/link/image.h"

namespace parallax::hw {

inline std::shared_ptr<const Image> randomFrame(int width, int height, uint32_t seed) {
  auto f = std::make_shared<Image>();
  f->width = width;
  f->height = height;
  f->pixels.resize(f->byteSize());
  std::mt19937 rng(seed);
  for (auto& b : f->pixels) b = static_cast<uint8_t>(rng());
  return f;
}

}  // namespace parallax::hw
