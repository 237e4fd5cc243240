#include "calibration/camera/calibration_camera.h"

#include "calibration/display/conventions.h"
#include "common/check.h"

namespace parallax {

bool CameraIntrinsics::project(const Eigen::Vector3d& q, Eigen::Vector2d* pixel) const {
  if (!(q.z() > 0.0)) return false;
  const double x = q.x() / q.z();
  const double y = q.y() / q.z();
  const double r2 = x * x + y * y;
  const double scale = 1.0 + k1 * r2 + k2 * r2 * r2;
  *pixel = {fx * x * scale + cx, fy * y * scale + cy};
  return true;
}

Eigen::Vector2d CameraIntrinsics::normalized(const Eigen::Vector2d& pixel) const {
  const double xd = (pixel.x() - cx) / fx;
  const double yd = (pixel.y() - cy) / fy;
  double x = xd, y = yd;
  // Fixed point x = xd / (1 + k1 r² + k2 r⁴): converges fast for a camera's mild distortion.
  for (int i = 0; i < 20; ++i) {
    const double r2 = x * x + y * y;
    const double scale = 1.0 + k1 * r2 + k2 * r2 * r2;
    x = xd / scale;
    y = yd / scale;
  }
  return {x, y};
}

double& intrinsicsParameter(CameraIntrinsics& intrinsics, int index) {
  switch (index) {
    case 0:
      return intrinsics.fx;
    case 1:
      return intrinsics.fy;
    case 2:
      return intrinsics.cx;
    case 3:
      return intrinsics.cy;
    case 4:
      return intrinsics.k1;
    case 5:
      return intrinsics.k2;
  }
  PARALLAX_CHECK(index >= 0 && index < kIntrinsicsParameters);
  return intrinsics.fx;
}

Eigen::Quaterniond aimCameraAt(const Eigen::Vector3d& centre, const Eigen::Vector3d& target) {
  return uprightLookingAt(centre, target);
}

bool projectPhysical(const CameraIntrinsics& intrinsics, const CameraPose& pose,
                     const Eigen::Vector3d& point, Eigen::Vector2d* pixel) {
  return intrinsics.project(pose.cameraFromPhysical(point), pixel);
}

std::vector<Eigen::Vector2d> screenFiducials(const Screen& screen) {
  const double hx = 0.5 * screen.width, hy = 0.5 * screen.height;
  return {{-hx, -hy}, {0.0, -hy}, {hx, -hy}, {-hx, 0.0}, {hx, 0.0}, {-hx, hy}, {0.0, hy}, {hx, hy}};
}

}  // namespace parallax
