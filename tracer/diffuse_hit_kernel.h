#pragma once
// The commonest first-generation hits, a SIMD vector at a time (Google Highway, chosen at run
// time): a whole packet of 16 primary rays that all met the same mesh, flat-shaded (no vertex
// normals or colours), of a plain diffuse material (no texture, no emission). Each lane's hit
// point (from the triangle's vertices) and its face normal turned toward the ray, with the
// material's albedo and highlight, go into 16 new LitSurfaces entries; the caller adds the
// ambient term and the frame cache's light bits. The arithmetic is hitInfoOf's and reflect's
// in Eigen's order, without fused multiply-adds: bit-identical to the scalar shading.

#include <embree3/rtcore.h>

#include "tracer/lit_surfaces.h"
#include "tracer/physical_scene.h"

namespace parallax {

// Appends the packet's 16 surfaces to `lit` (pixels and flags but the highlight bit left to the
// caller). Returns false, touching nothing, where the CPU's vectors do not divide a packet.
bool shadeDiffusePacket(const RTCRayHit16& packet, const PhysicalMesh& mesh,
                        const Material& material, LitSurfaces* lit);

}  // namespace parallax
