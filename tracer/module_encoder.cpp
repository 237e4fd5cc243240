#include "tracer/module_encoder.h"

#include <immintrin.h>

#include <Eigen/LU>
#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

#include "common/check.h"

namespace parallax {
namespace {

// Drives below 2^−24 of full scale are black on any response a module has (a gamma 2.6 curve's
// first code is ~5·10^−7).
constexpr float kMinDrive = 0x1.0p-24f;
constexpr int kBlock = 64;  // pixels per SIMD pass (a multiple of 8)

std::uint32_t bitsOf(float f) { return std::bit_cast<std::uint32_t>(f); }

}  // namespace

ModuleEncoder::ModuleEncoder(const ModuleColourCorrection& correction, int width, int height,
                             bool allowAvx2)
    : correction_(correction), width_(width), height_(height), useAvx2_(allowAvx2) {
  correction_.validate();
  PARALLAX_CHECK(width > 0 && height > 0);
  // A singular matrix has no content to go back to: decode shows black there (the fit never
  // gives one; a hand-made file might).
  const Eigen::FullPivLU<Eigen::Matrix3f> lu(correction_.driveFromContent);
  contentFromDrive_ = lu.isInvertible() ? Eigen::Matrix3f(lu.inverse()) : Eigen::Matrix3f::Zero();
  // Nearest code in light: code k wins from halfway between its light and the previous code's.
  thresholds_.assign(3 * kStride, std::numeric_limits<float>::infinity());
  for (int c = 0; c < 3; ++c) {
    const auto& r = correction_.response[static_cast<size_t>(c)];
    float* t = thresholds_.data() + c * kStride;
    t[0] = -std::numeric_limits<float>::infinity();
    for (int k = 1; k < 256; ++k) {
      t[k] = 0.5f * (r[static_cast<size_t>(k) - 1] + r[static_cast<size_t>(k)]);
    }
  }
  // The coarsest bins (8 mantissa bits, 0.4% of the drive) that hold at most one distinct
  // threshold each, so one comparison finds the code; a response with codes closer than
  // 2^−11 of their light gets the finest and may then round to a neighbour that close.
  auto binsHoldOneThreshold = [&](int shift) {
    for (int c = 0; c < 3; ++c) {
      const float* t = thresholds_.data() + c * kStride;
      for (int k = 2; k < 256; ++k) {
        if (t[k] != t[k - 1] && t[k - 1] >= kMinDrive &&
            (bitsOf(t[k]) >> shift) == (bitsOf(t[k - 1]) >> shift)) {
          return false;
        }
      }
    }
    return true;
  };
  interpolateGainRows();
  shift_ = 15;
  while (shift_ > 12 && !binsHoldOneThreshold(shift_)) --shift_;
  const std::uint32_t first = bitsOf(kMinDrive) >> shift_, last = bitsOf(1.0f) >> shift_;
  binCount_ = static_cast<int>(last - first) + 1;
  codes_.resize(3 * static_cast<size_t>(binCount_));
  for (int c = 0; c < 3; ++c) {
    const float* t = thresholds_.data() + c * kStride;
    for (int b = 0; b < binCount_; ++b) {
      const float lowest = std::bit_cast<float>((first + static_cast<std::uint32_t>(b)) << shift_);
      const int code = static_cast<int>(std::upper_bound(t + 1, t + 256, lowest) - (t + 1));
      codes_[static_cast<size_t>(c) * static_cast<size_t>(binCount_) + static_cast<size_t>(b)] =
          static_cast<std::uint8_t>(code);
    }
  }
  // Once here, not per row: a frame rendered in tiles encodes a row a tile.
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) kernel_.matrix[r][c] = correction_.driveFromContent(r, c);
    kernel_.lift[r] = correction_.lift[r];
    kernel_.black[r] = correction_.blackDrive[r];
    // Each channel's table starts binCount_ entries after the previous one's; the first bin is
    // the smallest drive kept.
    kernel_.binBase[r] = r * binCount_ - static_cast<int>(bitsOf(kMinDrive) >> shift_);
  }
  kernel_.shift = shift_;
}

