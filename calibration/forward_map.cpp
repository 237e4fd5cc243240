#include "calibration/forward_map.h"

#include <Eigen/LU>
#include <cmath>

namespace parallax {

ForwardMap::ForwardMap(const DisplayModel& model, int moduleIndex)
    : model_(model), rays_(model, moduleIndex) {}

ForwardMapResult ForwardMap::linearPixelOf(const Eigen::Vector3d& point) const {
  ForwardMapResult result;
  const Eigen::Vector3d& p = rays_.optics().position();
  // Top-view line from the module through the point, oriented toward the viewers.
  Eigen::Vector3d topView(point.x() - p.x(), 0.0, point.z() - p.z());
  if (topView.z() < 0.0) topView = -topView;
  if (!(topView.norm() > 1e-12 * (1.0 + p.norm()))) return result;  // point above the module
  double t;
  Eigen::Vector3d s;
  // The cylinder does not depend on y, so the top-view line finds s.x and s.z directly.
  if (!model_.screen.intersect(p, topView, &t, &s)) return result;
  const double ox = s.x() + topView.x() / topView.z() * (model_.observer.z - s.z());
  const Eigen::Vector3d o = model_.observer.pointAt(ox);
  // s.y: where the 3-D line o → P reaches s in the top view; use the better conditioned axis.
  const Eigen::Vector3d toPoint = point - o;
  const double lambda = std::abs(toPoint.z()) >= std::abs(toPoint.x())
                            ? (s.z() - o.z()) / toPoint.z()
                            : (s.x() - o.x()) / toPoint.x();
  if (!std::isfinite(lambda)) return result;
  s.y() = o.y() + lambda * toPoint.y();
  if (!model_.screen.contains(s.x(), s.y())) return result;
  if (!rays_.optics().project((s - p).normalized(), &result.pixel)) return result;
  result.ok = true;
  return result;
}

bool ForwardMap::residual(const Eigen::Vector2d& uv, const Eigen::Vector3d& point,
                          Eigen::Vector2d* r) const {
  const PixelRay ray = rays_.at(uv.x(), uv.y());
  if (!ray.valid()) return false;
  const Eigen::Vector3d along = ray.screenPoint - ray.origin;
  const double lambda = (point.z() - ray.origin.z()) / along.z();
  if (!std::isfinite(lambda)) return false;
  *r = (ray.origin + lambda * along).head<2>() - point.head<2>();
  return true;
}

ForwardMapResult ForwardMap::refineConical(const Eigen::Vector3d& point, Eigen::Vector2d uv) const {
  ForwardMapResult result;
  // Newton with a central-difference Jacobian: its truncation error only slows convergence, it
  // does not move the root, so the answer is as exact as the ray function itself.
  constexpr double kStep = 1e-3;  // px
  Eigen::Vector2d r;
  if (!residual(uv, point, &r)) return result;
  for (int iter = 1; iter <= 30; ++iter) {
    Eigen::Matrix2d jacobian;
    for (int axis = 0; axis < 2; ++axis) {
      Eigen::Vector2d plus = uv, minus = uv, rPlus, rMinus;
      plus[axis] += kStep;
      minus[axis] -= kStep;
      if (!residual(plus, point, &rPlus) || !residual(minus, point, &rMinus)) return result;
      jacobian.col(axis) = (rPlus - rMinus) / (2.0 * kStep);
    }
    const double det = jacobian.determinant();
    if (!std::isfinite(det) || det == 0.0) return result;
    Eigen::Vector2d step = jacobian.inverse() * r;
    // Damp steps that would leave the lens model or the screen.
    Eigen::Vector2d next = uv - step, rNext;
    int halvings = 0;
    while (!residual(next, point, &rNext) || rNext.norm() > r.norm() * 1.5 + 1e-15) {
      if (++halvings > 30) return result;
      step *= 0.5;
      next = uv - step;
    }
    uv = next;
    r = rNext;
    result.iterations = iter;
    if (step.norm() < 1e-10) {
      result.ok = true;
      result.pixel = uv;
      return result;
    }
  }
  return result;
}

ForwardMapResult ForwardMap::pixelOf(const Eigen::Vector3d& point) const {
  const ForwardMapResult linear = linearPixelOf(point);
  if (model_.screen.transfer == ScreenTransfer::kLinear) return linear;
  // Conical: start from the linear answer, or from the image centre when that has none.
  const OpticalModule& m = rays_.module();
  const Eigen::Vector2d start = linear.ok ? linear.pixel : Eigen::Vector2d(m.cx, m.cy);
  return refineConical(point, start);
}

}  // namespace parallax
