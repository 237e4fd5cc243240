#include "tracer/whitted_integrator.h"

#include <tbb/blocked_range2d.h>
#include <tbb/combinable.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <cmath>
#include <limits>
#include <memory>

#include <fmt/format.h>

#include "common/input_error.h"
#include "tracer/optics.h"

namespace parallax {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// One branch of a pixel's Whitted tree, waiting for its ray to be traced.
struct Path {
  int pixel = 0;
  Rgb weight = Rgb::Ones();
  float coneWidth = 0.0f;   // footprint width at the ray origin (physical metres)
  float coneSpread = 0.0f;  // growth of that width per metre travelled
  int inside = -1;          // material index of the glass the ray travels in, -1 in air
};

struct PendingShadow {
  int pixel;
  Rgb contribution;
};

// Slab test: does o + t d (t > 0) meet the box? If so, *entry is the t where it comes in.
bool hitsBox(const Eigen::Vector3f& o, const Eigen::Vector3f& d, const Eigen::Vector3f& lo,
             const Eigen::Vector3f& hi, float* entry) {
  float t0 = 0.0f, t1 = kInf;
  for (int i = 0; i < 3; ++i) {
    const float inv = 1.0f / d[i];
    float a = (lo[i] - o[i]) * inv, b = (hi[i] - o[i]) * inv;
    if (a > b) std::swap(a, b);
    // NaN from 0·inf (ray in the slab's plane) leaves the interval unchanged.
    t0 = a > t0 ? a : t0;
    t1 = b < t1 ? b : t1;
    if (t0 > t1) return false;
  }
  *entry = t0;
  return true;
}

struct HitInfo {
  Eigen::Vector3f position;
  Eigen::Vector3f geometricNormal;  // unit, facing the incoming ray
  Eigen::Vector3f shadingNormal;    // unit, same side as geometricNormal
  bool frontFace = true;            // the ray arrived on the side the CCW normal points to
  Eigen::Vector2f uv = Eigen::Vector2f::Zero();
  Rgb vertexColor = Rgb::Ones();
  float texelsPerMetreSq = 0.0f;  // uv area / physical area (for the texture footprint)
};

HitInfo hitInfoOf(const PhysicalMesh& mesh, unsigned prim, float u, float v, const Eigen::Vector3f& d) {
  const auto& tri = mesh.triangles[prim];
  const Eigen::Vector3f& p0 = mesh.positions[tri[0]];
  const Eigen::Vector3f& p1 = mesh.positions[tri[1]];
  const Eigen::Vector3f& p2 = mesh.positions[tri[2]];
  const float w = 1.0f - u - v;
  HitInfo h;
  // From the vertices, not o + t d: its error is then ulps of the vertices, not of the ray length.
  h.position = w * p0 + u * p1 + v * p2;
  const Eigen::Vector3f cross = (p1 - p0).cross(p2 - p0);
  Eigen::Vector3f ng = cross.normalized();
  h.frontFace = ng.dot(d) < 0.0f;
  if (!h.frontFace) ng = -ng;
  h.geometricNormal = ng;
  h.shadingNormal = ng;
  if (!mesh.normals.empty()) {
    const Eigen::Vector3f ns = w * mesh.normals[tri[0]] + u * mesh.normals[tri[1]] + v * mesh.normals[tri[2]];
    const float length = ns.norm();
    if (length > 0.0f && std::isfinite(length)) {
      Eigen::Vector3f n = ns / length;
      // Interpolated normals may point to the other side than the face; keep them on the
      // incoming side so shading and secondary rays stay consistent with the offset.
      if (n.dot(ng) < 0.0f) n = -n;
      h.shadingNormal = n;
    }
  }
  if (!mesh.uvs.empty()) {
    const Eigen::Vector2f& t0 = mesh.uvs[tri[0]];
    const Eigen::Vector2f& t1 = mesh.uvs[tri[1]];
    const Eigen::Vector2f& t2 = mesh.uvs[tri[2]];
    h.uv = w * t0 + u * t1 + v * t2;
    const Eigen::Vector2f a = t1 - t0, b = t2 - t0;
    const float uvArea = std::abs(a.x() * b.y() - a.y() * b.x());
    h.texelsPerMetreSq = uvArea / cross.norm();
  }
  if (!mesh.colors.empty()) h.vertexColor = w * mesh.colors[tri[0]] + u * mesh.colors[tri[1]] + v * mesh.colors[tri[2]];
  return h;
}

class TileRenderer {
 public:
  TileRenderer(const PhysicalScene& scene, const RayTextures& textures, const RenderOptions& options, int depth,
               Frame* frame, RayLog* log)
      : scene_(scene), textures_(textures), options_(options), depth_(depth), frame_(frame), log_(log),
        boxMargin_(0.01f * (scene.boundsMax() - scene.boundsMin()).norm()) {}