void ModuleEncoder::interpolateGainRows() {
  // Each grid row linear between its nodes along the module's rows (nodes evenly from the
  // first pixel's centre to the last's).
  const ModuleColourCorrection& m = correction_;
  gainRows_.resize(static_cast<size_t>(m.gainHeight) * static_cast<size_t>(width_));
  for (int j = 0; j < m.gainHeight; ++j) {
    const float* nodes = m.gain.data() + static_cast<size_t>(j) * static_cast<size_t>(m.gainWidth);
    float* row = gainRows_.data() + static_cast<size_t>(j) * static_cast<size_t>(width_);
    for (int x = 0; x < width_; ++x) {
      if (m.gainWidth < 2 || width_ < 2) {
        row[x] = nodes[0];
        continue;
      }
      const float t = static_cast<float>(x) / static_cast<float>(width_ - 1) *
                      static_cast<float>(m.gainWidth - 1);
      const int i = std::min(static_cast<int>(t), m.gainWidth - 2);
      row[x] = nodes[i] + (nodes[i + 1] - nodes[i]) * (t - static_cast<float>(i));
    }
  }
}

ModuleEncoder::RowGain ModuleEncoder::rowGain(int row) const {
  const ModuleColourCorrection& m = correction_;
  const float y = m.gainHeight < 2 || height_ < 2
                      ? 0.0f
                      : static_cast<float>(row) / static_cast<float>(height_ - 1) *
                            static_cast<float>(m.gainHeight - 1);
  const int y0 = std::min(static_cast<int>(y), std::max(m.gainHeight - 2, 0));
  const int y1 = std::min(y0 + 1, m.gainHeight - 1);
  const size_t w = static_cast<size_t>(width_);
  return {gainRows_.data() + static_cast<size_t>(y0) * w,
          gainRows_.data() + static_cast<size_t>(y1) * w, y - static_cast<float>(y0)};
}

void ModuleEncoder::driveOf(const Rgb& content, float gain, float drive[3]) const {
  const Eigen::Matrix3f& a = correction_.driveFromContent;
  // Content beyond the display's range (0..1, the target's black to its white) is clipped first,
  // as the plain sRGB encode clips it: a module's headroom above the target must not show.
  float in[3];
  for (int c = 0; c < 3; ++c) {
    const float v = content[c] > 0.0f ? content[c] : 0.0f;  // NaN → 0, like maxps
    in[c] = v < 1.0f ? v : 1.0f;
  }
  for (int c = 0; c < 3; ++c) {
    // Same operations in the same order as the SIMD path: bit-identical drives.
    float d = a(c, 0) * in[0];
    d = d + a(c, 1) * in[1];
    d = d + a(c, 2) * in[2];
    d = d + correction_.lift[c];
    d = d * gain - correction_.blackDrive[c];
    d = d > kMinDrive ? d : kMinDrive;  // NaN → black, like maxps with the bound second
    d = d < 1.0f ? d : 1.0f;
    drive[c] = d;
  }
}

int ModuleEncoder::codeOf(int channel, float drive) const {
  const float* t = thresholds_.data() + channel * kStride;
  return static_cast<int>(std::upper_bound(t + 1, t + 256, drive) - (t + 1));
}

std::vector<std::uint8_t> ModuleEncoder::encodeReference(const Frame& frame) const {
  PARALLAX_CHECK_OP(frame.width, ==, width_);
  PARALLAX_CHECK_OP(frame.height, ==, height_);
  std::vector<std::uint8_t> out(frame.pixels.size() * 3);
  for (int y = 0; y < height_; ++y) {
    const RowGain g = rowGain(y);
    for (int x = 0; x < width_; ++x) {
      float drive[3];
      driveOf(frame.at(x, y), g.at(x), drive);
      const size_t i =
          (static_cast<size_t>(y) * static_cast<size_t>(width_) + static_cast<size_t>(x)) * 3;
      for (int c = 0; c < 3; ++c)
        out[i + static_cast<size_t>(c)] = static_cast<std::uint8_t>(codeOf(c, drive[c]));
    }
  }
  return out;
}

