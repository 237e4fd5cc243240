#include "tracer/rasterizer.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "common/input_error.h"
#include "tracer/direct_shading.h"

namespace parallax {
namespace {

constexpr int kMaxTessellationLevel = 8;

// A small triangle after projection: module-image vertices (continuous pixel coordinates),
// their depth z, 1/w for perspective-correct weights, and their barycentrics in the source
// triangle (the attributes every later stage needs).
struct ScreenTriangle {
  float u[3], v[3];
  float z[3];
  float invW[3];
  float b1[3], b2[3];
  int mesh, triangle;
};

struct GridVertex {
  bool ok = false;
  float u = 0, v = 0, z = 0, invW = 0, b1 = 0, b2 = 0;
};

double msSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

struct Projector {
  const ForwardMap& forwardMap;
  double observerZ;
  int width, height;

  GridVertex project(const Eigen::Vector3d& p, float b1, float b2, RasterCounters* c) const {
    GridVertex g;
    ++c->projectedVertices;
    const ForwardMapResult r = forwardMap.pixelOfContinued(p);
    if (!r.ok || !r.pixel.allFinite()) {
      ++c->failedVertices;
      return g;
    }
    g.ok = true;
    g.u = static_cast<float>(r.pixel.x());
    g.v = static_cast<float>(r.pixel.y());
    g.z = static_cast<float>(p.z());
    g.invW = static_cast<float>(1.0 / (observerZ - p.z()));  // B_P lies before the observer line
    g.b1 = b1;
    g.b2 = b2;
    return g;
  }

  // Off the image even with a margin of half the corners' bounding box.
  bool offImage(const GridVertex (&corner)[3]) const {
    float lo[2] = {kInf, kInf}, hi[2] = {-kInf, -kInf};
    for (const GridVertex& g : corner) {
      lo[0] = std::min(lo[0], g.u), hi[0] = std::max(hi[0], g.u);
      lo[1] = std::min(lo[1], g.v), hi[1] = std::max(hi[1], g.v);
    }
    const float mu = 0.5f * (hi[0] - lo[0]) + 2.0f, mv = 0.5f * (hi[1] - lo[1]) + 2.0f;
    return hi[0] + mu < 0.0f || lo[0] - mu > static_cast<float>(width) || hi[1] + mv < 0.0f ||
           lo[1] - mv > static_cast<float>(height);
  }

  static constexpr float kInf = std::numeric_limits<float>::infinity();
};

void emit(const GridVertex& a, const GridVertex& b, const GridVertex& c, int mesh, int triangle,
          int width, int height, std::vector<ScreenTriangle>* out, RasterCounters* counters) {
  if (!a.ok || !b.ok || !c.ok) {
    ++counters->droppedTriangles;
    return;
  }
  const float area = (b.u - a.u) * (c.v - a.v) - (b.v - a.v) * (c.u - a.u);
  if (!(std::abs(area) > 0.0f)) return;  // degenerate in the image: covers no pixel centre
  const float loU = std::min({a.u, b.u, c.u}), hiU = std::max({a.u, b.u, c.u});
  const float loV = std::min({a.v, b.v, c.v}), hiV = std::max({a.v, b.v, c.v});
  if (hiU < 0.0f || loU > static_cast<float>(width) || hiV < 0.0f ||
      loV > static_cast<float>(height))
    return;
  ScreenTriangle t;
  const GridVertex* vs[3] = {&a, &b, &c};
  for (int k = 0; k < 3; ++k) {
    t.u[k] = vs[k]->u;
    t.v[k] = vs[k]->v;
    t.z[k] = vs[k]->z;
    t.invW[k] = vs[k]->invW;
    t.b1[k] = vs[k]->b1;
    t.b2[k] = vs[k]->b2;
  }
  t.mesh = mesh;
  t.triangle = triangle;
  out->push_back(t);
}

// Projects one source triangle, tessellated into N² = 4^level small ones over a barycentric
// grid (i, j), i + j ≤ N, whose vertices are projected once each.
void projectTriangle(const Projector& projector, const PhysicalMesh& mesh, int meshIndex,
                     int triangle, int level, std::vector<GridVertex>* grid,
                     std::vector<ScreenTriangle>* out, RasterCounters* c) {
  const auto& tri = mesh.triangles[static_cast<size_t>(triangle)];
  const Eigen::Vector3d p0 = mesh.positions[tri[0]].cast<double>();
  const Eigen::Vector3d e1 = mesh.positions[tri[1]].cast<double>() - p0;
  const Eigen::Vector3d e2 = mesh.positions[tri[2]].cast<double>() - p0;
  const int n = 1 << level;
  auto index = [n](int i, int j) { return static_cast<size_t>(j * (n + 1) + i); };
  grid->assign(static_cast<size_t>((n + 1) * (n + 1)), GridVertex{});
  GridVertex corners[3] = {projector.project(p0, 0.0f, 0.0f, c),
                           projector.project(p0 + e1, 1.0f, 0.0f, c),
                           projector.project(p0 + e2, 0.0f, 1.0f, c)};
  if (corners[0].ok && corners[1].ok && corners[2].ok && projector.offImage(corners)) {
    ++c->culledTriangles;
    return;
  }
  (*grid)[index(0, 0)] = corners[0];
  (*grid)[index(n, 0)] = corners[1];
  (*grid)[index(0, n)] = corners[2];
  for (int j = 0; j <= n; ++j) {
    for (int i = 0; i + j <= n; ++i) {
      if ((i == 0 && j == 0) || (i == n && j == 0) || (i == 0 && j == n)) continue;
      const double b1 = static_cast<double>(i) / n, b2 = static_cast<double>(j) / n;
      (*grid)[index(i, j)] = projector.project(p0 + b1 * e1 + b2 * e2, static_cast<float>(b1),
                                               static_cast<float>(b2), c);
    }
  }
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i + j < n; ++i) {
      const GridVertex& a = (*grid)[index(i, j)];
      const GridVertex& b = (*grid)[index(i + 1, j)];
      const GridVertex& d = (*grid)[index(i, j + 1)];
      emit(a, b, d, meshIndex, triangle, projector.width, projector.height, out, c);
      if (i + j + 1 < n)
        emit(b, (*grid)[index(i + 1, j + 1)], d, meshIndex, triangle, projector.width,
             projector.height, out, c);
    }
  }
}