  void render(int x0, int x1, int y0, int y1, RenderCounters* c);

 private:
  void initialRays(int x0, int x1, int y0, int y1, RenderCounters* c);
  void cone(int column, int row, const Eigen::Vector3f& toScreen, Path* path) const;
  void shade(size_t i, int generation, RenderCounters* c);
  Rgb textureColor(const Material& m, const HitInfo& h, const Path& path, float t, const Eigen::Vector3f& d,
                   RenderCounters* c) const;
  void pushBranch(const Path& parent, const Rgb& weight, const Eigen::Vector3f& origin, const Eigen::Vector3f& dir,
                  int inside, float coneWidth, RenderCounters* c);
  void logBatch(bool occlusion, int generation, const RTCRay* rays, size_t count, size_t stride);

  const PhysicalScene& scene_;
  const RayTextures& textures_;
  const RenderOptions& options_;
  const int depth_;
  Frame* frame_;
  RayLog* log_;
  const float boxMargin_;  // primary rays start this far (metres) before the scene's box

  std::vector<Path> paths_, nextPaths_;
  std::vector<RTCRayHit> rays_, nextRays_;
  // Shadow rays are gathered per light, then traced light after light: a packet then holds
  // neighbouring pixels' rays toward the same light, which traverse the BVH together.
  std::vector<std::vector<RTCRay>> shadowRaysByLight_;
  std::vector<std::vector<PendingShadow>> shadowsByLight_;
};

// o and s − o of a compact ray. A flat screen (the common case) needs no sag and its square root.
inline void expand(const RayFrame& f, const CompactRay& r, Eigen::Vector3f* o, Eigen::Vector3f* toScreen) {
  const float sz = f.curvature == 0.0f ? 0.0f : screenSag(f.curvature, r.screenX);
  *o = {r.originX, f.observerY, f.observerZ};
  *toScreen = {r.screenX - r.originX, r.screenY - f.observerY, sz - f.observerZ};
}

void TileRenderer::cone(int column, int row, const Eigen::Vector3f& toScreen, Path* path) const {
  // Footprint from the neighbouring pixels' rays (a ray differential): the width is the offset
  // between neighbouring origins, the spread the angle between neighbouring directions (small
  // angles: the change of s − o over its length).
  const RayFrame& f = textures_.frame();
  const CompactRay& self = textures_.at(column, row);
  const float inverseLength = 1.0f / toScreen.norm();
  float width = 0.0f, spread = 0.0f;
  const int nx = column + 1 < textures_.width() ? column + 1 : column - 1;
  const int ny = row + 1 < textures_.height() ? row + 1 : row - 1;
  for (const CompactRay* n : {nx >= 0 ? &textures_.at(nx, row) : nullptr, ny >= 0 ? &textures_.at(column, ny) : nullptr}) {
    if (!n || n->masked()) continue;
    Eigen::Vector3f o, t;
    expand(f, *n, &o, &t);
    width = std::max(width, std::abs(n->originX - self.originX));
    spread = std::max(spread, (t - toScreen).norm() * inverseLength);
  }
  path->coneWidth = width;
  path->coneSpread = spread;
}

void TileRenderer::initialRays(int x0, int x1, int y0, int y1, RenderCounters* c) {
  const RayFrame& f = textures_.frame();
  const bool cones = scene_.features().texturePass();
  const Eigen::Vector3f lo = scene_.boundsMin(), hi = scene_.boundsMax();
  const Rgb background = scene_.background();
  paths_.clear();
  rays_.clear();
  const size_t capacity = static_cast<size_t>(x1 - x0) * static_cast<size_t>(y1 - y0);
  paths_.reserve(capacity);
  rays_.reserve(capacity);
  for (int row = y0; row < y1; ++row) {
    for (int column = x0; column < x1; ++column) {
      const CompactRay& r = textures_.at(column, row);
      if (r.masked()) {
        ++c->masked;
        continue;
      }
      Eigen::Vector3f o, toScreen;
      expand(f, r, &o, &toScreen);
      // The box test needs no unit direction; most pixels of a small scene stop here, so the
      // square root of the normalisation is paid only by the rays that are traced.
      const int pixel = row * textures_.width() + column;
      float entry;
      if (!hitsBox(o, toScreen, lo, hi, &entry)) {
        ++c->missedBounds;
        frame_->pixels[static_cast<size_t>(pixel)] = background;
        continue;
      }
      Path path;
      path.pixel = pixel;
      if (cones) cone(column, row, toScreen, &path);
      // Start the ray just before the scene's box rather than on the observer line, metres
      // away: Embree intersects in float relative to the origin, so a near origin keeps the hit
      // (and the attributes interpolated there) exact to float precision of the scene's size,
      // where a far one loses digits in proportion to the distance (the outer modules' rays
      // start up to several metres to the side).
      const float advance = std::max(0.0f, entry - boxMargin_ / toScreen.norm());
      o += advance * toScreen;
      path.coneWidth += advance * toScreen.norm() * path.coneSpread;
      paths_.push_back(path);
      rays_.push_back(makeRayHit(o, toScreen.normalized()));
    }
  }
  c->pixels += static_cast<long>(capacity);
  c->primary += static_cast<long>(rays_.size());
}

void TileRenderer::render(int x0, int x1, int y0, int y1, RenderCounters* c) {
  initialRays(x0, x1, y0, y1, c);
  for (int generation = 0; generation < depth_ && !rays_.empty(); ++generation) {
    c->deepest = std::max(c->deepest, generation + 1);
    const bool coherent = generation == 0;
    if (log_) logBatch(false, generation, &rays_[0].ray, rays_.size(), sizeof(RTCRayHit));
    intersectBatch(scene_.handle(), rays_, options_.traversal, coherent);
    nextPaths_.clear();
    nextRays_.clear();
    shadowRaysByLight_.resize(scene_.lights().size());
    shadowsByLight_.resize(scene_.lights().size());
    for (size_t i = 0; i < rays_.size(); ++i) shade(i, generation, c);
    // One batch per light: no copying into a common array, and each batch is coherent.
    for (size_t l = 0; l < shadowRaysByLight_.size(); ++l) {
      std::vector<RTCRay>& rays = shadowRaysByLight_[l];
      const std::vector<PendingShadow>& pending = shadowsByLight_[l];
      if (rays.empty()) continue;
      if (log_) logBatch(true, generation, rays.data(), rays.size(), sizeof(RTCRay));
      occludedBatch(scene_.handle(), rays, options_.traversal, coherent);
      for (size_t i = 0; i < rays.size(); ++i) {
        // Embree sets tfar to -inf on an occluded ray.
        if (rays[i].tfar >= 0.0f) frame_->pixels[static_cast<size_t>(pending[i].pixel)] += pending[i].contribution;
      }
      c->shadow += static_cast<long>(rays.size());
      rays.clear();
      shadowsByLight_[l].clear();
    }
    std::swap(paths_, nextPaths_);
    std::swap(rays_, nextRays_);
  }
}

void TileRenderer::logBatch(bool occlusion, int generation, const RTCRay* rays, size_t count, size_t stride) {
  RayLog::Batch batch;
  batch.occlusion = occlusion;
  batch.coherent = generation == 0;
  batch.generation = generation;
  batch.rays.reserve(count);
  const auto* bytes = reinterpret_cast<const unsigned char*>(rays);
  // Logged before tracing, so each ray is replayed exactly as it was first handed to Embree.
  for (size_t i = 0; i < count; ++i) batch.rays.push_back(*reinterpret_cast<const RTCRay*>(bytes + i * stride));
  std::lock_guard<std::mutex> lock(log_->mutex);
  log_->batches.push_back(std::move(batch));
}

Rgb TileRenderer::textureColor(const Material& m, const HitInfo& h, const Path& path, float t,
                               const Eigen::Vector3f& d, RenderCounters* c) const {
  if (m.diffuseTexture < 0) return Rgb::Ones();
  const TextureImage& image = scene_.textures()[static_cast<size_t>(m.diffuseTexture)];
  if (image.levelCount() == 0) return Rgb::Ones();  // left out (mesh without UVs)
  ++c->textureLookups;
  float lod = 0.0f;
  if (options_.textureFiltering) {
    // Ray cone: footprint width at the hit, stretched by the incidence angle, in texels.
    const float width = path.coneWidth + t * path.coneSpread;
    const float cosine = std::max(std::abs(d.dot(h.geometricNormal)), 0.05f);
    const float texelsPerMetre =
        std::sqrt(h.texelsPerMetreSq * static_cast<float>(image.width()) * static_cast<float>(image.height()));
    lod = std::log2(std::max(width * texelsPerMetre / cosine, 1e-30f));
  }
  return image.lookup(h.uv.x(), h.uv.y(), lod);
}

void TileRenderer::pushBranch(const Path& parent, const Rgb& weight, const Eigen::Vector3f& origin,
                              const Eigen::Vector3f& dir, int inside, float coneWidth, RenderCounters* c) {
  if (weight.maxCoeff() < options_.minWeight) {
    ++c->pruned;
    return;
  }
  Path child = parent;
  child.weight = weight;
  child.inside = inside;
  child.coneWidth = coneWidth;
  nextPaths_.push_back(child);
  nextRays_.push_back(makeRayHit(origin, dir));
}

void TileRenderer::shade(size_t i, int generation, RenderCounters* c) {
  const RTCRayHit& r = rays_[i];
  Path& path = paths_[i];
  Rgb& out = frame_->pixels[static_cast<size_t>(path.pixel)];
  if (r.hit.geomID == RTC_INVALID_GEOMETRY_ID) {
    out += path.weight.cwiseProduct(scene_.background());
    return;
  }
  const Eigen::Vector3f d(r.ray.dir_x, r.ray.dir_y, r.ray.dir_z);
  const float t = r.ray.tfar;
  const PhysicalMesh& mesh = scene_.meshes()[r.hit.geomID];
  const Material& m = scene_.materials()[static_cast<size_t>(mesh.material)];
  const HitInfo h = hitInfoOf(mesh, r.hit.primID, r.hit.u, r.hit.v, d);
  Rgb weight = path.weight;
  if (path.inside >= 0) {
    // Beer–Lambert over the distance travelled inside the glass, in world units.
    const Material& glass = scene_.materials()[static_cast<size_t>(path.inside)];
    const float distance = t * scene_.worldPerPhysical();
    weight = weight.cwiseProduct((-glass.absorption * distance).array().exp().matrix());
  }
  const bool canBranch = generation + 1 < depth_;
  const float coneWidth = path.coneWidth + t * path.coneSpread;
  const Eigen::Vector3f above = offsetRayOrigin(h.position, h.geometricNormal);

  if (m.emission.maxCoeff() > 0.0f || m.kind == MaterialKind::kEmissive) {
    Rgb e = m.emission.cwiseProduct(h.vertexColor);
    if (m.kind == MaterialKind::kEmissive) e = e.cwiseProduct(textureColor(m, h, path, t, d, c));
    out += weight.cwiseProduct(e);
  }
  switch (m.kind) {
    case MaterialKind::kEmissive: return;
    case MaterialKind::kDiffuse: {
      const Rgb albedo = m.diffuse.cwiseProduct(h.vertexColor).cwiseProduct(textureColor(m, h, path, t, d, c));
      out += weight.cwiseProduct(albedo).cwiseProduct(scene_.ambient());
      const bool highlight = m.specular.maxCoeff() > 0.0f;
      for (size_t lightIndex = 0; lightIndex < scene_.lights().size(); ++lightIndex) {
        const PhysicalLight& light = scene_.lights()[lightIndex];
        Eigen::Vector3f l = light.toLight;
        float tfar = kInf;
        Rgb irradiance = light.intensity;
        if (light.kind == LightKind::kPoint) {
          const Eigen::Vector3f toLight = light.position - h.position;
          const float distance = toLight.norm();
          if (!(distance > 0.0f)) continue;
          l = toLight / distance;
          tfar = distance;
          const float worldDistance = distance * scene_.worldPerPhysical();
          irradiance /= worldDistance * worldDistance;
        }
        const float cosine = h.shadingNormal.dot(l);
        // Light from behind the geometric face cannot reach this side.
        if (cosine <= 0.0f || h.geometricNormal.dot(l) <= 0.0f) continue;
        Rgb response = albedo * cosine;
        if (highlight) {
          const float alignment = std::max(0.0f, reflect(d, h.shadingNormal).dot(l));
          response += m.specular * std::pow(alignment, m.shininess);
        }
        const Rgb contribution = weight.cwiseProduct(response).cwiseProduct(irradiance);
        if (contribution.maxCoeff() <= 0.0f) continue;
        shadowsByLight_[lightIndex].push_back({path.pixel, contribution});
        shadowRaysByLight_[lightIndex].push_back(makeShadowRay(above, l, tfar));
      }
      return;
    }
    case MaterialKind::kMirror: {
      if (!canBranch) return;
      ++c->reflection;
      pushBranch(path, weight.cwiseProduct(m.reflectance), above, reflect(d, h.shadingNormal), path.inside,
                 coneWidth, c);
      return;
    }
    case MaterialKind::kDielectric: {
      if (!canBranch) return;
      // Entering through the front face (the CCW side, outward for closed meshes) goes from air
      // into the glass; leaving through the back face goes out.
      const float eta = h.frontFace ? 1.0f / m.ior : m.ior;
      const Eigen::Vector3f& n = h.shadingNormal;
      Eigen::Vector3f refracted;
      float cosT = 0.0f;
      const float cosI = std::min(1.0f, -d.dot(n));
      const bool transmits = refract(d, n, eta, &refracted, &cosT);
      const float reflectance = transmits ? fresnelDielectric(cosI, cosT, eta) : 1.0f;
      ++c->reflection;
      pushBranch(path, weight * reflectance, above, reflect(d, n), path.inside, coneWidth, c);
      if (transmits) {
        ++c->refraction;
        const Eigen::Vector3f below = offsetRayOrigin(h.position, -h.geometricNormal);
        pushBranch(path, weight * (1.0f - reflectance), below, refracted,
                   h.frontFace ? mesh.material : -1, coneWidth, c);
      }
      return;
    }
  }
}

}  // namespace

