#pragma once
// The fit's residuals (display_fit.h lists them), each in the Ceres style: the observation held,
// a templated operator() that Ceres differentiates and the statistics call with doubles, the
// math above it, and Create() for the solver's cost function. Every residual is divided by its
// noise level σ (passed as 1/σ) so they are comparable; 1/σ = 1 gives the natural units.
// Parameter blocks (calibration_geometry.h): module[0..12] (quaternion, position, fx fy cx cy
// over the width, k1 k2), camera[0..6] (quaternion, centre), k[0] the screen curvature.
// Internal to parallax_fit.

#include <ceres/ceres.h>

#include <Eigen/Core>

#include "calibration/camera/calibration_geometry.h"

namespace parallax::fit {

// r = (π_module(s(k, camera, n)) − (u, v)) / σ, module px / σ: the camera pixel (n, normalized
// coordinates) back-projects to screen point s, projected into the module and compared with
// the decoded module pixel. Defined wherever the camera sees the screen (a robust start), but
// the camera's noise sits inside the model (errors in variables).
class ModulePxCorrespondenceCost {
 public:
  ModulePxCorrespondenceCost(const Eigen::Vector2d& cameraN, const Eigen::Vector2d& modulePx,
                             double width, double mirrorSign, double invSigma)
      : nx_(cameraN.x()),
        ny_(cameraN.y()),
        u_(modulePx.x()),
        v_(modulePx.y()),
        width_(width),
        mirrorSign_(mirrorSign),
        invSigma_(invSigma) {}

  template <typename T>
  bool operator()(const T* module, const T* camera, const T* k, T* r) const {
    Vec3<T> s;
    if (!screenPointOfCameraRay(k[0], camera, nx_, ny_, &s)) return false;
    T uv[2];
    if (!projectIntoModule(module, width_, mirrorSign_, s, uv)) return false;
    r[0] = (uv[0] - T(u_)) * T(invSigma_);
    r[1] = (uv[1] - T(v_)) * T(invSigma_);
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Vector2d& cameraN,
                                     const Eigen::Vector2d& modulePx, double width,
                                     double mirrorSign, double invSigma) {
    return new ceres::AutoDiffCostFunction<ModulePxCorrespondenceCost, 2, kModuleBlockSize,
                                           kCameraBlockSize, 1>(
        new ModulePxCorrespondenceCost(cameraN, modulePx, width, mirrorSign, invSigma));
  }

 private:
  double nx_, ny_, u_, v_, width_, mirrorSign_, invSigma_;
};

// r = (π_camera(s(module, k, u, v)) − observed camera px) · scale / σ. The noise sits on the
// camera pixel (the decoder locates the pattern in the picture; the module pixel is the code it
// read, exact), so the camera pixel is predicted from the module pixel and stays on the
// measured side: back-projecting the noisy camera pixel instead (ModulePxCorrespondenceCost)
// puts the noise inside the model, which biases least squares. `scale`, module px per camera
// px at this correspondence fixed at the start, keeps the residual in module px like the other
// form, so σ, outliers and reports keep their units.
class CameraPxCorrespondenceCost {
 public:
  CameraPxCorrespondenceCost(const CameraIntrinsics* intrinsics, const Eigen::Vector2d& modulePx,
                             const Eigen::Vector2d& cameraPx, double width, double mirrorSign,
                             double scaleOverSigma)
      : intrinsics_(intrinsics),
        u_(modulePx.x()),
        v_(modulePx.y()),
        cameraU_(cameraPx.x()),
        cameraV_(cameraPx.y()),
        width_(width),
        mirrorSign_(mirrorSign),
        scaleOverSigma_(scaleOverSigma) {}

  template <typename T>
  bool operator()(const T* module, const T* camera, const T* k, T* r) const {
    Vec3<T> s;
    if (!screenPointOfModulePixel(module, width_, mirrorSign_, k[0], u_, v_, &s)) return false;
    T px[2];
    if (!projectIntoCamera(*intrinsics_, camera, s, px)) return false;
    r[0] = (px[0] - T(cameraU_)) * T(scaleOverSigma_);
    r[1] = (px[1] - T(cameraV_)) * T(scaleOverSigma_);
    return true;
  }

