#pragma once
// A module frame: linear RGB floats, row-major, row 0 at the top (pixel rows as in the ray
// textures). Written as sRGB 8-bit PNG (what a module shows) or float EXR.

#include <cstdint>
#include <string>
#include <vector>

#include "calibration/display/srgb_transfer.h"  // linearFromSrgb
#include "tracer/scene.h"

namespace parallax {

struct Frame {
  int width = 0;
  int height = 0;
  std::vector<Rgb> pixels;

  Frame() = default;
  Frame(int w, int h)
      : width(w), height(h), pixels(static_cast<size_t>(w) * static_cast<size_t>(h), Rgb::Zero()) {}
  Rgb& at(int column, int row) {
    return pixels[static_cast<size_t>(row) * static_cast<size_t>(width) +
                  static_cast<size_t>(column)];
  }
  const Rgb& at(int column, int row) const {
    return pixels[static_cast<size_t>(row) * static_cast<size_t>(width) +
                  static_cast<size_t>(column)];
  }

  // sRGB-encoded, clamped to [0, 1], rounded: RGB RGB ... row-major.
  std::vector<std::uint8_t> toSrgb8() const;
};

// The bytes toSrgb8 gives `count` pixels (3 a pixel into `out`): a part of a frame.
void encodeSrgb8(const Rgb* pixels, size_t count, std::uint8_t* out);

std::uint8_t srgb8FromLinear(float linear);

// What a module shows of 8-bit sRGB bytes (RGB RGB ..., row-major), back in linear light.
// Throws std::invalid_argument when the byte count is not width × height × 3.
Frame frameFromSrgb8(int width, int height, const std::vector<std::uint8_t>& rgb);

// Both throw InputError naming the file when it cannot be written.
void writePng(const Frame& frame, const std::string& path);
void writeExr(const Frame& frame, const std::string& path);
// Where a module's frame lives in a frames folder, without extension: DIR/module_NNN (NNN the
// module index). `render` writes there and `view` reads from there.
std::string moduleFrameStem(const std::string& directory, int moduleIndex);

// Reads a frame back: 8/16-bit files are sRGB-decoded, float files taken as linear; grey and
// RGBA files are reduced to RGB. Throws InputError naming the file.
Frame readFrame(const std::string& path);

}  // namespace parallax
