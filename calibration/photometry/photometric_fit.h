#pragma once
// Flat-field samples → each module's photometry → the correction that makes every module show
// the same colours at the same brightness (calibration/display/colour_correction.h).
//
// Per module: the spatial falloff (a quadratic surface in the image fitted to the full-white
// luminance samples, smooth like a lens's vignetting, so it extends over image parts no
// station saw), the primaries (each channel's light at full drive, at the brightest point), the
// black level, and per channel a monotone response curve through the measured levels
// (pool-adjacent-violators, then log-log interpolation: exact for a power law; below the first
// level the fitted power law).
//
// The target, shared by all modules: primaries as saturated as every module reaches (each
// primary of the modules' mean chromaticity, moved toward white until every module's gamut holds
// it), white D65 ((1, 1, 1) in linear sRGB), a black every module reaches (the highest of their
// blacks), and a brightness every module reaches at every pixel (its darkest corner included)
// — or, with brightnessQuantile > 0, that of the quantile's module, those below it then fall
// short (the trade of uniformity for brightness).
//
// Modules that cannot join are excluded with their reason (never silently): not seen by the
// camera, dead (black), unable to show white, or primaries far outside the others' (they would
// shrink the common gamut). A dead module keeps an identity correction; the others a
// best-effort one at their own reach.

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "calibration/display/colour_correction.h"
#include "calibration/photometry/flat_field_capture.h"

namespace parallax {

struct PhotometricFitOptions {
  int gainGridWidth = 16, gainGridHeight = 12;
  double brightnessQuantile = 0.0;  // 0: uniform at the weakest module's level
  double deadFraction = 0.2;        // a white below this × the median module's: dead
  double gamutOutlierXy = 0.08;     // a primary farther than this (CIE xy) from the median's
  int minSamples = 100;

  // Throws InputError naming the field.
  void validate() const;
};

struct ModulePhotometricFigures {
  int module = 0;
  bool excluded = false;
  std::string reason;              // why it was excluded
  int samples = 0;                 // camera pixels that saw it
  Eigen::Vector3d gamma{0, 0, 0};  // power law fitted to each channel's response
  double whiteLuminance = 0.0;     // full white at its brightest point (ideal module: 1)
  double blackLuminance = 0.0;     // black level there
  double falloff = 0.0;            // 1 − its darkest image point's share of the brightest
  std::array<Eigen::Vector2d, 3> primariesXy{};
  double reach = 1.0;  // its brightness over the target's (< 1: falls short)
  Eigen::Matrix3d primaries = Eigen::Matrix3d::Zero();  // columns: channel light at full drive
  Eigen::Vector3d black = Eigen::Vector3d::Zero();
};

struct PhotometricCalibration {
  DisplayColourCorrection correction;
  std::vector<ModulePhotometricFigures> modules;
  double targetWhiteLuminance = 0.0, targetBlackLuminance = 0.0;
  std::array<Eigen::Vector2d, 3> targetPrimariesXy{};
  // The brightness shortfall among the included modules, 1 − the lowest reach (0 with a
  // quantile of 0: every module reaches the target).
  double brightnessShortfall = 0.0;

  std::vector<int> excluded() const;
  // The per-module table and the target, a line each (what `status` and the CLI print).
  std::string describe() const;
};

// Throws PhotometricCaptureError when no module can be calibrated.
PhotometricCalibration fitPhotometry(const FlatFieldCaptures& captures,
                                     const PhotometricFitOptions& options);

}  // namespace parallax
