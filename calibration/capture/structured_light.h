#pragma once
// Structured-light patterns for the modules and their per-pixel decoding: Gray code plus
// phase shift, along columns and along rows.
//
// Why this choice over dot grids: a dot grid gives one correspondence per dot and needs the
// dots to be found and identified in a camera image where each module is visible only in a
// narrow vertical stripe (about the diffusion width) — a stripe a few dots wide, whose
// identification breaks at its edges. Gray code + phase shift decodes every camera pixel on
// its own into a continuous module coordinate: the Gray code gives the period (robust,
// binary), the phase shift the position inside it (sub-pixel, insensitive to blur and to the
// lobe's brightness falloff since it is a ratio). It needs more frames (2 references +
// Gray bits + phase steps per axis), but every module shows its patterns at the same time
// (each screen column is lit by a different module from one station), so the frame count does
// not grow with the number of modules.
//
// Pattern of a frame at module pixel centre u (i + 0.5):
//   reference white 1, reference black 0;
//   Gray bit b: bit b of gray(floor(u / P)) (most significant first);
//   phase step k of N: 0.5 + 0.5 cos(2π u / P − 2π k / N).
// Decoding (with the black/white references B, W of the same pixel):
//   Gray bits: I > (W + B) / 2 → period index n;
//   phase θ = atan2(Σ I_k sin(2πk/N), Σ I_k cos(2πk/N)) ∈ [0, 2π) → fine = θ P / 2π;
//   u = fine + P·m with the integer m that puts u nearest to the period's centre n P + P/2.

#include <opencv2/core.hpp>
#include <optional>
#include <vector>

namespace parallax {

struct StructuredLightOptions {
  int periodPx = 16;          // phase period P
  int phaseSteps = 4;         // N
  double minContrast = 0.05;  // W − B below this (in linear units) → not decodable

  void validate() const;
};

enum class PatternAxis { kColumns, kRows };

// Number of Gray bits that cover `extent` pixels at period P.
int grayBitCount(int extent, int periodPx);

// The frames for one axis, in order: white, black, Gray bits (MSB first), phase steps.
// Each is a CV_32F image of width × height with values in [0, 1].
std::vector<cv::Mat> makePatternFrames(int width, int height, PatternAxis axis,
                                       const StructuredLightOptions& options);

// Decodes one pixel's intensities (linear units, in makePatternFrames' order) along an axis of
// `extent` pixels; nullopt when the contrast is too low or the code lands outside the image.
std::optional<double> decodePixel(const std::vector<float>& intensities, int extent,
                                  const StructuredLightOptions& options);

}  // namespace parallax
