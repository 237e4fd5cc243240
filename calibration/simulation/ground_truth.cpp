#include "calibration/simulation/ground_truth.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "calibration/display/conventions.h"
#include "calibration/simulation/seeded_random.h"
#include "common/input_error.h"

namespace parallax {
namespace {

void requireNonNegative(double value, const char* name) {
  if (!(std::isfinite(value) && value >= 0.0)) {
    throw InputError({"", name, 0}, fmt::format("must be finite and >= 0, got {}", value));
  }
}

}  // namespace

void GroundTruthOptions::validate() const {
  requireNonNegative(positionSigmaM, "position_sigma_m");
  requireNonNegative(positionLimitM, "position_limit_m");
  requireNonNegative(angleSigmaDeg, "angle_sigma_deg");
  requireNonNegative(angleLimitDeg, "angle_limit_deg");
  requireNonNegative(focalSigmaRel, "focal_sigma_rel");
  requireNonNegative(principalSigmaRel, "principal_sigma_rel");
  requireNonNegative(k1Limit, "k1_limit");
  requireNonNegative(k2Limit, "k2_limit");
  requireNonNegative(curvatureSigma, "curvature_sigma");
  if (focalSigmaRel > 0.2) throw InputError({"", "focal_sigma_rel", 0}, "must be <= 0.2");
  if (angleLimitDeg > 30.0) throw InputError({"", "angle_limit_deg", 0}, "must be <= 30");
  if (curvature && !std::isfinite(*curvature)) {
    throw InputError({"", "curvature", 0}, "must be finite");
  }
}

Eigen::Quaterniond rotateModule(const Eigen::Quaterniond& physicalFromModule, double yawRad,
                                double pitchRad, double rollRad) {
  // Module axes: x right (columns), y down (rows), z optical axis. Yaw turns about the module's
  // vertical (its y), pitch about its x, roll about its optical axis: composed on the module
  // side so the angles mean the same thing for every module in the row.
  const Eigen::Quaterniond moduleTurn = Eigen::AngleAxisd(yawRad, Eigen::Vector3d::UnitY()) *
                                        Eigen::AngleAxisd(pitchRad, Eigen::Vector3d::UnitX()) *
                                        Eigen::AngleAxisd(rollRad, Eigen::Vector3d::UnitZ());
  return (physicalFromModule * moduleTurn).normalized();
}

Eigen::Quaterniond aimModuleAt(const Eigen::Vector3d& position, const Eigen::Vector3d& target) {
  return uprightLookingAt(position, target);
}

DisplayModel makeGroundTruth(const DisplayModel& nominal, const GroundTruthOptions& options) {
  options.validate();
  nominal.validate();
  DisplayModel truth = nominal;
  truth.name = nominal.name + "-truth";
  SeededRandom random(options.seed);

  // Screen first, so the modules' draws do not depend on the screen options.
  SeededRandom screenRandom = random.split();
  const double kLimit = 0.9 / (0.5 * truth.screen.width);
  double k = options.curvature.value_or(nominal.screen.curvature +
                                        screenRandom.normal(options.curvatureSigma));
  if (!options.curvature) k = std::clamp(k, -kLimit, kLimit);
  truth.screen.curvature = k;
  if (options.transfer) truth.screen.transfer = *options.transfer;

  for (OpticalModule& m : truth.modules) {
    SeededRandom r = random.split();  // one stream per module: adding modules shifts nothing
    for (int axis = 0; axis < 3; ++axis) {
      m.position[axis] += r.clippedNormal(options.positionSigmaM, options.positionLimitM);
    }
    const double limit = radians(options.angleLimitDeg);
    const double sigma = radians(options.angleSigmaDeg);
    const double yaw = r.clippedNormal(sigma, limit);
    const double pitch = r.clippedNormal(sigma, limit);
    const double roll = r.clippedNormal(sigma, limit);
    m.orientation = rotateModule(m.orientation, yaw, pitch, roll);
    const double focalScale =
        1.0 + r.clippedNormal(options.focalSigmaRel, 3.0 * options.focalSigmaRel);
    const double aspect = m.fy / m.fx;
    m.fx *= focalScale;
    m.fy = m.fx * aspect * (1.0 + r.clippedNormal(0.002, 0.006));
    m.cx += r.clippedNormal(options.principalSigmaRel * m.width,
                            3.0 * options.principalSigmaRel * m.width);
    m.cy += r.clippedNormal(options.principalSigmaRel * m.height,
                            3.0 * options.principalSigmaRel * m.height);
    m.k1 += r.uniform(-options.k1Limit, options.k1Limit);
    m.k2 += r.uniform(-options.k2Limit, options.k2Limit);
  }
  truth.validate();
  return truth;
}

}  // namespace parallax
