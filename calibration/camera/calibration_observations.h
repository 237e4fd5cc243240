#pragma once
// What a calibration run has to work with, and nothing more: the calibration camera's
// intrinsics (from its checkerboard captures), the tape-measured camera positions, the
// fiducials' known places on the screen frame, and what was decoded from the images —
// correspondences (camera pixel ↔ module pixel that lit it), stripe centres (where, in one
// camera row, a module's light peaks: its light leaves that screen point toward the camera)
// and fiducial sightings. The true camera poses and the true display are never in here.

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "calibration/camera/calibration_camera.h"
#include "calibration/camera/camera_response_check.h"

namespace parallax {

struct CameraStation {
  Eigen::Vector3d tapeCentre = Eigen::Vector3d::Zero();  // measured by hand: cm accuracy
};

struct Correspondence {
  int camera = 0;
  int module = 0;
  Eigen::Vector2d cameraPx = Eigen::Vector2d::Zero();  // pixel centres at +0.5
  Eigen::Vector2d modulePx = Eigen::Vector2d::Zero();
};

struct StripeCentre {
  int camera = 0;
  int module = 0;
  Eigen::Vector2d cameraPx = Eigen::Vector2d::Zero();
};

struct FiducialSighting {
  int camera = 0;
  int fiducial = 0;
  Eigen::Vector2d cameraPx = Eigen::Vector2d::Zero();
};

struct CalibrationObservations {
  CameraIntrinsics intrinsics;
  // Their uncertainty when they were estimated (the checkerboard's; zero: taken as exact). The
  // fit holds them fixed and carries this into its σ (fit_uncertainty.h).
  IntrinsicsCovariance intrinsicsCovariance = IntrinsicsCovariance::Zero();
  std::vector<CameraStation> stations;
  std::vector<Eigen::Vector2d> fiducials;  // (x, y) on the screen surface, z = sag(x)
  std::vector<Correspondence> correspondences;
  std::vector<StripeCentre> stripes;
  std::vector<FiducialSighting> fiducialSightings;
  std::optional<CameraResponseCheck> cameraResponse;  // decoded from pictures only
  // Decoded from pictures: the lens blur the decoder undid (capture_decoder.h), nullopt when
  // camera.json did not state one.
  std::optional<double> lensBlurSigmaPx;
};

}  // namespace parallax
