#pragma once
// The simulated calibration camera as it really is: intrinsics, the true pose at every station
// and its sensor (render options, noise seed). Only the simulator (parallax-simhw, `parallax
// simulate`) and tests open this file — camera_truth.json —; a calibration never does (it has
// camera.json: the tape-measured stations).
//
//   {"format": "parallax-camera-truth", "version": 1, "seed": S,
//    intrinsics: {...as in camera.json...},
//    poses: [{centre: [x, y, z], physical_from_camera: [w, x, y, z]}],
//    sensor: {ambient, gamma, noise_sigma, blur_sigma_px, fiducial_radius_m, fiducial_brightness}}

#include <cstdint>
#include <string>
#include <vector>

#include "calibration/camera/calibration_camera.h"
#include "calibration/simulation/camera_renderer.h"

namespace parallax {

struct CameraTruth {
  CameraIntrinsics intrinsics;
  std::vector<CameraPose> poses;  // per station
  CameraRenderOptions sensor;
  std::uint64_t seed = 1;  // of the sensor noise
};

void saveCameraTruth(const CameraTruth& truth, const std::string& path);
// Throws InputError naming the file and the field.
CameraTruth loadCameraTruth(const std::string& path);

}  // namespace parallax