namespace {

// Pixels [0, n) of a block, four (SSE2) or eight (AVX2) at a time: deinterleave RGB RGB RGB RGB
// into R, G, B, then the matrix, the lift, the gain and the black, the clamp (maxps returns the
// bound for NaN), the bin from the bits. Returns how many pixels it did (the rest are the
// caller's). The two kernels do the same operations in the same order: the same bytes.
int kernelSse2(const EncodeKernelConstants& k, const float* in, const float* above,
               const float* below, float fraction, int start, int n, float (*drive)[kBlock],
               std::int32_t (*bin)[kBlock]) {
  __m128 m[3][3], lift[3], black[3];
  __m128i binBase[3];
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m[r][c] = _mm_set1_ps(k.matrix[r][c]);
    lift[r] = _mm_set1_ps(k.lift[r]);
    black[r] = _mm_set1_ps(k.black[r]);
    binBase[r] = _mm_set1_epi32(k.binBase[r]);
  }
  const __m128 lo = _mm_set1_ps(kMinDrive), hi = _mm_set1_ps(1.0f), f = _mm_set1_ps(fraction),
               zero = _mm_setzero_ps();
  const __m128i shift = _mm_cvtsi32_si128(k.shift);
  int j = start;
  for (; j + 4 <= n; j += 4) {
    const float* p = in + 3 * j;
    const __m128 a0 = _mm_loadu_ps(p), a1 = _mm_loadu_ps(p + 4), a2 = _mm_loadu_ps(p + 8);
    const __m128 rb = _mm_shuffle_ps(a1, a2, _MM_SHUFFLE(1, 1, 2, 2));   // r2 r2 r3 r3
    const __m128 gb = _mm_shuffle_ps(a0, a1, _MM_SHUFFLE(3, 0, 1, 1));   // g0 g0 g1 g2
    const __m128 ga = _mm_shuffle_ps(a1, a2, _MM_SHUFFLE(2, 2, 3, 3));   // g2 g2 g3 g3
    const __m128 bb = _mm_shuffle_ps(a0, a1, _MM_SHUFFLE(1, 1, 2, 2));   // b0 b0 b1 b1
    const __m128 bg = _mm_shuffle_ps(a2, a2, _MM_SHUFFLE(3, 2, 0, 0));   // b2 b2 g3 b3
    __m128 chan[3] = {_mm_shuffle_ps(a0, rb, _MM_SHUFFLE(2, 0, 3, 0)),   // r0 r1 r2 r3
                      _mm_shuffle_ps(gb, ga, _MM_SHUFFLE(2, 0, 2, 0)),   // g0 g1 g2 g3
                      _mm_shuffle_ps(bb, bg, _MM_SHUFFLE(3, 0, 2, 0))};  // b0 b1 b2 b3
    for (__m128& v : chan) v = _mm_min_ps(_mm_max_ps(v, zero), hi);      // the display's range
    const __m128 up = _mm_loadu_ps(above + j);
    const __m128 g = _mm_add_ps(up, _mm_mul_ps(f, _mm_sub_ps(_mm_loadu_ps(below + j), up)));
    for (int c = 0; c < 3; ++c) {
      __m128 d = _mm_mul_ps(m[c][0], chan[0]);
      d = _mm_add_ps(d, _mm_mul_ps(m[c][1], chan[1]));
      d = _mm_add_ps(d, _mm_mul_ps(m[c][2], chan[2]));
      d = _mm_add_ps(d, lift[c]);
      d = _mm_sub_ps(_mm_mul_ps(d, g), black[c]);
      d = _mm_min_ps(_mm_max_ps(d, lo), hi);
      _mm_store_ps(drive[c] + j, d);
      const __m128i b = _mm_add_epi32(_mm_srl_epi32(_mm_castps_si128(d), shift), binBase[c]);
      _mm_store_si128(reinterpret_cast<__m128i*>(bin[c] + j), b);
    }
  }
  return j;
}

