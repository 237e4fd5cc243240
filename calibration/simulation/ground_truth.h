#pragma once
// The simulator's ground truth: a DisplayModel made by perturbing a nominal one with a seed,
// by the amounts a real installation is off from its drawing (module positions by millimetres
// to centimetres, orientations by 1–3°, focal lengths by ~2%, principal points, a little
// radial distortion, the screen's curvature). The same seed gives the same model, bit for bit.
// Only the simulator, tests and reports open it; the fit never does.

#include <cstdint>
#include <optional>

#include "calibration/display/display_model.h"

namespace parallax {

struct GroundTruthOptions {
  std::uint64_t seed = 1;
  double positionSigmaM = 0.005;  // per axis
  double positionLimitM = 0.02;   // clip
  double angleSigmaDeg = 1.5;     // yaw, pitch, roll each
  double angleLimitDeg = 3.0;
  double focalSigmaRel = 0.02;      // fx, fy (fy follows fx within 0.2%)
  double principalSigmaRel = 0.01;  // of the module width / height
  double k1Limit = 0.05;            // uniform in ±limit
  double k2Limit = 0.01;
  double curvatureSigma = 0.02;            // added to the nominal k (1/m)
  std::optional<double> curvature;         // overrides the screen's k outright
  std::optional<ScreenTransfer> transfer;  // the truth may follow either transfer

  // Throws InputError naming the option.
  void validate() const;
};

DisplayModel makeGroundTruth(const DisplayModel& nominal, const GroundTruthOptions& options);

// Rotation about the module's own axes (yaw about physical y, then pitch, then roll about the
// optical axis) applied to a physicalFromModule orientation; used for perturbations and for
// building stress cases (grazing modules).
Eigen::Quaterniond rotateModule(const Eigen::Quaterniond& physicalFromModule, double yawRad,
                                double pitchRad, double rollRad);

// Orientation of an upright module at `position` aimed at `target` (conventions.h).
Eigen::Quaterniond aimModuleAt(const Eigen::Vector3d& position, const Eigen::Vector3d& target);

}  // namespace parallax
