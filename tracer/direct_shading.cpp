#include "tracer/direct_shading.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "tracer/hit_info.h"
#include "tracer/optics.h"

namespace parallax {
namespace {

Rgb shadePixel(const PhysicalScene& scene, const SurfaceSample& sample, const Eigen::Vector3f& d,
               DirectShadingCounters* c) {
  const PhysicalMesh& mesh = scene.meshes()[static_cast<size_t>(sample.mesh)];
  const Material& m = scene.materials()[static_cast<size_t>(mesh.material)];
  const HitInfo h = hitInfoOf(mesh, static_cast<unsigned>(sample.triangle), sample.b1, sample.b2, d,
                              m.diffuseTexture >= 0);
  Rgb texture = Rgb::Ones();
  if (m.diffuseTexture >= 0) {
    const TextureImage& image = scene.textures()[static_cast<size_t>(m.diffuseTexture)];
    if (image.levelCount() > 0) texture = image.lookup(h.uv.x(), h.uv.y(), 0.0f);
  }
  Rgb out = Rgb::Zero();
  if (m.emission.maxCoeff() > 0.0f || m.kind == MaterialKind::kEmissive) {
    Rgb e = m.emission.cwiseProduct(h.vertexColor);
    if (m.kind == MaterialKind::kEmissive) e = e.cwiseProduct(texture);
    out += e;
  }
  if (m.kind == MaterialKind::kMirror || m.kind == MaterialKind::kDielectric) {
    ++c->unshadeable;
    return out;
  }
  ++c->shaded;
  if (m.kind != MaterialKind::kDiffuse) return out;
  const Rgb albedo = m.diffuse.cwiseProduct(h.vertexColor).cwiseProduct(texture);
  out += albedo.cwiseProduct(scene.ambient());
  for (const PhysicalLight& light : scene.lights()) {
    Eigen::Vector3f l = light.toLight;
    Rgb irradiance = light.intensity;
    if (light.kind == LightKind::kPoint) {
      const Eigen::Vector3f toLight = light.position - h.position;
      const float distance = toLight.norm();
      if (!(distance > 0.0f)) continue;
      l = toLight / distance;
      const float worldDistance = distance * scene.worldPerPhysical();
      irradiance /= worldDistance * worldDistance;
    }
    const float cosine = h.shadingNormal.dot(l);
    if (cosine <= 0.0f || h.geometricNormal.dot(l) <= 0.0f) continue;
    Rgb response = albedo * cosine;
    if (m.specular.maxCoeff() > 0.0f) {
      response +=
          m.specular * std::pow(std::max(0.0f, reflect(d, h.shadingNormal).dot(l)), m.shininess);
    }
    out += response.cwiseProduct(irradiance);
  }
  return out;
}

}  // namespace

Frame shadeDirect(const PhysicalScene& scene, const VisibilityBuffer& visibility,
                  const RayTextures& textures, DirectShadingCounters* counters) {
  Frame frame(visibility.width, visibility.height);
  tbb::combinable<DirectShadingCounters> perThread;
  tbb::parallel_for(
      tbb::blocked_range<int>(0, visibility.height, 8), [&](const tbb::blocked_range<int>& rows) {
        DirectShadingCounters& c = perThread.local();
        for (int row = rows.begin(); row < rows.end(); ++row) {
          for (int column = 0; column < visibility.width; ++column) {
            const SurfaceSample& s = visibility.at(column, row);
            const CompactRay& r = textures.at(column, row);
            if (r.masked()) continue;  // black, as in the tracer
            frame.at(column, row) = s.covered()
                                        ? shadePixel(scene, s, textures.frame().direction(r), &c)
                                        : scene.background();
          }
        }
      });
  if (counters) {
    *counters = DirectShadingCounters{};
    perThread.combine_each([&](const DirectShadingCounters& c) {
      counters->shaded += c.shaded;
      counters->unshadeable += c.unshadeable;
    });
  }
  return frame;
}

}  // namespace parallax
