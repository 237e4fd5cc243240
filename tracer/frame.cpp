#include "tracer/frame.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>

#include "common/input_error.h"

namespace parallax {

std::uint8_t srgb8FromLinear(float linear) {
  // NaN must not reach a module: treat it as black (the integrator never makes one; this is the
  // last guard before the bytes leave).
  const float c = std::isfinite(linear) ? std::clamp(linear, 0.0f, 1.0f) : (linear > 0.0f ? 1.0f : 0.0f);
  const float encoded = c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
  return static_cast<std::uint8_t>(std::lround(encoded * 255.0f));
}

std::vector<std::uint8_t> Frame::toSrgb8() const {
  std::vector<std::uint8_t> out(pixels.size() * 3);
  for (size_t i = 0; i < pixels.size(); ++i) {
    for (int c = 0; c < 3; ++c) out[3 * i + static_cast<size_t>(c)] = srgb8FromLinear(pixels[i][c]);
  }
  return out;
}

namespace {

void writeImage(const std::string& path, const OIIO::ImageSpec& spec, const void* data) {
  auto output = OIIO::ImageOutput::create(path);
  if (!output) throw InputError({path, "", 0}, "no image writer for this file name: " + OIIO::geterror());
  if (!output->open(path, spec) || !output->write_image(spec.format, data) || !output->close()) {
    throw InputError({path, "", 0}, "cannot write the image: " + output->geterror());
  }
}

}  // namespace

void writePng(const Frame& frame, const std::string& path) {
  const std::vector<std::uint8_t> bytes = frame.toSrgb8();
  OIIO::ImageSpec spec(frame.width, frame.height, 3, OIIO::TypeDesc::UINT8);
  spec.attribute("oiio:ColorSpace", "sRGB");
  writeImage(path, spec, bytes.data());
}

void writeExr(const Frame& frame, const std::string& path) {
  std::vector<float> floats(frame.pixels.size() * 3);
  for (size_t i = 0; i < frame.pixels.size(); ++i) {
    for (int c = 0; c < 3; ++c) floats[3 * i + static_cast<size_t>(c)] = frame.pixels[i][c];
  }
  OIIO::ImageSpec spec(frame.width, frame.height, 3, OIIO::TypeDesc::FLOAT);
  spec.attribute("oiio:ColorSpace", "Linear");
  writeImage(path, spec, floats.data());
}

}  // namespace parallax
