#include "tracer/frame.h"

#include <OpenImageIO/imageio.h>
#include <immintrin.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <stdexcept>

#include "common/image_completeness.h"
#include "common/input_error.h"
#include "common/regular_file.h"

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
// daemon's frame time. `code[i]` is the exact code of i/4095; between those points the code can
// differ by at most one (the curve's steepest slope, 12.92 · 255 codes per unit, is 0.8 codes a
// step), which one comparison with each neighbouring code's lower bound corrects. So the result
// equals srgb8FromLinear bit for bit (the test sweeps it), at a lookup and two compares.
struct SrgbEncoder {
  static constexpr int kSteps = 4095;
  std::array<std::uint8_t, kSteps + 1> code{};
  // lowest[k]: the smallest float in [0, 1] that srgb8FromLinear maps to k or above (−inf for
  // k = 0, +inf for k = 256), found by bisection over the float bit patterns (monotonic).
  std::array<float, 257> lowest{};

  SrgbEncoder() {
    for (int i = 0; i <= kSteps; ++i)
      code[static_cast<size_t>(i)] = srgb8FromLinear(static_cast<float>(i) / kSteps);
    lowest[0] = -std::numeric_limits<float>::infinity();
    lowest[256] = std::numeric_limits<float>::infinity();
    for (int k = 1; k < 256; ++k) {
      std::uint32_t lo = 0,
                    hi = std::bit_cast<std::uint32_t>(1.0f);  // srgb8FromLinear(1) = 255 >= k
      while (lo < hi) {
        const std::uint32_t mid = lo + (hi - lo) / 2;
        if (srgb8FromLinear(std::bit_cast<float>(mid)) >= k)
          hi = mid;
        else
          lo = mid + 1;
      }
      lowest[static_cast<size_t>(k)] = std::bit_cast<float>(lo);
    }
  }

  // n ≤ kBlock channels. Clamping and scaling run over the block first, four at a time, the
  // table lookups after.
  static constexpr size_t kBlock = 256;
  void encode(const float* in, size_t n, std::uint8_t* out) const {
    alignas(64) float clamped[kBlock];
    alignas(64) int index[kBlock];
    // NaN and −inf to 0, +inf to 1, as srgb8FromLinear does: maxps returns its second operand
    // when either is NaN. (Written with SSE2, x86-64's baseline: GCC at -O2 turned the scalar
    // min/max into branches, which random data mispredicts.)
    const __m128 zero = _mm_setzero_ps(), one = _mm_set1_ps(1.0f), steps = _mm_set1_ps(kSteps),
                 half = _mm_set1_ps(0.5f);
    size_t i = 0;
    for (; i + 4 <= n; i += 4) {
      const __m128 c = _mm_min_ps(_mm_max_ps(_mm_loadu_ps(in + i), zero), one);
      _mm_store_ps(clamped + i, c);
      _mm_store_si128(reinterpret_cast<__m128i*>(index + i),
                      _mm_cvttps_epi32(_mm_add_ps(_mm_mul_ps(c, steps), half)));
    }
    for (; i < n; ++i) {
      const __m128 c = _mm_min_ss(_mm_max_ss(_mm_load_ss(in + i), zero), one);
      clamped[i] = _mm_cvtss_f32(c);
      index[i] = _mm_cvttss_si32(_mm_add_ss(_mm_mul_ss(c, steps), half));
    }
    for (size_t j = 0; j < n; ++j) {
      const float c = clamped[j];
      int k = code[static_cast<unsigned>(index[j])];
      k += c >= lowest[static_cast<size_t>(k) + 1];
      k -= c < lowest[static_cast<size_t>(k)];
      out[j] = static_cast<std::uint8_t>(k);
    }
  }
};

const SrgbEncoder& srgbEncoder() {
  static const SrgbEncoder encoder;
  return encoder;
}

}  // namespace

std::vector<std::uint8_t> Frame::toSrgb8() const {
  const SrgbEncoder& encode = srgbEncoder();
  std::vector<std::uint8_t> out(pixels.size() * 3);
  static_assert(sizeof(Rgb) == 3 * sizeof(float), "Rgb must be 3 packed floats");
  const float* in = pixels.empty() ? nullptr : pixels.front().data();
  // Raw pointers: a byte store may alias anything, so through `out` the compiler would reload
  // its data pointer and size after every store.
  std::uint8_t* bytes = out.data();
  const size_t n = out.size();
  for (size_t i = 0; i < n; i += SrgbEncoder::kBlock) {
    encode.encode(in + i, std::min(SrgbEncoder::kBlock, n - i), bytes + i);
  }
  return out;
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
