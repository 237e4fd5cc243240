#pragma once
// An axis-aligned box (B_W in world space, B_P in physical space).

#include <Eigen/Core>

namespace parallax {

struct Box3 {
  Eigen::Vector3d min = Eigen::Vector3d::Zero();
  Eigen::Vector3d max = Eigen::Vector3d::Zero();

  Eigen::Vector3d size() const { return max - min; }
  Eigen::Vector3d center() const { return 0.5 * (min + max); }
  bool contains(const Eigen::Vector3d& p) const {
    return (p.array() >= min.array()).all() && (p.array() <= max.array()).all();
  }
};

}  // namespace parallax