void RenderOptions::validate() const {
  if (tileWidth < 1 || tileWidth > 4096) throw InputError({"", "tile_width", 0}, "must be in 1..4096");
  if (tileHeight < 1 || tileHeight > 4096) throw InputError({"", "tile_height", 0}, "must be in 1..4096");
  if (!std::isfinite(minWeight) || minWeight < 0.0f || minWeight >= 1.0f) {
    throw InputError({"", "min_weight", 0}, "must be in [0, 1)");
  }
  if (maxDepth < 0 || maxDepth > 64) throw InputError({"", "max_depth", 0}, "must be in 0..64 (0: the scene's)");
}

RenderCounters& RenderCounters::operator+=(const RenderCounters& o) {
  pixels += o.pixels;
  masked += o.masked;
  missedBounds += o.missedBounds;
  primary += o.primary;
  shadow += o.shadow;
  reflection += o.reflection;
  refraction += o.refraction;
  pruned += o.pruned;
  textureLookups += o.textureLookups;
  deepest = std::max(deepest, o.deepest);
  return *this;
}

std::vector<std::string> RenderCounters::lines() const {
  return {
      fmt::format("  pixels {}: {} masked (never traced), {} miss the scene's bounds (never traversed)", pixels,
                  masked, missedBounds),
      fmt::format("  rays {}: primary {}, shadow {}, reflection {}, refraction {}", rays(), primary, shadow,
                  reflection, refraction),
      fmt::format("  branches pruned below the weight limit {}; texture lookups {}; deepest generation {}", pruned,
                  textureLookups, deepest),
  };
}

