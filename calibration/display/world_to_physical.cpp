#include "calibration/display/world_to_physical.h"

#include <fmt/format.h>

#include <cmath>
#include <limits>

#include "common/input_error.h"

namespace parallax {

WorldToPhysical physicalFromWorld(const Box3& worldBox, const Box3& displayableBox) {
  const Eigen::Vector3d worldSize = worldBox.size();
  const Eigen::Vector3d physicalSize = displayableBox.size();
  double scale = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 3; ++i) {
    if (!std::isfinite(worldBox.min[i]) || !std::isfinite(worldBox.max[i])) {
      throw InputError({"", "world_box", 0}, "bounds must be finite");
    }
    // A flat B_W (zero extent on one axis, e.g. a single plane) constrains nothing there.
    if (worldSize[i] < 0.0) {
      throw InputError({"", "world_box", 0},
                       fmt::format("max must not be below min (axis {}: {} vs {})", i,
                                   worldBox.min[i], worldBox.max[i]));
    }
    if (worldSize[i] > 0.0) scale = std::min(scale, physicalSize[i] / worldSize[i]);
  }
  if (!std::isfinite(scale) || !(scale > 0.0)) {
    throw InputError({"", "world_box", 0}, "the box is a single point; it needs an extent");
  }
  WorldToPhysical map;
  map.scale = scale;
  map.translation = displayableBox.center() - scale * worldBox.center();
  return map;
}

}  // namespace parallax
