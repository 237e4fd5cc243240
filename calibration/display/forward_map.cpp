#include "calibration/display/forward_map.h"

#include <Eigen/LU>
#include <cmath>

namespace parallax {

ForwardMap::ForwardMap(const DisplayModel& model, int moduleIndex)
    : model_(model), rays_(model, moduleIndex) {}

ForwardMapResult ForwardMap::linearPixelOf(const Eigen::Vector3d& point, bool withinScreen) const {
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
  if (withinScreen && !model_.screen.contains(s.x(), s.y())) return result;
  if (!rays_.optics().project((s - p).normalized(), &result.pixel)) return result;
  result.ok = true;
  return result;
}

bool ForwardMap::residual(const Eigen::Vector2d& uv, const Eigen::Vector3d& point,
                          Eigen::Vector2d* r) const {
  const PixelRay ray = rays_.atUnclipped(uv.x(), uv.y());
  if (!ray.valid()) return false;
  const Eigen::Vector3d along = ray.screenPoint - ray.origin;
  const double lambda = (point.z() - ray.origin.z()) / along.z();
  if (!std::isfinite(lambda)) return false;
  *r = (ray.origin + lambda * along).head<2>() - point.head<2>();
  return true;
}

ForwardMapResult ForwardMap::refineConical(const Eigen::Vector3d& point, Eigen::Vector2d uv,
                                           bool withinScreen) const {
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
      // Converged; it is an answer only if the ray really passes through the point and the
      // pixel's module ray lands on the screen itself, not on its continuation.
      result.ok =
          r.norm() <= 1e-9 * (1.0 + point.norm()) &&
          (withinScreen ? rays_.at(uv.x(), uv.y()) : rays_.atUnclipped(uv.x(), uv.y())).valid();
      result.pixel = uv;
      return result;
    }
  }
  return result;
}

bool ForwardMap::coneMismatch(double x, const Eigen::Vector3d& point, double* mismatch,
                              Eigen::Vector3d* s) const {
  const Eigen::Vector3d o = model_.observer.pointAt(x);
  double t;
  // The surface past the screen's edges too, so a root lying right at an edge stays bracketed;
  // the ray function rejects off-screen answers when Newton polishes them.
  if (!model_.screen.intersectFrom(o, point - o, -1.0, false, &t, s)) return false;
  const Eigen::Vector3d tangent = model_.screen.tangent(s->x());
  const Eigen::Vector3d incoming = (*s - rays_.optics().position()).normalized();
  *mismatch = (o - *s).normalized().dot(tangent) - incoming.dot(tangent);
  return std::isfinite(*mismatch);
}

std::vector<Eigen::Vector2d> ForwardMap::conicalStarts(const Eigen::Vector3d& point) const {
  std::vector<Eigen::Vector2d> starts;
  const double depth = model_.observer.z - point.z();
  if (!(depth > 0.0)) return starts;
  // X = P.x + depth·tan φ over φ ∈ (−89.5°, 89.5°): every origin whose line to P can be steep
  // enough to reach the screen.
  constexpr int kSamples = 256;
  constexpr double kMaxAngle = 1.5620696805349213;  // 89.5° in radians
  auto originAt = [&](int i) {
    return point.x() + depth * std::tan(-kMaxAngle + 2.0 * kMaxAngle * i / kSamples);
  };
  double prevX = 0.0, prevF = 0.0;
  bool prevOk = false;
  Eigen::Vector3d s;
  for (int i = 0; i <= kSamples; ++i) {
    const double x = originAt(i);
    double f;
    const bool ok = coneMismatch(x, point, &f, &s);
    if (ok && prevOk && (f == 0.0 || (f > 0.0) != (prevF > 0.0))) {
      double lo = prevX, hi = x, fLo = prevF;
      for (int k = 0; k < 200 && hi - lo > 1e-15 * (1.0 + std::abs(lo)); ++k) {
        const double mid = 0.5 * (lo + hi);
        double fMid;
        if (!coneMismatch(mid, point, &fMid, &s)) break;
        if ((fMid > 0.0) == (fLo > 0.0)) {
          lo = mid;
          fLo = fMid;
        } else {
          hi = mid;
        }
      }
      double f0;
      Eigen::Vector2d pixel;
      if (coneMismatch(0.5 * (lo + hi), point, &f0, &s) &&
          rays_.optics().project((s - rays_.optics().position()).normalized(), &pixel)) {
        starts.push_back(pixel);
      }
    }
    prevX = x;
    prevF = f;
    prevOk = ok;
  }
  return starts;
}

ForwardMapResult ForwardMap::pixelOf(const Eigen::Vector3d& point) const {
  return solve(point, true);
}

ForwardMapResult ForwardMap::pixelOfContinued(const Eigen::Vector3d& point) const {
  return solve(point, false);
}

ForwardMapResult ForwardMap::solve(const Eigen::Vector3d& point, bool withinScreen) const {
  if (model_.screen.transfer == ScreenTransfer::kLinear) return linearPixelOf(point, withinScreen);
  // Conical: Newton from the closed-form linear answer converges in a few steps for almost
  // every point. Where it does not (grazing pixels far from it), every root of the 1-D cone
  // condition is a candidate; Newton on the ray function itself polishes each, and the one whose
  // ray passes through P is the answer (the others belong to the mirror branch the ray
  // function's root rule rejects).
  const ForwardMapResult linear = linearPixelOf(point, withinScreen);
  if (linear.ok) {
    const ForwardMapResult quick = refineConical(point, linear.pixel, withinScreen);
    if (quick.ok) return quick;
  }
  for (const Eigen::Vector2d& start : conicalStarts(point)) {
    const ForwardMapResult result = refineConical(point, start, withinScreen);
    if (result.ok) return result;
  }
  return {};
}

}  // namespace parallax
