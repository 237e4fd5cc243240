#pragma once
// The paper's Algorithm 1, made precise: pixel position (u, v) of a module → its primary ray,
// which starts at o on the observer line and passes through the screen point s that the module
// ray of (u, v) lands on (conventions.h, screen_transfer.h). One function of continuous (u, v)
// serves pixel centres (i + 0.5, j + 0.5) and sub-pixel samples alike.

#include <Eigen/Core>
#include <cstdint>

#include "calibration/display/display_model.h"
#include "calibration/display/optical_module.h"

namespace parallax {

enum class RayStatus : std::uint8_t {
  kValid,
  kOutsideLens,   // beyond the radius where the distortion model folds
  kMissesScreen,  // the module ray does not land on the screen
  kNoTransfer,    // the screen transfer has no ray to the observer line
};

const char* rayStatusName(RayStatus status);

struct PixelRay {
  RayStatus status = RayStatus::kMissesScreen;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();           // o, on the observer line
  Eigen::Vector3d screenPoint = Eigen::Vector3d::Zero();      // s, on the screen
  Eigen::Vector3d moduleDirection = Eigen::Vector3d::Zero();  // unit, module → s

  bool valid() const { return status == RayStatus::kValid; }
  // Unit direction of the primary ray, from o through s into the scene.
  Eigen::Vector3d direction() const { return (screenPoint - origin).normalized(); }
};

class RayFunction {
 public:
  RayFunction(const DisplayModel& model, int moduleIndex);

  PixelRay at(double u, double v) const { return trace(u, v, true); }
  // The same map continued past the screen's edges: smooth everywhere the transfer is, so
  // solvers (the forward map's Newton) can difference it right at an edge.
  PixelRay atUnclipped(double u, double v) const { return trace(u, v, false); }
  PixelRay atPixel(int column, int row) const { return at(column + 0.5, row + 0.5); }

  const DisplayModel& model() const { return model_; }
  const OpticalModule& module() const { return module_; }
  const ModuleOptics& optics() const { return optics_; }

 private:
  PixelRay trace(double u, double v, bool withinExtent) const;

  const DisplayModel& model_;
  const OpticalModule& module_;
  ModuleOptics optics_;
};

}  // namespace parallax