  static ceres::CostFunction* Create(const CameraIntrinsics* intrinsics,
                                     const Eigen::Vector2d& modulePx,
                                     const Eigen::Vector2d& cameraPx, double width,
                                     double mirrorSign, double scaleOverSigma) {
    return new ceres::AutoDiffCostFunction<CameraPxCorrespondenceCost, 2, kModuleBlockSize,
                                           kCameraBlockSize, 1>(new CameraPxCorrespondenceCost(
        intrinsics, modulePx, cameraPx, width, mirrorSign, scaleOverSigma));
  }

 private:
  const CameraIntrinsics* intrinsics_;  // fixed: the camera was calibrated before
  double u_, v_, cameraU_, cameraV_, width_, mirrorSign_, scaleOverSigma_;
};

// r = stripeMismatch(s(k, camera, n), p, c) / σ, m / σ (1/σ in 1/m): at a stripe centre seen
// by a camera the transfer sends module light exactly to the camera centre c; s is where the
// camera ray through n meets the screen, p the module's position.
class StripeCost {
 public:
  StripeCost(const Eigen::Vector2d& cameraN, ScreenTransfer transfer, double invSigmaM)
      : nx_(cameraN.x()), ny_(cameraN.y()), invSigmaM_(invSigmaM), transfer_(transfer) {}

  template <typename T>
  bool operator()(const T* module, const T* camera, const T* k, T* r) const {
    Vec3<T> s;
    if (!screenPointOfCameraRay(k[0], camera, nx_, ny_, &s)) return false;
    const Vec3<T> p(module[4], module[5], module[6]);
    const Vec3<T> c(camera[4], camera[5], camera[6]);
    r[0] = stripeMismatch(transfer_, k[0], s, p, c) * T(invSigmaM_);
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Vector2d& cameraN, ScreenTransfer transfer,
                                     double invSigmaM) {
    return new ceres::AutoDiffCostFunction<StripeCost, 1, kModuleBlockSize, kCameraBlockSize, 1>(
        new StripeCost(cameraN, transfer, invSigmaM));
  }

 private:
  double nx_, ny_, invSigmaM_;
  ScreenTransfer transfer_;
};

// r = (π_camera(x, y, sag(k, x)) − observed) / σ, camera px / σ: a marker at (x, y) on the
// screen frame, which follows the screen's curvature.
class FiducialCost {
 public:
  FiducialCost(const CameraIntrinsics* intrinsics, const Eigen::Vector2d& screenXy,
               const Eigen::Vector2d& observedPx, double invSigma)
      : intrinsics_(intrinsics),
        x_(screenXy.x()),
        y_(screenXy.y()),
        px_(observedPx.x()),
        py_(observedPx.y()),
        invSigma_(invSigma) {}

  template <typename T>
  bool operator()(const T* camera, const T* k, T* r) const {
    const Vec3<T> point(T(x_), T(y_), screenSag(k[0], T(x_)));
    T pixel[2];
    if (!projectIntoCamera(*intrinsics_, camera, point, pixel)) return false;
    r[0] = (pixel[0] - T(px_)) * T(invSigma_);
    r[1] = (pixel[1] - T(py_)) * T(invSigma_);
    return true;
  }

  static ceres::CostFunction* Create(const CameraIntrinsics* intrinsics,
                                     const Eigen::Vector2d& screenXy,
                                     const Eigen::Vector2d& observedPx, double invSigma) {
    return new ceres::AutoDiffCostFunction<FiducialCost, 2, kCameraBlockSize, 1>(
        new FiducialCost(intrinsics, screenXy, observedPx, invSigma));
  }

 private:
  const CameraIntrinsics* intrinsics_;
  double x_, y_, px_, py_, invSigma_;
};

// r = (centre − tape) / σ_tape, m / σ: the camera centre near its tape-measured place.
class TapeCost {
 public:
  TapeCost(const Eigen::Vector3d& tape, double invSigma) : tape_(tape), invSigma_(invSigma) {}

  template <typename T>
  bool operator()(const T* camera, T* r) const {
    for (int i = 0; i < 3; ++i) r[i] = (camera[4 + i] - T(tape_[i])) * T(invSigma_);
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Vector3d& tape, double invSigma) {
    return new ceres::AutoDiffCostFunction<TapeCost, 3, kCameraBlockSize>(
        new TapeCost(tape, invSigma));
  }

 private:
  Eigen::Vector3d tape_;
  double invSigma_;
};

}  // namespace parallax::fit
