#pragma once
// Which meshes' bounds some shadow ray of a tile's lit surfaces may meet, toward one directional
// light. The shadow-ray kernel tests every ray against every mesh's bound (OccluderBound); on
// `orbit.lua` most tiles' surfaces (the floor's, the wall's) lie far from the moving objects,
// and a ray's tests against bounds it cannot reach were most of the kernel's time. One test per
// tile, light and mesh now leaves such a mesh out of the kernel's loops.
//
// A mesh is left out only where every ray from the surfaces would pass its bound in the
// kernel's own per-ray test (MayMeetSphere: beside or behind its sphere; a flat mesh's plane the
// ray stays on one side of; the mesh the surfaces leave), with margins beyond its rounding: the
// rays that go to Embree, and so the frame, are the same as without this.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>

#include "tracer/lit_surfaces.h"
#include "tracer/physical_scene.h"

namespace parallax {

// Where a tile's lit surfaces lie: a ball that holds every shadow ray's start.
struct SurfaceSpread {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double radius = 0.0;
  std::int32_t leaves = -1;  // the mesh every surface leaves by a bare face, else −1
  bool known = false;        // false: no surfaces, or a position not finite (every mesh stays)
};
SurfaceSpread spreadOf(const LitSurfaces& surfaces);

// The meshes some ray from `spread` toward the directional light `toLight` may meet: their
// indices into `active` (room for `count`), how many returned. `planeSide[k]`: which side of
// flat mesh k's plane the light lies on (+1, −1; 0: no plane test), as in the kernel.
std::size_t occludersWithin(const SurfaceSpread& spread, const Eigen::Vector3f& toLight,
                            const OccluderBound* occluders, std::size_t count, const int* planeSide,
                            std::uint8_t* active);

}  // namespace parallax
