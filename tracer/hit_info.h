#pragma once
// What shading needs to know about a ray's hit on a triangle: position (from the vertices),
// normals facing the incoming ray, uv, vertex colour, and the texel density for the texture
// footprint. Inline: it sits in the integrator's hot path. Shared by the Whitted integrator and the
// rasterizer's direct shading.

#include <Eigen/Core>
#include <cmath>

#include "tracer/physical_scene.h"

namespace parallax {

struct HitInfo {
  Eigen::Vector3f position;
  Eigen::Vector3f geometricNormal;  // unit, facing the incoming ray
  Eigen::Vector3f shadingNormal;    // unit, same side as geometricNormal
  bool frontFace = true;            // the ray arrived on the side the CCW normal points to
  Eigen::Vector2f uv = Eigen::Vector2f::Zero();
  Rgb vertexColor = Rgb::Ones();
  float texelsPerMetreSq = 0.0f;  // uv area / physical area (for the texture footprint)
};

// The hit's uv and texel density (h->uv, h->texelsPerMetreSq; left as they are on a mesh without
// uvs). (u, v): Embree's barycentrics of vertices 1 and 2.
[[gnu::always_inline]] inline void textureCoordinatesOf(const PhysicalMesh& mesh, unsigned prim,
                                                        float u, float v, HitInfo* h) {
  if (mesh.uvs.empty()) return;
  const auto& tri = mesh.triangles[prim];
  const float w = 1.0f - u - v;
  const Eigen::Vector2f& t0 = mesh.uvs[tri[0]];
  const Eigen::Vector2f& t1 = mesh.uvs[tri[1]];
  const Eigen::Vector2f& t2 = mesh.uvs[tri[2]];
  h->uv = w * t0 + u * t1 + v * t2;
  const Eigen::Vector2f a = t1 - t0, b = t2 - t0;
  const float uvArea = std::abs(a.x() * b.y() - a.y() * b.x());
  h->texelsPerMetreSq = uvArea / mesh.crossLengths[prim];
}

// (u, v): Embree's barycentrics of vertices 1 and 2; d: the incoming ray's direction;
// `wantUv`: the surface samples a texture (its uv and texel density are needed).
// Always inlined: the HitInfo is then never written to memory and read back (a call was a third
// of the shading time).
[[gnu::always_inline]] inline HitInfo hitInfoOf(const PhysicalMesh& mesh, unsigned prim, float u,
                                                float v, const Eigen::Vector3f& d, bool wantUv) {
  const auto& tri = mesh.triangles[prim];
  const Eigen::Vector3f& p0 = mesh.positions[tri[0]];
  const Eigen::Vector3f& p1 = mesh.positions[tri[1]];
  const Eigen::Vector3f& p2 = mesh.positions[tri[2]];
  const float w = 1.0f - u - v;
  HitInfo h;
  // From the vertices, not o + t d: its error is then ulps of the vertices, not of the ray length.
  h.position = w * p0 + u * p1 + v * p2;
  Eigen::Vector3f ng = mesh.faceNormals[prim];
  h.frontFace = ng.dot(d) < 0.0f;
  if (!h.frontFace) ng = -ng;
  h.geometricNormal = ng;
  h.shadingNormal = ng;
  if (!mesh.normals.empty()) {
    const Eigen::Vector3f ns =
        w * mesh.normals[tri[0]] + u * mesh.normals[tri[1]] + v * mesh.normals[tri[2]];
    const float length = ns.norm();
    if (length > 0.0f && std::isfinite(length)) {
      Eigen::Vector3f n = ns / length;
      // Interpolated normals may point to the other side than the face; keep them on the
      // incoming side so shading and secondary rays stay consistent with the offset.
      if (n.dot(ng) < 0.0f) n = -n;
      h.shadingNormal = n;
    }
  }
  if (wantUv) textureCoordinatesOf(mesh, prim, u, v, &h);
  if (!mesh.colors.empty())
    h.vertexColor = w * mesh.colors[tri[0]] + u * mesh.colors[tri[1]] + v * mesh.colors[tri[2]];
  return h;
}

}  // namespace parallax