Frame renderFrame(const PhysicalScene& scene, const RayTextures& textures, const RenderOptions& options,
                  RenderCounters* counters, RayLog* log) {
  options.validate();
  Frame frame(textures.width(), textures.height());
  int depth = scene.features().depth;
  if (options.maxDepth > 0) depth = std::min(depth, options.maxDepth);
  tbb::combinable<RenderCounters> perThread;
  // One renderer per worker thread, so its ray and path arrays are allocated once a frame, not
  // once a tile.
  tbb::enumerable_thread_specific<std::unique_ptr<TileRenderer>> renderers(
      [&] { return std::make_unique<TileRenderer>(scene, textures, options, depth, &frame, log); });
  const tbb::blocked_range2d<int> range(0, textures.height(), options.tileHeight, 0, textures.width(),
                                        options.tileWidth);
  tbb::parallel_for(range, [&](const tbb::blocked_range2d<int>& tile) {
    renderers.local()->render(tile.cols().begin(), tile.cols().end(), tile.rows().begin(), tile.rows().end(),
                              &perThread.local());
  }, tbb::simple_partitioner());
  if (counters) {
    *counters = RenderCounters{};
    perThread.combine_each([&](const RenderCounters& c) { *counters += c; });
  }
  return frame;
}

double processCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) * 1e-6;
}