// Scan-converts the triangles binned to one band of rows into its slice of the buffers.
void rasterizeBand(const std::vector<ScreenTriangle>& triangles, const std::vector<int>& binned,
                   int row0, int row1, const RayTextures& textures, Interpolation interpolation,
                   std::vector<float>* depth, VisibilityBuffer* out, long* fragments) {
  const int width = textures.width();
  for (int index : binned) {
    const ScreenTriangle& t = triangles[static_cast<size_t>(index)];
    // Orient counter-clockwise in (u, v) so all three edge functions are ≥ 0 inside.
    int k1 = 1, k2 = 2;
    const float area =
        (t.u[1] - t.u[0]) * (t.v[2] - t.v[0]) - (t.v[1] - t.v[0]) * (t.u[2] - t.u[0]);
    if (area < 0.0f) std::swap(k1, k2);
    const int order[3] = {0, k1, k2};
    const float inverseArea = 1.0f / std::abs(area);
    const float loU = std::min({t.u[0], t.u[1], t.u[2]}), hiU = std::max({t.u[0], t.u[1], t.u[2]});
    const float loV = std::min({t.v[0], t.v[1], t.v[2]}), hiV = std::max({t.v[0], t.v[1], t.v[2]});
    // Pixel centres (i + ½, j + ½) inside the bounding box.
    const int c0 = std::max(0, static_cast<int>(std::ceil(loU - 0.5f)));
    const int c1 = std::min(width - 1, static_cast<int>(std::floor(hiU - 0.5f)));
    const int r0 = std::max(row0, static_cast<int>(std::ceil(loV - 0.5f)));
    const int r1 = std::min(row1 - 1, static_cast<int>(std::floor(hiV - 0.5f)));
    for (int row = r0; row <= r1; ++row) {
      const float y = static_cast<float>(row) + 0.5f;
      for (int column = c0; column <= c1; ++column) {
        const float x = static_cast<float>(column) + 0.5f;
        // λ_k: the edge function of the edge opposite vertex k, over the area.
        float lambda[3];
        bool inside = true;
        for (int e = 0; e < 3 && inside; ++e) {
          const int a = order[(e + 1) % 3], b = order[(e + 2) % 3];
          const float edge = (t.u[b] - t.u[a]) * (y - t.v[a]) - (t.v[b] - t.v[a]) * (x - t.u[a]);
          lambda[order[e]] = edge * inverseArea;
          inside = edge >= 0.0f;
        }
        if (!inside) continue;
        if (textures.at(column, row).masked()) continue;
        ++*fragments;
        float weight[3];
        if (interpolation == Interpolation::kPerspective) {
          const float sum = lambda[0] * t.invW[0] + lambda[1] * t.invW[1] + lambda[2] * t.invW[2];
          for (int k = 0; k < 3; ++k) weight[k] = lambda[k] * t.invW[k] / sum;
        } else {
          for (int k = 0; k < 3; ++k) weight[k] = lambda[k];
        }
        const float z = weight[0] * t.z[0] + weight[1] * t.z[1] + weight[2] * t.z[2];
        float& stored = (*depth)[static_cast<size_t>((row - row0) * width + column)];
        if (!(z > stored)) continue;  // nearer = larger z; the first of equals wins
        stored = z;
        SurfaceSample& s = out->at(column, row);
        s.mesh = t.mesh;
        s.triangle = t.triangle;
        s.b1 = weight[0] * t.b1[0] + weight[1] * t.b1[1] + weight[2] * t.b1[2];
        s.b2 = weight[0] * t.b2[0] + weight[1] * t.b2[1] + weight[2] * t.b2[2];
      }
    }
  }
}

}  // namespace

