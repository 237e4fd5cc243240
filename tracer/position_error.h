#pragma once
// How far a frame's surfaces are from the exact answer, the error axis of the paper's
// comparison (Fig. 6 and the error-vs-time table of `parallax report`).
//
// The exact answer of a pixel is the point where its centre's primary ray, from the ray
// function in double precision (not the float ray textures), meets the plane of the triangle
// the ray tracer found there: the tracer decides which surface, double precision says where.
// For a candidate (rasterized or traced) VisibilityBuffer, over the pixels both cover:
//   physical mm: |P_candidate − P_exact|;
//   module px:   |forwardMap(P_candidate) − (i + ½, j + ½)|, how far from this pixel the point
//                the candidate shows here belongs (the exact point maps to the centre itself).
// Pixels covered by only one of the two (silhouettes the rasterizer's straight edges miss) are
// counted apart: they have no position error, they have a wrong surface.

#include <Eigen/Core>
#include <vector>

#include "calibration/display/display_model.h"
#include "calibration/display/forward_map.h"
#include "tracer/physical_scene.h"
#include "tracer/visibility_buffer.h"

namespace parallax {

struct ExactSurface {
  int width = 0, height = 0;
  std::vector<Eigen::Vector3d> points;  // physical; NaN where the pixel shows no surface

  const Eigen::Vector3d& at(int column, int row) const {
    return points[static_cast<size_t>(row) * static_cast<size_t>(width) +
                  static_cast<size_t>(column)];
  }
};

// `traced`: tracePrimaryVisibility of the same module (it names each pixel's triangle).
ExactSurface exactSurface(const PhysicalScene& scene, const DisplayModel& model, int moduleIndex,
                          const VisibilityBuffer& traced);

struct PositionErrorOptions {
  // The module-pixel error costs a forward map (a Newton solve under `conical`) per pixel: it is
  // taken on at most this many covered pixels, spread evenly; the mm error on all of them.
  long maxPixelSamples = 20000;
};

struct PositionError {
  long compared = 0;       // covered by both
  long candidateOnly = 0;  // the candidate shows a surface where the exact ray sees none
  long exactOnly = 0;      // and the converse
  double rmsMm = 0.0, maxMm = 0.0;
  long pixelSamples = 0;
  long pixelFailures = 0;  // the candidate's point has no pixel in this module (forward map fails)
  double rmsPx = 0.0, maxPx = 0.0;
};

PositionError positionError(const PhysicalScene& scene, const VisibilityBuffer& candidate,
                            const ExactSurface& exact, const ForwardMap& forwardMap,
                            const PositionErrorOptions& options = {});

}  // namespace parallax
