#pragma once
// An 8-bit image as it travels over the link: module frames and camera captures.

#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "hw/link/link_protocol.h"

namespace parallax::hw {

// Which bytes may differ between images of one family: two images of the same `family` are
// byte for byte equal outside `spans`. Its producer knows (LivePixels: outside the scene's
// footprint every frame holds the same backdrop); the link then sends a module only these
// bytes when it shows an image of the same family (a patch frame, PROTOCOL.md).
struct ImageRegions {
  uint64_t family = 0;                               // not 0
  std::vector<std::pair<uint32_t, uint32_t>> spans;  // [begin, end) bytes, sorted, disjoint
};

struct Image {
  int width = 0, height = 0;
  PixelFormat format = PixelFormat::kRgb8;
  std::vector<uint8_t> pixels;                  // row-major, tightly packed
  std::shared_ptr<const ImageRegions> regions;  // null: any byte may differ

  size_t byteSize() const { return static_cast<size_t>(width) * height * bytesPerPixel(format); }
  bool empty() const { return pixels.empty(); }
};

// Writes an 8-bit PNG (OpenImageIO); throws std::runtime_error naming the file on failure.
void writePng(const Image& image, const std::string& path);

}  // namespace parallax::hw