// The same with eight pixels: each 128-bit lane holds four pixels laid out as in kernelSse2, so
// the in-lane shuffles are the same.
__attribute__((target("avx2"))) int kernelAvx2(const EncodeKernelConstants& k, const float* in,
                                               const float* above, const float* below,
                                               float fraction, int n, float (*drive)[kBlock],
                                               std::int32_t (*bin)[kBlock]) {
  __m256 m[3][3], lift[3], black[3];
  __m256i binBase[3];
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m[r][c] = _mm256_set1_ps(k.matrix[r][c]);
    lift[r] = _mm256_set1_ps(k.lift[r]);
    black[r] = _mm256_set1_ps(k.black[r]);
    binBase[r] = _mm256_set1_epi32(k.binBase[r]);
  }
  const __m256 lo = _mm256_set1_ps(kMinDrive), hi = _mm256_set1_ps(1.0f),
               f = _mm256_set1_ps(fraction), zero = _mm256_setzero_ps();
  const __m128i shift = _mm_cvtsi32_si128(k.shift);
  int j = 0;
  for (; j + 8 <= n; j += 8) {
    const float* p = in + 3 * j;
    const __m256 a0 =
        _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_loadu_ps(p)), _mm_loadu_ps(p + 12), 1);
    const __m256 a1 =
        _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_loadu_ps(p + 4)), _mm_loadu_ps(p + 16), 1);
    const __m256 a2 =
        _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_loadu_ps(p + 8)), _mm_loadu_ps(p + 20), 1);
    const __m256 rb = _mm256_shuffle_ps(a1, a2, _MM_SHUFFLE(1, 1, 2, 2));
    const __m256 gb = _mm256_shuffle_ps(a0, a1, _MM_SHUFFLE(3, 0, 1, 1));
    const __m256 ga = _mm256_shuffle_ps(a1, a2, _MM_SHUFFLE(2, 2, 3, 3));
    const __m256 bb = _mm256_shuffle_ps(a0, a1, _MM_SHUFFLE(1, 1, 2, 2));
    const __m256 bg = _mm256_shuffle_ps(a2, a2, _MM_SHUFFLE(3, 2, 0, 0));
    __m256 chan[3] = {_mm256_shuffle_ps(a0, rb, _MM_SHUFFLE(2, 0, 3, 0)),
                      _mm256_shuffle_ps(gb, ga, _MM_SHUFFLE(2, 0, 2, 0)),
                      _mm256_shuffle_ps(bb, bg, _MM_SHUFFLE(3, 0, 2, 0))};
    for (__m256& v : chan) v = _mm256_min_ps(_mm256_max_ps(v, zero), hi);
    const __m256 up = _mm256_loadu_ps(above + j);
    const __m256 g =
        _mm256_add_ps(up, _mm256_mul_ps(f, _mm256_sub_ps(_mm256_loadu_ps(below + j), up)));
    for (int c = 0; c < 3; ++c) {
      __m256 d = _mm256_mul_ps(m[c][0], chan[0]);
      d = _mm256_add_ps(d, _mm256_mul_ps(m[c][1], chan[1]));
      d = _mm256_add_ps(d, _mm256_mul_ps(m[c][2], chan[2]));
      d = _mm256_add_ps(d, lift[c]);
      d = _mm256_sub_ps(_mm256_mul_ps(d, g), black[c]);
      d = _mm256_min_ps(_mm256_max_ps(d, lo), hi);
      _mm256_store_ps(drive[c] + j, d);
      const __m256i b =
          _mm256_add_epi32(_mm256_srl_epi32(_mm256_castps_si256(d), shift), binBase[c]);
      _mm256_store_si256(reinterpret_cast<__m256i*>(bin[c] + j), b);
    }
  }
  return kernelSse2(k, in, above, below, fraction, j, n, drive, bin);  // the last four
}

bool cpuHasAvx2() {
  static const bool has = __builtin_cpu_supports("avx2");
  return has;
}

}  // namespace

std::vector<std::uint8_t> ModuleEncoder::encode(const Frame& frame) const {
  PARALLAX_CHECK_OP(frame.width, ==, width_);
  PARALLAX_CHECK_OP(frame.height, ==, height_);
  std::vector<std::uint8_t> out(frame.pixels.size() * 3);
  for (int y = 0; y < height_; ++y)
    encodeRow(frame, y, 0, width_,
              out.data() + static_cast<size_t>(y) * static_cast<size_t>(width_) * 3);
  return out;
}

