#include "tracer/position_error.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "calibration/display/ray_function.h"
#include "common/check.h"

namespace parallax {

ExactSurface exactSurface(const PhysicalScene& scene, const DisplayModel& model, int moduleIndex,
                          const VisibilityBuffer& traced) {
  const RayFunction rays(model, moduleIndex);
  ExactSurface out;
  out.width = traced.width;
  out.height = traced.height;
  out.points.assign(traced.samples.size(),
                    Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN()));
  tbb::parallel_for(
      tbb::blocked_range<int>(0, traced.height, 4), [&](const tbb::blocked_range<int>& rowRange) {
        for (int row = rowRange.begin(); row < rowRange.end(); ++row) {
          for (int column = 0; column < traced.width; ++column) {
            const SurfaceSample& s = traced.at(column, row);
            if (!s.covered()) continue;
            const PixelRay ray = rays.atPixel(column, row);
            if (!ray.valid()) continue;
            const PhysicalMesh& mesh = scene.meshes()[static_cast<size_t>(s.mesh)];
            const auto& tri = mesh.triangles[static_cast<size_t>(s.triangle)];
            const Eigen::Vector3d p0 = mesh.positions[tri[0]].cast<double>();
            const Eigen::Vector3d n = (mesh.positions[tri[1]].cast<double>() - p0)
                                          .cross(mesh.positions[tri[2]].cast<double>() - p0);
            const Eigen::Vector3d d = ray.direction();
            const double denominator = n.dot(d);
            // A ray in the triangle's plane (grazing to the last bit): no better answer than the
            // tracer's.
            const Eigen::Vector3d point =
                std::abs(denominator) > 1e-12 * n.norm()
                    ? Eigen::Vector3d(ray.origin + n.dot(p0 - ray.origin) / denominator * d)
                    : surfacePosition(scene, s).cast<double>();
            out.points[static_cast<size_t>(row) * static_cast<size_t>(traced.width) +
                       static_cast<size_t>(column)] = point;
          }
        }
      });
  return out;
}

PositionError positionError(const PhysicalScene& scene, const VisibilityBuffer& candidate,
                            const ExactSurface& exact, const ForwardMap& forwardMap,
                            const PositionErrorOptions& options) {
  PARALLAX_CHECK_OP(candidate.width, ==, exact.width);
  PARALLAX_CHECK_OP(candidate.height, ==, exact.height);
  // Which pixels get the module-pixel error: every stride-th of the compared ones.
  long comparable = 0;
  for (size_t i = 0; i < candidate.samples.size(); ++i) {
    if (candidate.samples[i].covered() && exact.points[i].allFinite()) ++comparable;
  }
  const long stride = std::max<long>(
      1, (comparable + options.maxPixelSamples - 1) / std::max<long>(1, options.maxPixelSamples));

  struct Partial {
    PositionError e;
    double sumMm2 = 0.0, sumPx2 = 0.0;
  };
  // Row prefix counts of comparable pixels, so each row knows which of its pixels are sampled.
  std::vector<long> before(static_cast<size_t>(candidate.height) + 1, 0);
  for (int row = 0; row < candidate.height; ++row) {
    long n = 0;
    for (int column = 0; column < candidate.width; ++column) {
      n += candidate.at(column, row).covered() && exact.at(column, row).allFinite();
    }
    before[static_cast<size_t>(row) + 1] = before[static_cast<size_t>(row)] + n;
  }
  tbb::combinable<Partial> partials;
  tbb::parallel_for(tbb::blocked_range<int>(0, candidate.height, 2),
                    [&](const tbb::blocked_range<int>& rowRange) {
                      Partial& p = partials.local();
                      for (int row = rowRange.begin(); row < rowRange.end(); ++row) {
                        long index = before[static_cast<size_t>(row)];
                        for (int column = 0; column < candidate.width; ++column) {
                          const SurfaceSample& s = candidate.at(column, row);
                          const Eigen::Vector3d& exactPoint = exact.at(column, row);
                          const bool hasExact = exactPoint.allFinite();
                          if (!s.covered() || !hasExact) {
                            if (s.covered()) ++p.e.candidateOnly;
                            if (hasExact) ++p.e.exactOnly;
                            continue;
                          }
                          ++p.e.compared;
                          const Eigen::Vector3d position = surfacePosition(scene, s).cast<double>();
                          const double mm = 1e3 * (position - exactPoint).norm();
                          p.sumMm2 += mm * mm;
                          p.e.maxMm = std::max(p.e.maxMm, mm);
                          if (index++ % stride != 0) continue;
                          const ForwardMapResult r = forwardMap.pixelOfContinued(position);
                          if (!r.ok) {
                            ++p.e.pixelFailures;
                            continue;
                          }
                          const double px =
                              (r.pixel - Eigen::Vector2d(column + 0.5, row + 0.5)).norm();
                          ++p.e.pixelSamples;
                          p.sumPx2 += px * px;
                          p.e.maxPx = std::max(p.e.maxPx, px);
                        }
                      }
                    });
  Partial total;
  partials.combine_each([&](const Partial& p) {
    total.e.compared += p.e.compared;
    total.e.candidateOnly += p.e.candidateOnly;
    total.e.exactOnly += p.e.exactOnly;
    total.e.pixelSamples += p.e.pixelSamples;
    total.e.pixelFailures += p.e.pixelFailures;
    total.e.maxMm = std::max(total.e.maxMm, p.e.maxMm);
    total.e.maxPx = std::max(total.e.maxPx, p.e.maxPx);
    total.sumMm2 += p.sumMm2;
    total.sumPx2 += p.sumPx2;
  });
  PositionError e = total.e;
  if (e.compared > 0) e.rmsMm = std::sqrt(total.sumMm2 / static_cast<double>(e.compared));
  if (e.pixelSamples > 0) e.rmsPx = std::sqrt(total.sumPx2 / static_cast<double>(e.pixelSamples));
  return e;
}

}  // namespace parallax
