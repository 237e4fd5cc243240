#pragma once
// The world → physical map: a uniform scale and a translation that fit the scene's box B_W,
// centred, inside the displayable box B_P. No per-axis stretch: it would bend reflections and
// light directions.

#include <Eigen/Core>

#include "calibration/display/box3.h"

namespace parallax {

struct WorldToPhysical {
  double scale = 1.0;
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Eigen::Vector3d point(const Eigen::Vector3d& world) const { return scale * world + translation; }
  Eigen::Vector3d vector(const Eigen::Vector3d& world) const { return scale * world; }
  Eigen::Vector3d worldPoint(const Eigen::Vector3d& physical) const {
    return (physical - translation) / scale;
  }
};

// physicalFromWorld for B_W inside B_P. Throws InputError("world_box") when B_W is empty,
// inverted or not finite.
WorldToPhysical physicalFromWorld(const Box3& worldBox, const Box3& displayableBox);

}  // namespace parallax