void ModuleEncoder::encodeRow(const Frame& frame, int y, int begin, int end,
                              std::uint8_t* rowBytes) const {
  PARALLAX_CHECK_OP(frame.width, ==, width_);
  PARALLAX_CHECK_OP(frame.height, ==, height_);
  PARALLAX_CHECK(y >= 0 && y < height_ && begin >= 0 && begin <= end && end <= width_);
  static_assert(sizeof(Rgb) == 3 * sizeof(float), "Rgb must be 3 packed floats");
  const EncodeKernelConstants& k = kernel_;
  const bool avx2 = useAvx2_ && cpuHasAvx2();
  const std::uint8_t* codes = codes_.data();
  const float* thresholds = thresholds_.data();

  alignas(32) float drive[3][kBlock];
  alignas(32) std::int32_t bin[3][kBlock];
  const RowGain g = rowGain(y);
  const float* in = frame.pixels[static_cast<size_t>(y) * static_cast<size_t>(width_)].data();
  // A pixel's bytes depend on its value and its column's gain only, so a row's blocks may start
  // at any column.
  for (int x0 = begin; x0 < end; x0 += kBlock) {
    const int n = std::min(kBlock, end - x0);
    const float *above = g.above + x0, *below = g.below + x0;
    int j = avx2 ? kernelAvx2(k, in + 3 * x0, above, below, g.fraction, n, drive, bin)
                 : kernelSse2(k, in + 3 * x0, above, below, g.fraction, 0, n, drive, bin);
    for (; j < n; ++j) {
      float d[3];
      driveOf(frame.at(x0 + j, y), g.at(x0 + j), d);
      for (int c = 0; c < 3; ++c) {
        drive[c][j] = d[c];
        bin[c][j] = static_cast<std::int32_t>(bitsOf(d[c]) >> shift_) + k.binBase[c];
      }
    }
    // The code at the bin's lowest drive, one step up if the drive passed the next code's
    // threshold inside the bin.
    std::uint8_t* o = rowBytes + 3 * x0;
    for (int i = 0; i < n; ++i) {
      // Written out per channel: GCC keeps a three-step inner loop otherwise.
      const int red = codes[bin[0][i]], green = codes[bin[1][i]], blue = codes[bin[2][i]];
      o[3 * i + 0] = static_cast<std::uint8_t>(red + (drive[0][i] >= thresholds[red + 1]));
      o[3 * i + 1] =
          static_cast<std::uint8_t>(green + (drive[1][i] >= thresholds[kStride + green + 1]));
      o[3 * i + 2] =
          static_cast<std::uint8_t>(blue + (drive[2][i] >= thresholds[2 * kStride + blue + 1]));
    }
  }
}

Frame ModuleEncoder::decode(const std::vector<std::uint8_t>& bytes) const {
  PARALLAX_CHECK_OP(bytes.size(), ==,
                    static_cast<size_t>(width_) * static_cast<size_t>(height_) * 3);
  Frame out(width_, height_);
  for (int y = 0; y < height_; ++y) {
    const RowGain g = rowGain(y);
    for (int x = 0; x < width_; ++x) {
      const size_t p =
          static_cast<size_t>(y) * static_cast<size_t>(width_) + static_cast<size_t>(x);
      Eigen::Vector3f drive;
      for (int c = 0; c < 3; ++c)
        drive[c] =
            correction_.response[static_cast<size_t>(c)][bytes[3 * p + static_cast<size_t>(c)]];
      // drive = (M · content + lift) · gain − black  ⇒  content = M⁻¹ ((drive + black) / gain −
      // lift)
      const Eigen::Vector3f content =
          contentFromDrive_ * ((drive + correction_.blackDrive) / g.at(x) - correction_.lift);
      out.pixels[p] = content.cwiseMax(0.0f);
    }
  }
  return out;
}

}  // namespace parallax
