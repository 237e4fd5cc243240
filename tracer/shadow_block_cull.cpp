// Compiled once per instruction set by Highway's foreach_target, as shadow_ray_kernel.cpp is:
// the box of a tile's surfaces is worked out for every ray generation of every tile.
#ifndef HWY_DISABLED_TARGETS
#define HWY_DISABLED_TARGETS HWY_SSSE3
#endif
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "tracer/shadow_block_cull.cpp"
#include "tracer/shadow_block_cull.h"

#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>

HWY_BEFORE_NAMESPACE();
namespace parallax {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

SurfaceSpread SpreadOf(const LitSurfaces& surfaces) {
  SurfaceSpread spread;
  const size_t n = surfaces.size();
  if (n == 0) return spread;
  const hn::ScalableTag<float> d;
  const hn::RebindToSigned<decltype(d)> di;
  const size_t lanes = hn::Lanes(d);
  const float* axis[3] = {surfaces.field(LitSurfaces::kPx), surfaces.field(LitSurfaces::kPy),
                          surfaces.field(LitSurfaces::kPz)};
  const std::int32_t* flags = surfaces.flags();
  // The mesh bits and the bare-face bit of every surface the same, the bit set.
  const std::int32_t bits =
      static_cast<std::int32_t>(~0u << LitSurfaces::kMeshShift) | LitSurfaces::kLeavesMesh;
  const std::int32_t first = flags[0] & bits;
  const auto firstBits = hn::Set(di, first), bitMask = hn::Set(di, bits);
  const auto infinity = hn::Set(d, std::numeric_limits<float>::infinity());
  hn::Vec<decltype(d)> lo[3] = {infinity, infinity, infinity};
  hn::Vec<decltype(d)> hi[3] = {hn::Neg(infinity), hn::Neg(infinity), hn::Neg(infinity)};
  auto finite = hn::FirstN(d, lanes);
  auto same = hn::FirstN(di, lanes);
  for (size_t j = 0; j < n; j += lanes) {
    const auto valid = hn::FirstN(d, n - j);
    for (int a = 0; a < 3; ++a) {
      const auto v = hn::LoadU(d, axis[a] + j);
      // Lanes past the end leave the box as it is (and count as finite).
      finite = hn::And(finite, hn::Or(hn::IsFinite(v), hn::Not(valid)));
      lo[a] = hn::IfThenElse(valid, hn::Min(lo[a], v), lo[a]);
      hi[a] = hn::IfThenElse(valid, hn::Max(hi[a], v), hi[a]);
    }
    const auto own = hn::And(hn::LoadU(di, flags + j), bitMask);
    same = hn::And(same, hn::Or(hn::Eq(own, firstBits), hn::Not(hn::RebindMask(di, valid))));
  }
  if (!hn::AllTrue(d, finite)) return spread;
  Eigen::Vector3d low, high;
  for (int a = 0; a < 3; ++a) {
    low[a] = hn::GetLane(hn::MinOfLanes(d, lo[a]));
    high[a] = hn::GetLane(hn::MaxOfLanes(d, hi[a]));
  }
  if ((first & LitSurfaces::kLeavesMesh) && hn::AllTrue(di, same))
    spread.leaves = first >> LitSurfaces::kMeshShift;
  spread.centre = 0.5 * (low + high);
  // The rays start off the surfaces by at most 256 ulps or 1/65536 along the unit normal
  // (OffsetCoordinate): 1e-4 of the largest coordinate, and 1e-4, hold that three times over.
  const double largest = std::max(low.cwiseAbs().maxCoeff(), high.cwiseAbs().maxCoeff());
  spread.radius = 0.5 * (high - low).norm() + 1e-4 * (largest + 1.0);
  spread.known = true;
  return spread;
}

}  // namespace HWY_NAMESPACE
}  // namespace parallax
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace parallax {

HWY_EXPORT(SpreadOf);

SurfaceSpread spreadOf(const LitSurfaces& surfaces) {
  return HWY_DYNAMIC_DISPATCH(SpreadOf)(surfaces);
}

std::size_t occludersWithin(const SurfaceSpread& spread, const Eigen::Vector3f& toLight,
                            const OccluderBound* occluders, std::size_t count, const int* planeSide,
                            std::uint8_t* active) {
  std::size_t kept = 0;
  const Eigen::Vector3d l = toLight.cast<double>();
  const double radius = spread.radius;
  for (std::size_t k = 0; k < count; ++k) {
    if (spread.known) {
      const OccluderBound& bound = occluders[k];
      if (static_cast<std::int32_t>(k) == spread.leaves) continue;
      // Beside the sphere: the kernel's ray from a passes beside when |w|² − (w · l)² > r² +
      // 1e-5 |w|²; a line through a point within `radius` of the centre q lies at least
      // D − radius from the sphere's centre (D: from q's line), and |w| ≤ |c − q| + radius.
      // Twice the allowance covers the kernel's rounding. Behind it: (c − a) · l + r < 0 for
      // every a.
      const Eigen::Vector3d w = bound.sphere.head<3>().cast<double>() - spread.centre;
      const double r = bound.sphere.w();
      const double along = w.dot(l);
      const double farthest = w.norm() + radius;
      const double beside = std::sqrt(std::max(0.0, w.squaredNorm() - along * along)) - radius;
      if (beside > 0.0 && beside * beside > r * r + 2e-5 * farthest * farthest) continue;
      if (along + radius * (1.0 + 1e-6) + r < -1e-5 * farthest) continue;
      // A flat mesh whose plane every ray starts on the far side of, heading away.
      if (bound.flat() && planeSide[k] != 0) {
        const double start =
            bound.plane.head<3>().cast<double>().dot(spread.centre) - bound.plane.w();
        const double margin = bound.planeMargin + 1e-5 * (spread.centre.norm() + radius);
        const double reach = radius * (1.0 + 1e-6);
        if (planeSide[k] > 0 && start - reach > margin) continue;
        if (planeSide[k] < 0 && start + reach < -margin) continue;
      }
    }
    active[kept++] = static_cast<std::uint8_t>(k);
  }
  return kept;
}

}  // namespace parallax
#endif  // HWY_ONCE
