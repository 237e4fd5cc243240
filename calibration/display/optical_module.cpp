#include "calibration/display/optical_module.h"

#include <cmath>
#include <limits>

#include "calibration/display/quadratic.h"

namespace parallax {

double maxUndistortedRadius(double k1, double k2) {
  // Smallest positive r² root of 5 k2 (r²)² + 3 k1 r² + 1 = 0.
  const QuadraticRoots roots = solveQuadratic(5.0 * k2, 3.0 * k1, 1.0);
  double best = std::numeric_limits<double>::infinity();
  for (int i = 0; i < roots.count; ++i) {
    if (roots.root[i] > 0.0) best = std::min(best, std::sqrt(roots.root[i]));
  }
  return best;
}

ModuleOptics::ModuleOptics(const OpticalModule& module)
    : position_(module.position),
      physicalFromModule_(module.orientation.normalized().toRotationMatrix()),
      fx_(module.fx),
      fy_(module.fy),
      cx_(module.cx),
      cy_(module.cy),
      k1_(module.k1),
      k2_(module.k2),
      mirrorSign_(module.mirror ? -1.0 : 1.0),
      distorted_(module.k1 != 0.0 || module.k2 != 0.0),
      maxRadius_(maxUndistortedRadius(module.k1, module.k2)) {
  const double r = maxRadius_;
  const double r2 = r * r;
  maxDistortedRadius_ = std::isinf(r) ? r : r * (1.0 + k1_ * r2 + k2_ * r2 * r2);
}

double ModuleOptics::undistortRadius(double rd) const {
  // Newton on g(r) = r (1 + k1 r² + k2 r⁴) − rd, safeguarded by bisection on [lo, hi] where g is
  // monotone, so it always converges to the one root. Starting from the series inverse
  // rd (1 − k1 rd² + (3 k1² − k2) rd⁴), Newton needs 1–3 steps for a real lens; it stops once a
  // step no longer changes r by more than a few ulp (asking for less never ends in floating point).
  double lo = 0.0;
  double hi = std::isinf(maxRadius_) ? std::max(1.0, 2.0 * rd) : maxRadius_;
  // Without a fold g grows without bound; widen until it brackets rd.
  while (std::isinf(maxRadius_) && hi * (1.0 + k1_ * hi * hi + k2_ * hi * hi * hi * hi) < rd) {
    hi *= 2.0;
  }
  const double rd2 = rd * rd;
  double r = rd * (1.0 - k1_ * rd2 + (3.0 * k1_ * k1_ - k2_) * rd2 * rd2);
  if (!(r > lo && r < hi)) r = 0.5 * (lo + hi);
  for (int iter = 0; iter < 60; ++iter) {
    const double r2 = r * r;
    const double g = r * (1.0 + k1_ * r2 + k2_ * r2 * r2) - rd;
    if (g == 0.0) return r;
    if (g > 0.0)
      hi = r;
    else
      lo = r;
    const double dg = 1.0 + 3.0 * k1_ * r2 + 5.0 * k2_ * r2 * r2;
    double next = r - g / dg;
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (std::abs(next - r) <= 4e-16 * r) return next;
    r = next;
  }
  return r;
}

bool ModuleOptics::rayDirection(double u, double v, Eigen::Vector3d* direction) const {
  double x = (u - cx_) / fx_;
  double y = (v - cy_) / fy_;
  if (distorted_) {
    const double rd = std::sqrt(x * x + y * y);
    if (!(rd < maxDistortedRadius_)) return false;
    if (rd > 0.0) {
      const double scale = undistortRadius(rd) / rd;
      x *= scale;
      y *= scale;
    }
  }
  const Eigen::Vector3d local(mirrorSign_ * x, y, 1.0);
  *direction = (physicalFromModule_ * local).normalized();
  return true;
}

bool ModuleOptics::project(const Eigen::Vector3d& direction, Eigen::Vector2d* pixel) const {
  const Eigen::Vector3d local = physicalFromModule_.transpose() * direction;
  if (!(local.z() > 0.0)) return false;
  const double x = mirrorSign_ * local.x() / local.z();
  const double y = local.y() / local.z();
  double scale = 1.0;
  if (distorted_) {
    const double r2 = x * x + y * y;
    if (!(std::sqrt(r2) < maxRadius_)) return false;
    scale = 1.0 + k1_ * r2 + k2_ * r2 * r2;
  }
  *pixel = {fx_ * x * scale + cx_, fy_ * y * scale + cy_};
  return true;
}

}  // namespace parallax