double replayRayLog(const PhysicalScene& scene, const RayLog& log, Traversal traversal, RayKind kind, long* rays,
                    double* cpuMs) {
  auto wanted = [&](const RayLog::Batch& batch) {
    switch (kind) {
      case RayKind::kAll: return true;
      case RayKind::kPrimary: return !batch.occlusion && batch.generation == 0;
      case RayKind::kShadow: return batch.occlusion;
      case RayKind::kSecondary: return !batch.occlusion && batch.generation > 0;
    }
    return false;
  };
  // Work on copies: tracing overwrites tfar (and the hit fields of intersection rays).
  std::vector<std::vector<RTCRayHit>> hits(log.batches.size());
  std::vector<std::vector<RTCRay>> shadows(log.batches.size());
  long count = 0;
  for (size_t b = 0; b < log.batches.size(); ++b) {
    const RayLog::Batch& batch = log.batches[b];
    if (!wanted(batch)) continue;
    count += static_cast<long>(batch.rays.size());
    if (batch.occlusion) {
      shadows[b] = batch.rays;
    } else {
      hits[b].reserve(batch.rays.size());
      for (const RTCRay& r : batch.rays) {
        RTCRayHit h = makeRayHit({r.org_x, r.org_y, r.org_z}, {r.dir_x, r.dir_y, r.dir_z}, r.tfar);
        hits[b].push_back(h);
      }
    }
  }
  const double cpuStart = processCpuMs();
  const auto start = std::chrono::steady_clock::now();
  tbb::parallel_for(size_t{0}, log.batches.size(), [&](size_t b) {
    const RayLog::Batch& batch = log.batches[b];
    if (batch.occlusion) {
      occludedBatch(scene.handle(), shadows[b], traversal, batch.coherent);
    } else if (!hits[b].empty()) {
      intersectBatch(scene.handle(), hits[b], traversal, batch.coherent);
    }
  });
  if (rays) *rays = count;
  if (cpuMs) *cpuMs = processCpuMs() - cpuStart;
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace parallax
