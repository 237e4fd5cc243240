#pragma once
// The fit's covariance carried to what a viewer sees: for a grid of pixels over a module's whole
// image, the standard deviation of
//   module px:   the pixel the fitted model uses to light the true screen point (the error
//                compareRays measures, ray_error.h), from the module's parameters alone;
//   observer mm: where the pixel's primary ray meets the observer line, from the module's
//                parameters and the screen curvature k (the transfer turns both into an angle).
// First order: J Σ Jᵀ with J by central differences through the same manifold the fit uses,
// so a module is judged by the rays it will actually light, corners included (where the fit
// extrapolates and the error is largest), not by its parameters' σ.

#include <Eigen/Core>

#include "calibration/display/display_model.h"

namespace parallax {

struct RayUncertaintyOptions {
  // Grid spacing (module px): the pixels compareRays samples (ray_error.h) at the same step,
  // so a prediction and a truth comparison look at the same pixels. 0: the image's width / 32
  // (at least 4 px), a few hundred pixels a module. The worst pixel is near the edge of the
  // area that lands on the screen, so the grid must be dense, not a few corners.
  int stepPx = 0;

  void validate() const;
};

struct RayUncertainty {
  int samples = 0;  // grid pixels whose ray reaches the observer line
  // σ of the error's length (the square root of the trace of its covariance: the RMS the
  // error would have over many calibrations), RMS over the grid and at its worst pixel.
  double rmsPx = 0.0, worstPx = 0.0;
  double rmsObserverMm = 0.0, worstObserverMm = 0.0;
  // False when the covariance is not finite (a rank-deficient module): nothing bounds its rays.
  bool bounded = true;
};

// `covariance`: (kModuleTangentSize + 1)², the module's tangent parameters in the fit's order
// (calibration_geometry.h, Ceres' quaternion manifold) followed by the curvature k.
RayUncertainty predictRayUncertainty(const DisplayModel& fitted, int module,
                                     const Eigen::MatrixXd& covariance,
                                     const RayUncertaintyOptions& options = {});

}  // namespace parallax
