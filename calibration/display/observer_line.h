#pragma once
// The line viewers stand on: y = y_obs, z = z_obs (> 0), parallel to x.

#include <Eigen/Core>

namespace parallax {

struct ObserverLine {
  double y = 0.0;  // height (m)
  double z = 2.0;  // distance in front of the screen centre (m)

  Eigen::Vector3d pointAt(double x) const { return {x, y, z}; }
};

}  // namespace parallax
