#pragma once
// What a viewer sees: the screen's appearance from a viewpoint, assembled from the module
// frames through the display physics (the "observer views").
//
// The view is parametrised by the screen itself: view pixel (i, j) is the screen point
// s = (−W/2 + (i + ½)·W/w, H/2 − (j + ½)·H/h, sag), so two views of the same display compare
// pixel for pixel whatever the viewpoint. At s every module whose image covers s sends its pixel
// (the forward projection of s − p) along the ray its transfer gives, toward o on the observer
// line; the screen spreads it horizontally in a Gaussian lobe whose full width at half maximum
// is the display's diffusion width. The viewer receives the sum over modules of colour × lobe
// at the horizontal angle between "s → o" and "s → viewer", each module's lobe scaled by its
// share of the modules' exit angles at s, so that the row sums to ~1 (a brightness-calibrated
// display): with too narrow a diffusion the viewer sees dark gaps.

#include <Eigen/Core>
#include <vector>

#include "calibration/display/display_model.h"
#include "calibration/display/ray_textures.h"
#include "tracer/frame.h"

namespace parallax {

struct ObserverViewOptions {
  int width = 640;   // view pixels across the screen's chord
  int height = 360;  // and down its height

  void validate() const;  // throws InputError naming the option
};

// `frames[i]` is module i's frame (linear RGB), each of its module's resolution. `coverage`
// (optional) receives, per view pixel, the summed lobe weight: ~1 where the modules light that
// screen point for this viewer, 0 where none of their rays reaches the viewer (outside the
// display's field of view), in between in the gaps of a too narrow diffusion.
Frame synthesizeObserverView(const DisplayModel& model, const std::vector<Frame>& frames,
                             const Eigen::Vector3d& viewer, const ObserverViewOptions& options,
                             std::vector<float>* coverage = nullptr);

// The rays a viewer at x on the observer line sees the scene along, one per view pixel (o = the
// viewer, s = the view pixel's screen point), in the tracer's compact form: rendering them with
// renderFrame gives the view traced directly, the reference for synthesizeObserverView.
RayTextures observerViewRays(const DisplayModel& model, double viewerX,
                             const ObserverViewOptions& options);
// The same for a viewer anywhere in front of the screen (off the observer line too).
RayTextures observerViewRays(const DisplayModel& model, const Eigen::Vector3d& viewer,
                             const ObserverViewOptions& options);

// Peak signal-to-noise ratio (dB) of two same-sized frames over sRGB-encoded values in [0, 1];
// +inf when they are identical. With `mask`, only pixels whose mask value is ≥ 0.5 count.
double psnrDb(const Frame& a, const Frame& b, const std::vector<float>* mask = nullptr);

}  // namespace parallax
