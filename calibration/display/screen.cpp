#include "calibration/display/screen.h"

#include "calibration/display/quadratic.h"

namespace parallax {

const char* transferName(ScreenTransfer transfer) {
  return transfer == ScreenTransfer::kLinear ? "linear" : "conical";
}

bool parseTransfer(const std::string& name, ScreenTransfer* transfer) {
  if (name == "conical") {
    *transfer = ScreenTransfer::kConical;
  } else if (name == "linear") {
    *transfer = ScreenTransfer::kLinear;
  } else {
    return false;
  }
  return true;
}

Eigen::Vector3d Screen::tangent(double x) const {
  const double kx = curvature * x;
  return {std::sqrt(1.0 - kx * kx), 0.0, kx};
}

Eigen::Vector3d Screen::frontNormal(double x) const {
  const double kx = curvature * x;
  return {-kx, 0.0, std::sqrt(1.0 - kx * kx)};
}

bool Screen::intersectFrom(const Eigen::Vector3d& p, const Eigen::Vector3d& d, double side,
                           bool withinExtent, double* t, Eigen::Vector3d* hit) const {
  // The cylinder x² + (z − R)² = R², multiplied by k so that k = 0 is the plane z = 0:
  //   k (x² + z²) − 2 z = 0.
  // Along p + t d:  A t² + B t + C = 0 with
  const double k = curvature;
  const double a = k * (d.x() * d.x() + d.z() * d.z());
  const double b = 2.0 * (k * (p.x() * d.x() + p.z() * d.z()) - d.z());
  const double c = k * (p.x() * p.x() + p.z() * p.z()) - 2.0 * p.z();
  const QuadraticRoots roots = solveQuadratic(a, b, c);
  for (int i = 0; i < roots.count; ++i) {
    const double ti = roots.root[i];
    if (!(ti > 0.0)) continue;
    const double x = p.x() + ti * d.x();
    const double y = p.y() + ti * d.y();
    // The screen is the branch through the origin (k z < 1), not the far side of the circle.
    const double z = p.z() + ti * d.z();
    if (!(k * z < 1.0)) continue;
    if (withinExtent && !contains(x, y)) continue;
    // A crossing from the other side is not what the caller traces (for a module ray: it is
    // light that went round an edge); the ray goes on to its next crossing.
    if (!(side * d.dot(frontNormal(x)) > 0.0)) continue;
    *t = ti;
    *hit = pointAt(x, y);
    return true;
  }
  return false;
}

}  // namespace parallax
