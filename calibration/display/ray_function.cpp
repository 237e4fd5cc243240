#include "calibration/display/ray_function.h"

#include "calibration/display/screen_transfer.h"

namespace parallax {

const char* rayStatusName(RayStatus status) {
  switch (status) {
    case RayStatus::kValid:
      return "valid";
    case RayStatus::kOutsideLens:
      return "outside the lens model";
    case RayStatus::kMissesScreen:
      return "misses the screen";
    case RayStatus::kNoTransfer:
      return "no transfer to the observer line";
  }
  return "?";
}

RayFunction::RayFunction(const DisplayModel& model, int moduleIndex)
    : model_(model),
      module_(model.modules.at(static_cast<size_t>(moduleIndex))),
      optics_(module_) {}

PixelRay RayFunction::trace(double u, double v, bool withinExtent) const {
  PixelRay ray;
  if (!optics_.rayDirection(u, v, &ray.moduleDirection)) {
    ray.status = RayStatus::kOutsideLens;
    return ray;
  }
  double t;
  if (!model_.screen.intersectFrom(optics_.position(), ray.moduleDirection, +1.0, withinExtent, &t,
                                   &ray.screenPoint)) {
    ray.status = RayStatus::kMissesScreen;
    return ray;
  }
  double x;
  if (!transferToObserverLine(model_.screen, model_.observer, ray.screenPoint, ray.moduleDirection,
                              &x)) {
    ray.status = RayStatus::kNoTransfer;
    return ray;
  }
  ray.origin = model_.observer.pointAt(x);
  ray.status = RayStatus::kValid;
  return ray;
}

}  // namespace parallax
