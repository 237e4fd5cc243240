#pragma once
// What the simulated calibration camera sees, given what every module currently shows.
// CalibrationPhysics (hw/simulator/calibration_physics.h) renders the screen of a ground-truth
// display from the camera's station; RawPatternPhysics, the stand-in for link tests, returns the
// pattern of the module being looked at, unchanged.

#include <memory>
#include <span>

#include "hw/link/camera_settings.h"
#include "hw/link/image.h"

namespace parallax::hw {

class CameraPhysics {
 public:
  virtual ~CameraPhysics() = default;
  // `frames[i]` is module i's last verified frame (empty when it has none yet). An empty
  // image means "cannot take this picture" (answered unsupported).
  virtual Image render(std::span<const Image* const> frames, int viewModule, int station,
                       const CameraSettings& settings) const = 0;
};

class RawPatternPhysics : public CameraPhysics {
 public:
  Image render(std::span<const Image* const> frames, int viewModule, int station,
               const CameraSettings& settings) const override;
};

}  // namespace parallax::hw