const char* interpolationName(Interpolation interpolation) {
  return interpolation == Interpolation::kLinear ? "linear" : "perspective";
}

void RasterOptions::validate() const {
  if (tessellationLevel < 0 || tessellationLevel > kMaxTessellationLevel) {
    throw InputError({"", "tessellation_level", 0},
                     "must be in 0..8 (each level multiplies the triangles by 4)");
  }
  if (bandRows < 1 || bandRows > 4096) throw InputError({"", "band_rows", 0}, "must be in 1..4096");
}

Rasterizer::Rasterizer(const DisplayModel& model, int moduleIndex)
    : model_(model), forwardMap_(model, moduleIndex) {}

VisibilityBuffer Rasterizer::rasterize(const PhysicalScene& scene, const RayTextures& textures,
                                       const RasterOptions& options,
                                       RasterCounters* counters) const {
  options.validate();
  const auto start = std::chrono::steady_clock::now();
  const int width = textures.width(), height = textures.height();
  const Projector projector{forwardMap_, model_.observer.z, width, height};

  // Projection, parallel over source triangles; each keeps its own output list so the order
  // (and therefore which of two equal depths wins) does not depend on the thread schedule.
  struct Source {
    int mesh, triangle;
  };
  std::vector<Source> sources;
  for (size_t m = 0; m < scene.meshes().size(); ++m) {
    for (size_t t = 0; t < scene.meshes()[m].triangles.size(); ++t)
      sources.push_back({static_cast<int>(m), static_cast<int>(t)});
  }
  std::vector<std::vector<ScreenTriangle>> perSource(sources.size());
  tbb::combinable<RasterCounters> perThread;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, sources.size(), 4),
                    [&](const tbb::blocked_range<size_t>& range) {
                      std::vector<GridVertex> grid;
                      RasterCounters& c = perThread.local();
                      for (size_t i = range.begin(); i < range.end(); ++i) {
                        const Source& s = sources[i];
                        projectTriangle(projector, scene.meshes()[static_cast<size_t>(s.mesh)],
                                        s.mesh, s.triangle, options.tessellationLevel, &grid,
                                        &perSource[i], &c);
                      }
                    });
  std::vector<ScreenTriangle> triangles;
  size_t total = 0;
  for (const auto& list : perSource) total += list.size();
  triangles.reserve(total);
  for (auto& list : perSource) {
    triangles.insert(triangles.end(), list.begin(), list.end());
    std::vector<ScreenTriangle>().swap(list);
  }
  const double projectMs = msSince(start);

  // Binning by bands of rows, then the bands in parallel, each with its own slice of z-buffer.
  const auto rasterStart = std::chrono::steady_clock::now();
  const int bands = (height + options.bandRows - 1) / options.bandRows;
  std::vector<std::vector<int>> binned(static_cast<size_t>(bands));
  for (size_t i = 0; i < triangles.size(); ++i) {
    const ScreenTriangle& t = triangles[i];
    const float loV = std::min({t.v[0], t.v[1], t.v[2]}), hiV = std::max({t.v[0], t.v[1], t.v[2]});
    const int first =
        std::clamp(static_cast<int>(std::floor(loV - 0.5f)) / options.bandRows, 0, bands - 1);
    const int last =
        std::clamp(static_cast<int>(std::floor(hiV + 0.5f)) / options.bandRows, 0, bands - 1);
    for (int b = first; b <= last; ++b)
      binned[static_cast<size_t>(b)].push_back(static_cast<int>(i));
  }
  VisibilityBuffer out(width, height);
  tbb::combinable<long> fragments;
  tbb::parallel_for(0, bands, [&](int band) {
    const int row0 = band * options.bandRows, row1 = std::min(height, row0 + options.bandRows);
    std::vector<float> depth(static_cast<size_t>((row1 - row0) * width),
                             -std::numeric_limits<float>::infinity());
    rasterizeBand(triangles, binned[static_cast<size_t>(band)], row0, row1, textures,
                  options.interpolation, &depth, &out, &fragments.local());
  });
  if (counters) {
    *counters = RasterCounters{};
    perThread.combine_each([&](const RasterCounters& c) {
      counters->culledTriangles += c.culledTriangles;
      counters->projectedVertices += c.projectedVertices;
      counters->failedVertices += c.failedVertices;
      counters->droppedTriangles += c.droppedTriangles;
    });
    counters->sourceTriangles = static_cast<long>(sources.size());
    counters->drawnTriangles = static_cast<long>(triangles.size());
    counters->fragments = fragments.combine([](long a, long b) { return a + b; });
    counters->coveredPixels = out.coveredCount();
    counters->projectMs = projectMs;
    counters->rasterMs = msSince(rasterStart);
  }
  return out;
}

Frame rasterizeFrame(const Rasterizer& rasterizer, const PhysicalScene& scene,
                     const RayTextures& textures, const RasterOptions& options,
                     RasterCounters* counters) {
  return shadeDirect(scene, rasterizer.rasterize(scene, textures, options, counters), textures);
}

}  // namespace parallax
