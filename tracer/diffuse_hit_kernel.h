#pragma once
// The commonest first-generation hits, a SIMD vector at a time (Google Highway, chosen at run
// time): the lanes of a packet of 16 primary rays that met one mesh (without vertex colours) of
// a plain diffuse material (no emission); a packet that met several such meshes is shaded by one
// call a mesh. Each lane's hit point (from the
// triangle's vertices), its face normal turned toward the ray and its shading normal (the
// vertex normals interpolated, where the mesh has them; a vector whose lanes met at most three
// triangles reads each triangle's corners once, any other gathers them), with the material's albedo
// and highlight, go into 16 new LitSurfaces entries; the caller adds the ambient term and the frame
// cache's light bits. The arithmetic is hitInfoOf's and reflect's in Eigen's order, without fused
// multiply-adds: bit-identical to the scalar shading.

#include <embree3/rtcore.h>

#include "tracer/lit_surfaces.h"
#include "tracer/physical_scene.h"

namespace parallax {

// Writes the surfaces of the packet's lanes that met mesh `geomID` into `lit`, lane k at index
// first + k (the caller extends `lit`; pixels, and the flags but the highlight and mesh bits, are
// left to it). wholePacket: every lane met this mesh (no masking). Returns false, touching
// nothing, where the CPU's vectors do not divide a packet.
bool shadeDiffusePacket(const RTCRayHit16& packet, unsigned geomID, const PhysicalMesh& mesh,
                        const Material& material, LitSurfaces* lit, size_t first, bool wholePacket);

}  // namespace parallax
