#pragma once
// The texture colours of a first-generation packet's lanes that met one textured diffuse mesh
// (after diffuse_hit_kernel.h), a SIMD vector of lanes at a time (Google Highway, the widest
// instruction set the CPU has, chosen at run time): each hit's uv and texel density
// (textureCoordinatesOf of hit_info.h), the ray's cone from its neighbours' rays where not
// known yet (the integrator's cone()), the cone's footprint at the hit and its mip level (its
// textureColor), and the trilinear lookup (TextureImage::lookup), a level at a time for the
// lanes that need it. The arithmetic is the scalar code's in Eigen's order, without
// fused multiply-adds, and std::log2 itself lane by lane, so the colours are bit-identical
// whichever target runs.

#include <embree3/rtcore.h>

#include <cstdint>

#include "calibration/display/ray_textures.h"
#include "tracer/physical_scene.h"
#include "tracer/texture_image.h"

namespace parallax {

struct TextureLanes {
  const RTCRayHit16* packet = nullptr;
  unsigned geomID = 0;                  // the mesh's lanes are those with this geomID
  const PhysicalMesh* mesh = nullptr;   // with uvs
  const TextureImage* image = nullptr;  // with at least one level
  bool filtering = true;                // RenderOptions::textureFiltering: the footprint's level
  // Per lane (16): the ray's footprint, width at its origin and growth a metre (Path). In the
  // lanes of `coneUnknown` (nonzero) the footprint is computed here first (the integrator's
  // cone(): from the neighbouring pixels' rays in `textures`, `pixel` the lane's), coneWidth
  // holding the distance its origin was advanced; both are written back.
  float* coneWidth = nullptr;
  float* coneSpread = nullptr;
  const std::int32_t* coneUnknown = nullptr;
  const std::int32_t* pixel = nullptr;
  const RayTextures* textures = nullptr;
  float* color[3] = {};  // out, per lane (16): the texture's colour, in the mesh's lanes
};

void lookUpTextures(const TextureLanes& job);

}  // namespace parallax
