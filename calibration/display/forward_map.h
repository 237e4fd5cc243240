#pragma once
// The forward map, physical point → module pixel (the "double perspective" rasterizers use):
// the inverse of the ray function. Under `linear` it is closed form: in the top view the module
// p, the screen point s, the point P and the origin o are collinear, so the top-view line p→P
// gives s.x and o.x, and the line o→P gives s.y. Under `conical` there is no closed form: Newton
// on (u, v) over the ray function, started from the linear answer. Not projective, which is
// why interpolating linearly inside a rasterized triangle is wrong.
//
// The conical start: a candidate origin X on the observer line fixes the line o → P, hence the
// screen point s where it crosses the screen, hence the module ray p → s; X is right when the
// outgoing and incoming directions have the same cosine along the tangent at s. That scalar
// equation in X is bracketed by a scan over the angle of o → P and solved by bisection, which
// is robust for grazing pixels far from the linear answer; Newton then polishes (u, v).

#include <Eigen/Core>
#include <vector>

#include "calibration/display/display_model.h"
#include "calibration/display/ray_function.h"

namespace parallax {

struct ForwardMapResult {
  bool ok = false;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();  // (u, v), continuous; may lie off the image
  int iterations = 0;                               // Newton steps (conical)
};

class ForwardMap {
 public:
  ForwardMap(const DisplayModel& model, int moduleIndex);

  // Pixel position whose primary ray passes through the physical point; not ok when none does
  // (the point is off every ray of the module, or the solve does not converge).
  ForwardMapResult pixelOf(const Eigen::Vector3d& physicalPoint) const;
  // The same map continued past the screen's edges (RayFunction::atUnclipped): a point whose
  // ray would cross the screen's plane beyond its extent still gets the pixel, off the image
  // or masked. What a rasterizer needs for the vertices of a triangle that leaves the image:
  // their pixels lie outside it and clipping in the image does the rest.
  ForwardMapResult pixelOfContinued(const Eigen::Vector3d& physicalPoint) const;

 private:
  ForwardMapResult solve(const Eigen::Vector3d& point, bool withinScreen) const;
  ForwardMapResult linearPixelOf(const Eigen::Vector3d& point, bool withinScreen) const;
  ForwardMapResult refineConical(const Eigen::Vector3d& point, Eigen::Vector2d start,
                                 bool withinScreen) const;
  // Pixel candidates from the bracketed 1-D solve over the origin X (see above).
  std::vector<Eigen::Vector2d> conicalStarts(const Eigen::Vector3d& point) const;
  // Cosine mismatch for origin X: (o − s)/|o − s|·t − d·t; false where o → P misses the screen.
  bool coneMismatch(double x, const Eigen::Vector3d& point, double* mismatch,
                    Eigen::Vector3d* s) const;
  // Where the primary ray of (u, v) crosses the plane z = point.z, minus the point (x, y).
  bool residual(const Eigen::Vector2d& uv, const Eigen::Vector3d& point, Eigen::Vector2d* r) const;

  const DisplayModel& model_;
  RayFunction rays_;
};

}  // namespace parallax
