#pragma once
// The texture colours of a first-generation packet's lanes that met one textured diffuse mesh
// (after diffuse_hit_kernel.h), a SIMD vector of lanes at a time (Google Highway, the widest
// instruction set the CPU has, chosen at run time): each hit's uv and texel density
// (textureCoordinatesOf of hit_info.h), the ray cone's footprint there and its mip level (the
// integrator's textureColor), and the trilinear lookup (TextureImage::lookup), a level at a time
// for the lanes that need it. The arithmetic is the scalar code's in Eigen's order, without
// fused multiply-adds, and std::log2 itself lane by lane, so the colours are bit-identical
// whichever target runs.

#include <embree3/rtcore.h>

#include "tracer/physical_scene.h"
#include "tracer/texture_image.h"

namespace parallax {

struct TextureLanes {
  const RTCRayHit16* packet = nullptr;
  unsigned geomID = 0;                  // the mesh's lanes are those with this geomID
  const PhysicalMesh* mesh = nullptr;   // with uvs
  const TextureImage* image = nullptr;  // with at least one level
  bool filtering = true;                // RenderOptions::textureFiltering: the footprint's level
  // Per lane (16): the ray's footprint, width at its origin and growth a metre (Path).
  const float* coneWidth = nullptr;
  const float* coneSpread = nullptr;
  float* color[3] = {};  // out, per lane (16): the texture's colour, in the mesh's lanes
};

void lookUpTextures(const TextureLanes& job);

}  // namespace parallax
