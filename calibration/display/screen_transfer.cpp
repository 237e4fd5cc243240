#include "calibration/display/screen_transfer.h"

#include <cmath>

#include "calibration/display/quadratic.h"

namespace parallax {

bool linearTransfer(const Screen& screen, const ObserverLine& observer, const Eigen::Vector3d& s,
                    const Eigen::Vector3d& d, double* x) {
  // A ray running parallel to the screen plane in top view never reaches the line.
  if (!(d.z() > 0.0)) return false;
  const double ox = s.x() + d.x() / d.z() * (observer.z - s.z());
  if (!std::isfinite(ox)) return false;
  *x = ox;
  return true;
}

bool conicalTransfer(const Screen& screen, const ObserverLine& observer, const Eigen::Vector3d& s,
                     const Eigen::Vector3d& d, double* x) {
  const Eigen::Vector3d t = screen.tangent(s.x());
  const double a = d.dot(t);
  // |a| → 1: the cone collapses onto the tangent, which runs along the screen.
  if (!(std::abs(a) < 1.0 - 1e-12)) return false;
  const double tx = t.x(), tz = t.z();
  const double yy = observer.y - s.y();
  const double zz = observer.z - s.z();
  const double a2 = a * a;
  // Half-b form of the quadratic. Its discriminant, simplified with tx² + tz² = 1, is
  //   b'² − A C = a² ((1 − a²)(Y² + Z²) − tz² Y²),
  // written that way so its sign is exact: for a = 0 the double root must not vanish to a
  // rounding error, and a negative Q is the honest "the cone misses the line".
  const double qa = tx * tx - a2;
  const double qb = tx * tz * zz;
  const double qc = tz * tz * zz * zz - a2 * (yy * yy + zz * zz);
  const double inner = (1.0 - a2) * (yy * yy + zz * zz) - tz * tz * yy * yy;
  if (inner < 0.0) return false;
  const double root = std::abs(a) * std::sqrt(inner);
  QuadraticRoots roots;
  const double q = -(qb + std::copysign(root, qb));
  if (q != 0.0) {
    roots.root[roots.count++] = qc / q;
    if (qa != 0.0) roots.root[roots.count++] = q / qa;
  } else if (qa != 0.0) {  // qb = 0 and root = 0: the double root ξ = 0 (a = 0 on a flat screen)
    roots.root[roots.count++] = 0.0;
  }

  const Eigen::Vector3d dPerp = d - a * t;
  bool found = false;
  double bestAlignment = -2.0;
  for (int i = 0; i < roots.count; ++i) {
    const double xi = roots.root[i];
    const double along = tx * xi + tz * zz;  // (o − s) · t
    // Keep only the cone of d, not its mirror image (where (o − s)·t has the other sign).
    if (a != 0.0 && !(along * a > 0.0)) continue;
    const Eigen::Vector3d e = Eigen::Vector3d(xi, yy, zz).normalized();
    // Smaller rotation about t ⇔ larger dot product of the components across t.
    const double alignment = (e - a * t).dot(dPerp);
    if (alignment > bestAlignment) {
      bestAlignment = alignment;
      *x = s.x() + xi;
      found = true;
    }
  }
  return found && std::isfinite(*x);
}

bool transferToObserverLine(const Screen& screen, const ObserverLine& observer,
                            const Eigen::Vector3d& s, const Eigen::Vector3d& d, double* x) {
  return screen.transfer == ScreenTransfer::kLinear ? linearTransfer(screen, observer, s, d, x)
                                                    : conicalTransfer(screen, observer, s, d, x);
}

}  // namespace parallax
