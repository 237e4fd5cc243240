#pragma once
// One optical module (projector): pose, pinhole intrinsics, radial distortion, resolution and
// the rear-projection mirror flag (conventions.h), and ModuleOptics, its precomputed form for
// per-pixel use.

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace parallax {

struct OpticalModule {
  int id = 0;
  Eigen::Vector3d position = {0.0, 0.0, -1.0};  // physical (m), behind the screen
  // physicalFromModule, unit.
  Eigen::Quaterniond orientation = Eigen::Quaterniond(0.0, 0.0, 0.0, 1.0);
  double fx = 1000.0, fy = 1000.0;  // focal lengths (px)
  double cx = 512.0, cy = 384.0;    // principal point (px, centres at +0.5)
  double k1 = 0.0, k2 = 0.0;        // radial distortion (OpenCV convention)
  int width = 1024, height = 768;   // resolution (px)
  bool mirror = true;               // rear projection: image mirrored as seen from the front

  long pixelCount() const { return static_cast<long>(width) * height; }
};

// Largest undistorted radius r at which r·(1 + k1 r² + k2 r⁴) still increases (its derivative
// 1 + 3 k1 r² + 5 k2 r⁴ first reaches zero), or +inf when it never stops.
double maxUndistortedRadius(double k1, double k2);

class ModuleOptics {
 public:
  explicit ModuleOptics(const OpticalModule& module);

  // Unit direction in physical space of the module ray through pixel position (u, v), or
  // false when (u, v) lies beyond the radius where the distortion model folds.
  bool rayDirection(double u, double v, Eigen::Vector3d* direction) const;

  // Pixel position (u, v) that a physical direction from the module projects to; false when
  // it points backward or beyond the fold of the distortion model. Not clipped to the image.
  bool project(const Eigen::Vector3d& direction, Eigen::Vector2d* pixel) const;

  const Eigen::Vector3d& position() const { return position_; }
  const Eigen::Matrix3d& physicalFromModule() const { return physicalFromModule_; }

 private:
  // Undistorted radius for a distorted one (monotone inverse below the fold).
  double undistortRadius(double distorted) const;

  Eigen::Vector3d position_;
  Eigen::Matrix3d physicalFromModule_;
  double fx_, fy_, cx_, cy_, k1_, k2_;
  double mirrorSign_;
  bool distorted_;
  double maxRadius_;           // undistorted
  double maxDistortedRadius_;  // its image
};

}  // namespace parallax
