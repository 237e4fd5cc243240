#include "tracer/texture_image.h"

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "common/check.h"
#include "tracer/frame.h"

namespace parallax {
namespace {

int wrap(int i, int n) {
  if (i >= 0 && i < n) return i;  // the common case: no division
  const int m = i % n;
  return m < 0 ? m + n : m;
}

}  // namespace

int wrapFloor(float f, int n) {
  // Within ±2^24 an int holds f exactly; beyond, reduce with fmod first.
  if (std::abs(f) < 16777216.0f) return wrap(static_cast<int>(f), n);
  return wrap(static_cast<int>(std::fmod(f, static_cast<float>(n))), n);
}

TextureImage::TextureImage(int width, int height, std::vector<float> rgb) {
  PARALLAX_CHECK(width > 0 && height > 0);
  PARALLAX_CHECK_OP(rgb.size(), ==, static_cast<size_t>(width) * static_cast<size_t>(height) * 3);
  levels_.push_back({width, height, std::move(rgb)});
  buildPyramid();
}

TextureImage TextureImage::constant(const Rgb& color) {
  return TextureImage(1, 1, {color.x(), color.y(), color.z()});
}

bool TextureImage::load(const std::string& path, bool srgb, long maxPixels, TextureImage* out,
                        std::string* error) {
  OIIO::ImageBuf source;
  const auto failed = [&](const std::string& why) {
    *error = why.empty() ? "cannot read the image" : why;
    return false;
  };
  // The header first: the size is checked before the pixels are allocated and decoded.
  if (!source.init_spec(path, 0, 0)) return failed(source.geterror());
  const OIIO::ImageSpec header = source.spec();
  if (header.width <= 0 || header.height <= 0 || header.nchannels <= 0 || header.width > 65536 ||
      header.height > 65536) {
    return failed("unsupported image size or channel count");
  }
  const long pixels = static_cast<long>(header.width) * header.height;
  if (pixels > maxPixels) {
    return failed(fmt::format(
        "{}x{} is {} pixels, more than the {} left for it (at most {} a texture file, {} all of "
        "a scene's together)",
        header.width, header.height, pixels, maxPixels, kMaxFilePixels, kMaxScenePixels));
  }
  // Only the channels used (grey, or RGB; alpha and the rest are ignored) are read.
  const int channels = header.nchannels >= 3 ? 3 : 1;
  if (!source.read(0, 0, 0, channels, true, OIIO::TypeDesc::FLOAT))
    return failed(source.geterror());
  const OIIO::ImageSpec& spec = source.spec();
  const bool decode =
      srgb && (spec.format == OIIO::TypeDesc::UINT8 || spec.format == OIIO::TypeDesc::UINT16);
  std::vector<float> rgb(static_cast<size_t>(spec.width) * static_cast<size_t>(spec.height) * 3);
  std::vector<float> pixel(static_cast<size_t>(spec.nchannels));
  size_t k = 0;
  for (int y = 0; y < spec.height; ++y) {
    for (int x = 0; x < spec.width; ++x) {
      source.getpixel(spec.x + x, spec.y + y, pixel.data(), spec.nchannels);
      for (int c = 0; c < 3; ++c) {
        // Grey (1 or 2 channels) replicates; alpha is ignored.
        const float value = pixel[static_cast<size_t>(spec.nchannels >= 3 ? c : 0)];
        const float v = std::isfinite(value) ? std::max(value, 0.0f) : 0.0f;
        rgb[k++] = decode ? linearFromSrgb(v) : v;
      }
    }
  }
  *out = TextureImage(spec.width, spec.height, std::move(rgb));
  return true;
}

void TextureImage::buildPyramid() {
  while (levels_.back().width > 1 || levels_.back().height > 1) {
    const Level& fine = levels_.back();
    Level coarse;
    coarse.width = std::max(1, fine.width / 2);
    coarse.height = std::max(1, fine.height / 2);
    OIIO::ImageSpec fineSpec(fine.width, fine.height, 3, OIIO::TypeDesc::FLOAT);
    OIIO::ImageBuf fineBuf(fineSpec, const_cast<float*>(fine.rgb.data()));
    OIIO::ImageBuf coarseBuf;
    // A box filter over each 2×2 block (the footprint a level stands for); OIIO handles odd sizes.
    OIIO::ImageBufAlgo::resize(coarseBuf, fineBuf, "box", 0.0f,
                               OIIO::ROI(0, coarse.width, 0, coarse.height, 0, 1, 0, 3));
    coarse.rgb.resize(static_cast<size_t>(coarse.width) * static_cast<size_t>(coarse.height) * 3);
    coarseBuf.get_pixels(OIIO::ROI(0, coarse.width, 0, coarse.height, 0, 1, 0, 3),
                         OIIO::TypeDesc::FLOAT, coarse.rgb.data());
    levels_.push_back(std::move(coarse));
  }
}

Rgb TextureImage::texel(int level, int x, int y) const {
  const Level& l = levels_[static_cast<size_t>(level)];
  const size_t i = (static_cast<size_t>(wrap(y, l.height)) * static_cast<size_t>(l.width) +
                    static_cast<size_t>(wrap(x, l.width))) *
                   3;
  return {l.rgb[i], l.rgb[i + 1], l.rgb[i + 2]};
}

Rgb TextureImage::bilinear(int level, float u, float v) const {
  const Level& l = levels_[static_cast<size_t>(level)];
  // uv (0,0) is the bottom-left corner; texel centres sit at half-integers.
  const float x = u * static_cast<float>(l.width) - 0.5f;
  const float y = (1.0f - v) * static_cast<float>(l.height) - 0.5f;
  const float fx = std::floor(x), fy = std::floor(y);
  const float ax = x - fx, ay = y - fy;
  // The +1 neighbours wrap with a compare instead of a second modulo.
  const int x0 = wrapFloor(fx, l.width);
  const int y0 = wrapFloor(fy, l.height);
  const int x1 = x0 + 1 == l.width ? 0 : x0 + 1;
  const int y1 = y0 + 1 == l.height ? 0 : y0 + 1;
  const size_t w = static_cast<size_t>(l.width);
  const float* row0 = l.rgb.data() + static_cast<size_t>(y0) * w * 3;
  const float* row1 = l.rgb.data() + static_cast<size_t>(y1) * w * 3;
  const Eigen::Map<const Rgb> c00(row0 + 3 * static_cast<size_t>(x0)),
      c10(row0 + 3 * static_cast<size_t>(x1));
  const Eigen::Map<const Rgb> c01(row1 + 3 * static_cast<size_t>(x0)),
      c11(row1 + 3 * static_cast<size_t>(x1));
  return (1 - ay) * ((1 - ax) * c00 + ax * c10) + ay * ((1 - ax) * c01 + ax * c11);
}

Rgb TextureImage::lookup(float u, float v, float lod) const {
  if (!std::isfinite(u) || !std::isfinite(v))
    return texel(static_cast<int>(levels_.size()) - 1, 0, 0);
  const float maxLevel = static_cast<float>(levels_.size() - 1);
  const float level = std::isfinite(lod) ? std::clamp(lod, 0.0f, maxLevel) : 0.0f;
  const int l0 = static_cast<int>(level);
  const float a = level - static_cast<float>(l0);
  if (a <= 0.0f || l0 + 1 >= static_cast<int>(levels_.size())) return bilinear(l0, u, v);
  return (1.0f - a) * bilinear(l0, u, v) + a * bilinear(l0 + 1, u, v);
}

}  // namespace parallax
