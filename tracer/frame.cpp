#include "tracer/frame.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <stdexcept>

#include "common/check.h"
#include "common/image_completeness.h"
#include "common/input_error.h"
#include "common/regular_file.h"
#include "tracer/srgb_encode_kernel.h"

namespace parallax {

std::uint8_t srgb8FromLinear(float linear) {
  // NaN must not reach a module: treat it as black (the integrator never makes one; this is the
  // last guard before the bytes leave).
  const float c =
      std::isfinite(linear) ? std::clamp(linear, 0.0f, 1.0f) : (linear > 0.0f ? 1.0f : 0.0f);
  const float encoded = c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
  return static_cast<std::uint8_t>(std::lround(encoded * 255.0f));
}

Frame frameFromSrgb8(int width, int height, const std::vector<std::uint8_t>& rgb) {
  if (width < 0 || height < 0 ||
      rgb.size() != static_cast<size_t>(width) * static_cast<size_t>(height) * 3) {
    throw std::invalid_argument("frameFromSrgb8: byte count is not width x height x 3");
  }
  static const std::array<float, 256> kLinear = [] {
    std::array<float, 256> table{};
    for (int i = 0; i < 256; ++i)
      table[static_cast<size_t>(i)] = linearFromSrgb(static_cast<float>(i) / 255.0f);
    return table;
  }();
  Frame frame(width, height);
  for (size_t i = 0; i < frame.pixels.size(); ++i) {
    frame.pixels[i] = Rgb(kLinear[rgb[3 * i]], kLinear[rgb[3 * i + 1]], kLinear[rgb[3 * i + 2]]);
  }
  return frame;
}

namespace {

// srgb8FromLinear by table: the exact formula's pow costs ~10 ns a channel, a third of the
// daemon's frame time. An input in [0, 1] falls in the bin of its float bit pattern's top bits
// (bits >> kShift: 16257 bins, each 2^16 consecutive floats). Over a bin the code rises by at
// most one (the codes are never closer than 2^16 floats: checked below; 2^17 fails above 0.5), so a
// bin holds one code or two: the code of its lowest input, and the next code from the step input
// on. Both are exact (the formula at the bin's lowest input, and the smallest input the formula
// maps to the next code, found by bisection over the float bit patterns: the formula is monotonic),
// so the result equals srgb8FromLinear bit for bit (the tests sweep it). One 32-bit word a bin
// holds both, the code in the top byte and the step input's low kShift bits below it (2^kShift,
// never reached, where the bin has no step): one lookup (a vector gather) and one compare, done
// a SIMD vector at a time (srgb_encode_kernel.h).
struct SrgbEncoder {
  static constexpr int kShift = SrgbTable::kShift;
  static constexpr std::uint32_t kLowBits = (1u << kShift) - 1;
  static constexpr int kBins = static_cast<int>(std::bit_cast<std::uint32_t>(1.0f) >> kShift) + 1;
  std::array<std::uint32_t, kBins> words{};

  SrgbEncoder() {
    // The smallest float in [0, 1] for which `reaches` holds (it is monotonic in the input).
    auto smallest = [](auto reaches) {
      std::uint32_t lo = 0, hi = std::bit_cast<std::uint32_t>(1.0f);
      while (lo < hi) {
        const std::uint32_t mid = lo + (hi - lo) / 2;
        if (reaches(std::bit_cast<float>(mid)))
          hi = mid;
        else
          lo = mid + 1;
      }
      return lo;
    };
    // lowest[k]: the bits of the smallest input the formula maps to k or above (k = 1..255).
    std::array<std::uint32_t, 256> lowest{};
    for (int k = 1; k < 256; ++k)
      lowest[static_cast<size_t>(k)] = smallest([&](float c) { return srgb8FromLinear(c) >= k; });
    for (int i = 0; i < kBins; ++i) {
      const auto first = static_cast<std::uint32_t>(i) << kShift;
      const std::uint32_t last = std::min(first | kLowBits, std::bit_cast<std::uint32_t>(1.0f));
      const int k = srgb8FromLinear(std::bit_cast<float>(first));
      // The bin's last input is at most one code higher: two codes cover the bin.
      const int top = srgb8FromLinear(std::bit_cast<float>(last));
      PARALLAX_CHECK_OP(top - k, <=, 1);
      if (top > k)
        PARALLAX_CHECK_OP(lowest[static_cast<size_t>(top)] >> kShift, ==,
                          static_cast<std::uint32_t>(i));
      const std::uint32_t step =
          top > k ? lowest[static_cast<size_t>(top)] & kLowBits : kLowBits + 1;
      words[static_cast<size_t>(i)] = static_cast<std::uint32_t>(k) << 24 | step;
    }
  }

  SrgbTable table() const { return {words.data()}; }
};

const SrgbEncoder& srgbEncoder() {
  static const SrgbEncoder encoder;
  return encoder;
}

}  // namespace

std::vector<std::uint8_t> Frame::toSrgb8() const {
  std::vector<std::uint8_t> out(pixels.size() * 3);
  if (!pixels.empty()) encodeSrgb8(pixels.data(), pixels.size(), out.data());
  return out;
}

void encodeSrgb8(const Rgb* pixels, size_t count, std::uint8_t* out) {
  static_assert(sizeof(Rgb) == 3 * sizeof(float), "Rgb must be 3 packed floats");
  if (count > 0) encodeSrgbChannels(pixels->data(), 3 * count, srgbEncoder().table(), out);
}

namespace {

void writeImage(const std::string& path, const OIIO::ImageSpec& spec, const void* data) {
  auto output = OIIO::ImageOutput::create(path);
  if (!output)
    throw InputError({path, "", 0}, "no image writer for this file name: " + OIIO::geterror());
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

// Larger than any frame we write (16-bit 8K RGBA is 256 MiB raw); the cap keeps a hostile path
// such as a huge file from being read whole.
constexpr size_t kMaxFrameFileBytes = size_t{512} << 20;

Frame readFrame(const std::string& path) {
  // Checked whole first: a truncated file is one clear line instead of libpng's own noise.
  requireCompleteImage(path, readRegularFile(path, kMaxFrameFileBytes));
  auto input = OIIO::ImageInput::open(path);
  if (!input) throw InputError({path, "", 0}, "cannot read the image: " + OIIO::geterror());
  const OIIO::ImageSpec& spec = input->spec();
  if (spec.width < 1 || spec.height < 1 || spec.width > 16384 || spec.height > 16384 ||
      spec.nchannels < 1) {
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
