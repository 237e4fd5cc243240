#pragma once
// A simulated display with photometric variation and its colour camera, for photometric
// calibration without hardware (tests, `parallax report`, the demo): a seeded geometric truth
// of a display, a seeded photometric truth, the rig's camera binned 8× (a photometric capture
// needs no resolution) and a FlatFieldCamera that photographs what the modules show through
// the simulated physics (colour_picture_renderer.h). The geometric truth stands in for the
// geometric calibration.

#include <cstdint>
#include <memory>
#include <vector>

#include "calibration/photometry/flat_field_capture.h"
#include "calibration/simulation/camera_renderer.h"
#include "calibration/simulation/photometric_truth.h"

namespace parallax {

class SimulatedPhotometricRig {
 public:
  SimulatedPhotometricRig(const DisplayModel& nominal, std::uint64_t seed,
                          const PhotometricTruthOptions& truthOptions);

  // The flat fields as captureFlatFields takes them, every binned camera pixel.
  FlatFieldCaptures capture(FlatFieldOptions options);
  // Module i's light for its RGB8 frame (uniform frames the fast way).
  cv::Mat light(int module, const std::uint8_t* rgb) const;

  const DisplayModel& geometry() const { return geometry_; }
  PhotometricTruth& photometry() { return photometry_; }  // tests break modules
  const PhotometricTruth& photometry() const { return photometry_; }

  double exposureScale = 1.0;  // a camera whose exposure is off by this much (saturation)
  bool blind = false;          // a camera that gives black pictures

 private:
  cv::Mat take(int station, const std::vector<const std::uint8_t*>& frames, double exposure);

  DisplayModel geometry_;
  PhotometricTruth photometry_;
  CameraIntrinsics intrinsics_;  // binned
  std::vector<CameraPose> poses_;
  CameraRenderOptions sensor_;
  std::vector<std::unique_ptr<StationView>> views_;
  std::vector<cv::Mat> falloff_;             // per module, CV_32F
  mutable std::vector<cv::Mat> blackLight_;  // per module, once asked for
  std::uint64_t pictures_ = 0;
};

}  // namespace parallax
