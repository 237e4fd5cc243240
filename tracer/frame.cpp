#include "tracer/frame.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "common/input_error.h"

namespace parallax {

std::uint8_t srgb8FromLinear(float linear) {
  // NaN must not reach a module: treat it as black (the integrator never makes one; this is the
  // last guard before the bytes leave).
  const float c = std::isfinite(linear) ? std::clamp(linear, 0.0f, 1.0f) : (linear > 0.0f ? 1.0f : 0.0f);
  const float encoded = c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
  return static_cast<std::uint8_t>(std::lround(encoded * 255.0f));
}

float linearFromSrgb(float encoded) {
  return encoded <= 0.04045f ? encoded / 12.92f : std::pow((encoded + 0.055f) / 1.055f, 2.4f);
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

std::string moduleFrameStem(const std::string& directory, int moduleIndex) {
  char name[32];
  std::snprintf(name, sizeof name, "module_%03d", moduleIndex);
  return (std::filesystem::path(directory) / name).string();
}

Frame readFrame(const std::string& path) {
  auto input = OIIO::ImageInput::open(path);
  if (!input) throw InputError({path, "", 0}, "cannot read the image: " + OIIO::geterror());
  const OIIO::ImageSpec& spec = input->spec();
  if (spec.width < 1 || spec.height < 1 || spec.width > 16384 || spec.height > 16384 || spec.nchannels < 1) {
    throw InputError({path, "", 0}, "unsupported image size or channel count");
  }
  std::vector<float> data(static_cast<size_t>(spec.width) * static_cast<size_t>(spec.height) *
                          static_cast<size_t>(spec.nchannels));
  if (!input->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, data.data())) {
    throw InputError({path, "", 0}, "cannot read the pixels: " + input->geterror());
  }
  const bool decode = spec.format == OIIO::TypeDesc::UINT8 || spec.format == OIIO::TypeDesc::UINT16;
  Frame frame(spec.width, spec.height);
  const size_t channels = static_cast<size_t>(spec.nchannels);
  for (size_t i = 0; i < frame.pixels.size(); ++i) {
    for (size_t c = 0; c < 3; ++c) {
      const float v = data[i * channels + std::min(c, channels - 1)];
      frame.pixels[i][static_cast<int>(c)] = decode ? linearFromSrgb(v) : v;
    }
  }
  return frame;
}

}  // namespace parallax
