#pragma once
// An 8-bit image as it travels over the link: module frames and camera captures.

#include <cstdint>
#include <vector>

#include "hw/link/link_protocol.h"

namespace parallax::hw {

struct Image {
  int width = 0, height = 0;
  PixelFormat format = PixelFormat::kRgb8;
  std::vector<uint8_t> pixels;  // row-major, tightly packed

  size_t byteSize() const { return static_cast<size_t>(width) * height * bytesPerPixel(format); }
  bool empty() const { return pixels.empty(); }
};

// Writes an 8-bit PNG (OpenImageIO); throws std::runtime_error naming the file on failure.
void writePng(const Image& image, const std::string& path);

}  // namespace parallax::hw
