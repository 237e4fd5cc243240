#pragma once
// The calibration camera's intrinsics from its pictures of a checkerboard (cv::calibrateCamera),
// with our distortion model exactly: radial k1, k2 only (tangential p1 = p2 = 0 and k3 = 0
// held), applied in the projection direction as OpenCV does (conventions.h) — so OpenCV's
// (k1, k2) are ours, and only the principal point moves by half a pixel (pixelFromOpenCv).
// Pictures where the whole board is not found are skipped and named in the result; fewer
// usable pictures than `minPictures` is an InputError.

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "calibration/camera/calibration_camera.h"
#include "calibration/capture/calibration_board.h"
#include "calibration/capture/checkerboard.h"

namespace parallax {

struct CheckerboardPicture {
  std::string name;  // for reports and errors (a file name inside the captures folder)
  cv::Mat recorded;  // 8-bit grey, as the camera recorded it
};

struct CheckerboardCalibrationOptions {
  int minPictures = 4;    // usable pictures needed (each adds six pose unknowns)
  double maxRmsPx = 1.0;  // a larger RMS reprojection error is refused: wrong board or bad pictures
};

struct PictureError {
  std::string name;
  double rmsPx = 0.0;  // RMS reprojection error of this picture's corners
};

struct CheckerboardCalibration {
  CameraIntrinsics intrinsics;  // width and height are the pictures'
  // Standard deviations of fx, fy, cx, cy, k1, k2: the covariance's diagonal (OpenCV's own
  // when it could not be formed).
  double sigmaFx = 0.0, sigmaFy = 0.0, sigmaCx = 0.0, sigmaCy = 0.0, sigmaK1 = 0.0, sigmaK2 = 0.0;
  // Their whole covariance, correlations included (f, k1 and the principal point err
  // together): what a fit holding these intrinsics fixed carries into its own σ. Zero when the
  // corners' information could not be inverted.
  IntrinsicsCovariance covariance = IntrinsicsCovariance::Zero();
  double rmsPx = 0.0;                // over every corner of every used picture
  std::vector<PictureError> used;    // per used picture
  std::vector<std::string> skipped;  // pictures where the board was not found
  double detectSeconds = 0.0, solveSeconds = 0.0;
};

// Throws InputError naming the picture (wrong size, not 8-bit) or, with too few usable
// pictures or a refused fit, the field "pictures".
CheckerboardCalibration calibrateFromCheckerboard(
    const std::vector<CheckerboardPicture>& pictures, const CheckerboardBoard& board, int width,
    int height, const CheckerboardCalibrationOptions& options = {});

// The same from views already found (calibration_board.h's detectBoard; ChArUco's may each
// hold different corners), named for the report. Throws InputError ("pictures") as above.
CheckerboardCalibration calibrateFromViews(const std::vector<std::string>& names,
                                           const std::vector<BoardView>& views, int width,
                                           int height,
                                           const CheckerboardCalibrationOptions& options = {});

// The report: fx, fy, cx, cy, k1, k2 with their σ, the RMS and the worst pictures, the skipped
// ones; with `truth`, each value's error against it.
std::string formatCheckerboardCalibration(const CheckerboardCalibration& result,
                                          const CameraIntrinsics* truth = nullptr);

}  // namespace parallax
