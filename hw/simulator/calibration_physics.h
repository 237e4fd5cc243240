#pragma once
// The simulated calibration camera's real physics for parallax-simhw: the screen of a
// ground-truth display photographed from the camera's true pose at the requested station
// (calibration/simulation/camera_renderer.h: the HPO lobe, ambient light, the fiducial markers,
// blur, the sensor's response and noise), given what every module currently shows.
//
// Without a photometric truth, module frames are read as linear light, value / 255 (a module's
// response is taken as linear: the patterns the host sends are 8-bit linear), and exposure,
// gain and white balance are accepted and held but do not change the picture. With one
// (calibration/simulation/photometric_truth.h) every module shows its truth's light (response,
// black, primaries, falloff) and the exposure scales the light (10 ms = 1). The picture is 8-bit
// grey (the light's luminance), or RGB when the capture asks for colour (the photometric
// capture), through the sensor's response curve, as a camera gives it.

#include <memory>
#include <mutex>
#include <optional>
#include <vector>

#include "calibration/display/display_model.h"
#include "calibration/simulation/camera_renderer.h"
#include "calibration/simulation/camera_truth.h"
#include "calibration/simulation/photometric_truth.h"
#include "calibration/simulation/seeded_random.h"
#include "hw/simulator/camera_physics.h"

namespace parallax::hw {

class CalibrationPhysics : public CameraPhysics {
 public:
  // Throws InputError when the truth's modules differ in size (the simulator's modules share one).
  CalibrationPhysics(DisplayModel truth, CameraTruth camera,
                     std::optional<PhotometricTruth> photometry = std::nullopt);
  Image render(std::span<const Image* const> frames, int viewModule, int station,
               const CameraSettings& settings) const override;

 private:
  const StationView& view(int station) const;

  // Module m's light for its frame: CV_32FC3 (R, G, B).
  cv::Mat moduleLight(int m, const Image& frame) const;

  DisplayModel truth_;
  CameraTruth camera_;
  std::optional<PhotometricTruth> photometry_;
  mutable std::vector<std::unique_ptr<StationView>> views_;  // per station, made on first use
  mutable SeededRandom random_;
  mutable std::mutex mutex_;
};

}  // namespace parallax::hw
