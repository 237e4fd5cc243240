#pragma once
// A module frame's bytes with its photometric correction applied (calibration/display/
// colour_correction.h): the content clipped to the display's range (0..1, as the plain sRGB
// encode clips it), the colour matrix, the black lift, the spatial gain map and the module's
// own response curve, fused with the 8-bit encoding that Frame::toSrgb8 does for an ideal
// module. Built once per module when a correction is installed; encode() runs per frame.
//
// Speed (bench/frame_encode_bench): the matrix and the gain run four pixels at a time with
// SSE2; the code comes from a table indexed by the drive's float bits (exponent and the top
// mantissa bits: fine steps near black, where a gamma curve's codes crowd, and coarse near
// white) followed by one comparison with the next code's threshold, which makes it exact.

#include <cstdint>
#include <vector>

#include "calibration/display/colour_correction.h"
#include "tracer/frame.h"

namespace parallax {

// What the encode's SIMD kernels need, as plain numbers (module_encoder.cpp).
struct EncodeKernelConstants {
  float matrix[3][3] = {};
  float lift[3] = {}, black[3] = {};
  int shift = 0;
  int binBase[3] = {};  // channel c's bin = (drive bits >> shift) + binBase[c]
};

class ModuleEncoder {
 public:
  // Throws InputError (from validate) for a malformed correction.
  // `allowAvx2`: use AVX2 where the processor has it (false: SSE2 only; the test runs both).
  ModuleEncoder(const ModuleColourCorrection& correction, int width, int height,
                bool allowAvx2 = true);

  // RGB RGB ... row-major, the bytes the module is sent. CHECKs the frame's size.
  std::vector<std::uint8_t> encode(const Frame& frame) const;
  // Row y's columns [begin, end) into `rowBytes` (the row's first byte, 3 a pixel): the bytes
  // encode() gives them (a frame rendered only inside its scene's footprint).
  void encodeRow(const Frame& frame, int y, int begin, int end, std::uint8_t* rowBytes) const;

  // The same bytes by the definition (nearest code by search, no tables): the test's reference.
  std::vector<std::uint8_t> encodeReference(const Frame& frame) const;

  // The content (target space) the module shows for `bytes` as the correction models it: each
  // code's drive, the gain and the colour matrix undone. What a viewer sees of a corrected
  // module when the calibration is right (the daemon's `view`); content the module could not
  // reach comes back as what it shows instead.
  Frame decode(const std::vector<std::uint8_t>& bytes) const;

  int width() const { return width_; }
  int height() const { return height_; }

 private:
  // The gain along row `row`: between two grid rows (each already linear between its nodes
  // along the whole module row, gainRows_), computed the same way by both paths.
  struct RowGain {
    const float* above;
    const float* below;
    float fraction;
    float at(int x) const { return above[x] + fraction * (below[x] - above[x]); }
  };
  RowGain rowGain(int row) const;
  void interpolateGainRows();
  // The drive of one pixel, computed exactly as the SIMD path computes it.
  void driveOf(const Rgb& content, float gain, float drive[3]) const;
  int codeOf(int channel, float drive) const;  // by search

  ModuleColourCorrection correction_;
  Eigen::Matrix3f contentFromDrive_;
  int width_, height_;
  bool useAvx2_;
  std::vector<float> gainRows_;  // gainHeight rows of width floats
  // thresholds_[c * kStride + k]: the smallest drive whose nearest code is k (−inf for k = 0,
  // +inf for k = 256).
  static constexpr int kStride = 512;
  std::vector<float> thresholds_;
  // codes_[c · binCount_ + bin]: the code at the bin's lowest drive; bins are the float bit
  // patterns of the drive shifted right by shift_, from the smallest drive kept (2^−24) up.
  // Bytes: the three channels' tables and thresholds stay in a 32 KiB L1 cache together.
  int shift_ = 15;
  int binCount_ = 0;
  std::vector<std::uint8_t> codes_;
  EncodeKernelConstants kernel_;  // from the correction and the tables above
};

}  // namespace parallax
