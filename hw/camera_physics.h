#pragma once
// What the simulated calibration camera sees, given what every module currently shows. The
// calibration engineer supplies the real physics (rendering the screen from a ground-truth
// DisplayModel, in calibration/, which hw/ may call); until then RawPatternPhysics returns
// the pattern of the module being looked at, unchanged.

#include <memory>
#include <span>

#include "hw/image.h"

namespace parallax::hw {

struct CameraSettings {
  uint32_t exposureUs = 10000;
  double gain = 1.0;
  double whiteBalanceRed = 1.0, whiteBalanceBlue = 1.0;
};

class CameraPhysics {
 public:
  virtual ~CameraPhysics() = default;
  // `frames[i]` is module i's last verified frame (empty when it has none yet).
  virtual Image render(std::span<const Image* const> frames, int viewModule,
                       const CameraSettings& settings) const = 0;
};

class RawPatternPhysics : public CameraPhysics {
 public:
  Image render(std::span<const Image* const> frames, int viewModule,
               const CameraSettings& settings) const override;
};

}  // namespace parallax::hw
