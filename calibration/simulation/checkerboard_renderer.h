#pragma once
// The simulated calibration camera's pictures of the checkerboard (checkerboard.h), through its
// true model (pinhole + radial distortion, calibration_camera.h) and its sensor (lens blur,
// response curve, noise: camera_renderer.h's recordThroughSensor), as camera_renderer.h
// renders the screen. Edges are antialiased: a pixel whose four corners fall in different cells
// of the board is supersampled 8 × 8 (the board point of each sample interpolated between the
// exact board points of the pixel's corners), so the corners' subpixel positions mean something.
//
// The poses are seeded and spread to make every intrinsic observable: board centres stratified
// over a 3 × 3 grid of the frame (corners first, where the distortion is strongest), distances
// that make the sheet fill 35–70% of the picture's width, tilted 20–45° about a random axis in
// its plane and rolled up to ±20°.

#include <Eigen/Geometry>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "calibration/camera/calibration_camera.h"
#include "calibration/capture/checkerboard.h"
#include "calibration/simulation/camera_renderer.h"
#include "calibration/simulation/seeded_random.h"

namespace parallax {

struct CheckerboardShotOptions {
  int pictures = 12;
  double minFill = 0.35,
         maxFill = 0.7;  // the sheet's width over the picture's, at its centre's depth
  double minTiltDeg = 20.0, maxTiltDeg = 45.0;
  double maxRollDeg = 20.0;
  double whiteReflectance = 0.75, blackReflectance = 0.05;  // the print, under unit light
  double background = 0.15;    // linear light of the room behind the board
  double lightFalloff = 0.15;  // light falls by this fraction across the sheet (uneven lighting)

  // Throws InputError naming the field.
  void validate() const;
};

// Pose of the board in the camera frame: camera point = cameraFromBoard · board point.
std::vector<Eigen::Isometry3d> checkerboardPoses(const CheckerboardBoard& board,
                                                 const CameraIntrinsics& intrinsics,
                                                 const CheckerboardShotOptions& options,
                                                 SeededRandom& random);

// The light reaching each camera pixel (CV_32F, linear), before the sensor.
cv::Mat checkerboardLight(const CheckerboardBoard& board, const CameraIntrinsics& intrinsics,
                          const Eigen::Isometry3d& cameraFromBoard,
                          const CheckerboardShotOptions& options);

// The recorded 8-bit pictures of `poses` (the camera's sensor options and noise from `random`).
std::vector<cv::Mat> photographCheckerboard(const CheckerboardBoard& board,
                                            const CameraIntrinsics& intrinsics,
                                            const std::vector<Eigen::Isometry3d>& poses,
                                            const CameraRenderOptions& sensor,
                                            const CheckerboardShotOptions& options,
                                            SeededRandom& random);

}  // namespace parallax
