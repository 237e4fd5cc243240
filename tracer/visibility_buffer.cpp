#include "tracer/visibility_buffer.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <limits>

#include "tracer/ray_batch.h"

namespace parallax {

long VisibilityBuffer::coveredCount() const {
  return std::count_if(samples.begin(), samples.end(),
                       [](const SurfaceSample& s) { return s.covered(); });
}

Eigen::Vector3f surfacePosition(const PhysicalScene& scene, const SurfaceSample& sample) {
  const PhysicalMesh& mesh = scene.meshes()[static_cast<size_t>(sample.mesh)];
  const auto& tri = mesh.triangles[static_cast<size_t>(sample.triangle)];
  const float b0 = 1.0f - sample.b1 - sample.b2;
  return b0 * mesh.positions[tri[0]] + sample.b1 * mesh.positions[tri[1]] +
         sample.b2 * mesh.positions[tri[2]];
}

VisibilityBuffer tracePrimaryVisibility(const PhysicalScene& scene, const RayTextures& textures) {
  VisibilityBuffer out(textures.width(), textures.height());
  const RayFrame& frame = textures.frame();
  const Eigen::Vector3f lo = scene.boundsMin(), hi = scene.boundsMax();
  const float margin = 0.01f * (hi - lo).norm();
  tbb::parallel_for(
      tbb::blocked_range<int>(0, textures.height(), 8), [&](const tbb::blocked_range<int>& rows) {
        std::vector<RTCRayHit> rays;
        std::vector<int> pixels;
        for (int row = rows.begin(); row < rows.end(); ++row) {
          for (int column = 0; column < textures.width(); ++column) {
            const CompactRay& r = textures.at(column, row);
            if (r.masked()) continue;
            // As renderFrame does: start just before the scene's bounds, not metres away on the
            // observer line, so Embree's float intersection is exact to the scene's size.
            Eigen::Vector3f o = frame.origin(r);
            const Eigen::Vector3f d = frame.direction(r);
            float entry = 0.0f, exit = std::numeric_limits<float>::infinity();
            for (int k = 0; k < 3; ++k) {
              float a = (lo[k] - o[k]) / d[k], b = (hi[k] - o[k]) / d[k];
              if (a > b) std::swap(a, b);
              entry = a > entry ? a : entry;  // NaN (ray in a slab's plane) leaves it unchanged
              exit = b < exit ? b : exit;
            }
            if (entry > exit) continue;  // misses the scene's bounds: background
            o += std::max(0.0f, entry - margin) * d;
            rays.push_back(makeRayHit(o, d));
            pixels.push_back(row * textures.width() + column);
          }
        }
        intersectBatch(scene.handle(), rays, Traversal::kStream, true);
        for (size_t i = 0; i < rays.size(); ++i) {
          const RTCRayHit& h = rays[i];
          if (h.hit.geomID == RTC_INVALID_GEOMETRY_ID) continue;
          SurfaceSample& s = out.samples[static_cast<size_t>(pixels[i])];
          s.mesh = static_cast<int>(h.hit.geomID);
          s.triangle = static_cast<int>(h.hit.primID);
          s.b1 = h.hit.u;
          s.b2 = h.hit.v;
        }
      });
  return out;
}

}  // namespace parallax
