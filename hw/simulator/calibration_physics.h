#pragma once
// The simulated calibration camera's real physics for parallax-simhw: the screen of a
// ground-truth display photographed from the camera's true pose at the requested station
// (calibration/simulation/camera_renderer.h: the HPO lobe, ambient light, the fiducial markers,
// blur, the sensor's response and noise), given what every module currently shows.
//
// Module frames are read as linear light, value / 255 (a module's response is taken as linear:
// the patterns the host sends are 8-bit linear). The picture is 8-bit grey, through the
// sensor's response curve, as a camera gives it. Exposure, gain and white balance are
// accepted and held (the host locks them) but do not change the picture.

#include <memory>
#include <mutex>
#include <vector>

#include "calibration/display/display_model.h"
#include "calibration/simulation/camera_renderer.h"
#include "calibration/simulation/camera_truth.h"
#include "calibration/simulation/seeded_random.h"
#include "hw/simulator/camera_physics.h"

namespace parallax::hw {

class CalibrationPhysics : public CameraPhysics {
 public:
  // Throws InputError when the truth's modules differ in size (the simulator's modules share one).
  CalibrationPhysics(DisplayModel truth, CameraTruth camera);
  Image render(std::span<const Image* const> frames, int viewModule, int station,
               const CameraSettings& settings) const override;

 private:
  const StationView& view(int station) const;

  DisplayModel truth_;
  CameraTruth camera_;
  mutable std::vector<std::unique_ptr<StationView>> views_;  // per station, made on first use
  mutable SeededRandom random_;
  mutable std::mutex mutex_;
};

}  // namespace parallax::hw
