#pragma once
// The holographic screen: a vertical cylinder section (conventions.h), its transfer model and
// its horizontal diffusion width.

#include <Eigen/Core>
#include <cmath>
#include <string>

namespace parallax {

// How the screen turns a module ray into the ray that reaches the observer line
// (screen_transfer.h has the math of both).
enum class ScreenTransfer {
  kConical,  // the physics of a thin vertical diffuser: keeps the direction cosine along the
             // screen's horizontal tangent (default)
  kLinear,   // the paper's reading: keeps the top-view slope
};

const char* transferName(ScreenTransfer transfer);
// Returns false for an unknown name.
bool parseTransfer(const std::string& name, ScreenTransfer* transfer);

// z(x) = k x² / (1 + sqrt(1 − k² x²)): exact at k = 0 and free of the cancellation that ruins
// R − sqrt(R² − x²) for large R. Templated so Ceres can differentiate it.
template <typename T>
T screenSag(const T& k, const T& x) {
  using std::sqrt;
  return k * x * x / (T(1) + sqrt(T(1) - k * k * x * x));
}

// dz/dx = k x / sqrt(1 − k² x²).
template <typename T>
T screenSlope(const T& k, const T& x) {
  using std::sqrt;
  return k * x / sqrt(T(1) - k * k * x * x);
}

struct Screen {
  double width = 1.6;      // chord: the x extent (m)
  double height = 0.9;     // y extent (m)
  double curvature = 0.0;  // k = 1/R (1/m); k > 0: edges toward the viewers
  ScreenTransfer transfer = ScreenTransfer::kConical;
  double diffusionDeg = 1.0;  // horizontal angular spread of outgoing light (full width)

  double sag(double x) const { return screenSag(curvature, x); }
  double slope(double x) const { return screenSlope(curvature, x); }
  Eigen::Vector3d pointAt(double x, double y) const { return {x, y, sag(x)}; }
  // Unit horizontal tangent (1, 0, z'(x)) normalised; written with the sag's own square root
  // so it stays exact at k = 0: t = (sqrt(1 − k²x²), 0, k x).
  Eigen::Vector3d tangent(double x) const;
  // Unit normal pointing toward the viewers: (−k x, 0, sqrt(1 − k²x²)).
  Eigen::Vector3d frontNormal(double x) const;
  bool contains(double x, double y) const {
    return std::abs(x) <= 0.5 * width && std::abs(y) <= 0.5 * height;
  }

  // The ray p + t·d (d need not be unit) meets the screen surface: the smallest t > 0 where it
  // crosses the screen's own branch of the cylinder inside the screen's extent arriving from
  // behind (crossings from the front are passed through). Returns false when there is none. The hit
  // point is projected onto the surface (z = sag(x)), so it lies on the screen exactly even for k =
  // 0 and grazing rays.
  bool intersect(const Eigen::Vector3d& p, const Eigen::Vector3d& d, double* t,
                 Eigen::Vector3d* hit) const {
    return intersectFrom(p, d, +1.0, true, t, hit);
  }
  // side = +1: the ray must arrive from behind (d·n > 0); −1: from the front. Without
  // withinExtent the surface continues past the screen's edges (searches that must bracket a
  // root lying right at an edge need that).
  bool intersectFrom(const Eigen::Vector3d& p, const Eigen::Vector3d& d, double side,
                     bool withinExtent, double* t, Eigen::Vector3d* hit) const;
};

}  // namespace parallax
