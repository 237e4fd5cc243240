#pragma once
// The calibration camera: pinhole intrinsics with OpenCV radial distortion (the same
// conventions as a module, conventions.h: pixel centres at +0.5, distortion applied in the
// projection direction) and a pose physicalFromCamera. The camera frame is OpenCV's: x right,
// y down, z forward. A camera on the observer line looks back at the screen (toward −z).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "calibration/display/display_model.h"

namespace parallax {

struct CameraIntrinsics {
  int width = 1920, height = 1080;
  double fx = 2100.0, fy = 2100.0;
  double cx = 960.0, cy = 540.0;  // pixel centres at +0.5
  double k1 = 0.0, k2 = 0.0;

  // Pixel of a camera-frame point; false behind the camera.
  bool project(const Eigen::Vector3d& cameraPoint, Eigen::Vector2d* pixel) const;
  // Undistorted normalized coordinates (x/z, y/z) of a pixel position (fixed-point inversion
  // of the radial polynomial, as OpenCV's undistortPoints does; exact enough for |k| < 0.3).
  Eigen::Vector2d normalized(const Eigen::Vector2d& pixel) const;
  bool contains(const Eigen::Vector2d& pixel) const {
    return pixel.x() >= 0.0 && pixel.y() >= 0.0 && pixel.x() < width && pixel.y() < height;
  }

  // A width × height sensor with square pixels of focal length `focalPx`, the principal point
  // at the image centre, radial distortion k1 (simulated cameras and tests).
  static CameraIntrinsics centred(int width, int height, double focalPx, double k1 = 0.0) {
    CameraIntrinsics c;
    c.width = width;
    c.height = height;
    c.fx = c.fy = focalPx;
    c.cx = 0.5 * width;
    c.cy = 0.5 * height;
    c.k1 = k1;
    return c;
  }
};

// The six intrinsics a checkerboard calibration estimates, in the order of their covariance
// wherever one is carried: fx, fy, cx, cy, k1, k2.
inline constexpr int kIntrinsicsParameters = 6;
using IntrinsicsCovariance = Eigen::Matrix<double, kIntrinsicsParameters, kIntrinsicsParameters>;
double& intrinsicsParameter(CameraIntrinsics& intrinsics, int index);

struct CameraPose {
  Eigen::Quaterniond physicalFromCamera = Eigen::Quaterniond::Identity();
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  // physical (m)

  Eigen::Vector3d cameraFromPhysical(const Eigen::Vector3d& p) const {
    return physicalFromCamera.conjugate() * (p - centre);
  }
};

// Orientation of an upright camera at `centre` looking at `target`.
Eigen::Quaterniond aimCameraAt(const Eigen::Vector3d& centre, const Eigen::Vector3d& target);

// Pixel of a physical point seen by a camera; false when behind it.
bool projectPhysical(const CameraIntrinsics& intrinsics, const CameraPose& pose,
                     const Eigen::Vector3d& point, Eigen::Vector2d* pixel);

// The fiducial markers on the screen frame: (x, y) positions on the screen surface (z =
// sag(x)), the corners and the middles of the edges. Their z depends on the curvature, so they
// tell the fit about k as well as about the camera pose.
std::vector<Eigen::Vector2d> screenFiducials(const Screen& screen);

}  // namespace parallax
