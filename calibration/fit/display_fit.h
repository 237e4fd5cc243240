#pragma once
// The Ceres fit of a DisplayModel to calibration observations (calibration_observations.h).
//
// Unknowns, started from the nominal layout: every observed module's pose (a quaternion on
// Ceres' EigenQuaternionManifold), intrinsics and radial distortion (one 13-entry block, see
// fit_geometry.h); every camera station's pose (started from its tape-measured centre, aimed at
// the screen centre); the screen curvature k (never R: k = 0 is an ordinary value).
// Residuals, each divided by its noise level σ so they are comparable:
//   correspondence (2), in two stages (FitOptions::residualInCameraPx):
//       first, the camera pixel back-projects to a screen point s(k, camera); its projection
//       into the module minus the decoded module pixel (module px). Defined wherever the
//       camera sees the screen, so robust from a poor start, but the camera's noise sits
//       inside the model (an errors-in-variables bias);
//       then, from that start and without its gross outliers, the decoded module pixel lights
//       a screen point s(module, k) whose camera pixel is predicted and compared with the
//       measured one, scaled to module px. The noise stays on the measured side.
//   stripe (1): at a stripe centre seen by a camera the transfer sends module light exactly to
//       the camera; the mismatch (fit_geometry.h's stripeMismatch, mm on the screen). This is
//       what separates a module's focal length from its distance.
//   fiducial (2): the markers on the screen frame reprojected into the camera (camera px).
//   tape (3): each camera centre near its tape-measured place (σ = the tape's accuracy).
// A Cauchy loss guards against decoding outliers. The noise levels start from the options and
// are re-estimated from the first stage's residuals (median absolute deviation) for the
// second, and again from its residuals for the covariance, so the standard deviations
// reported afterwards mean what they say.

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "calibration/camera/calibration_observations.h"
#include "calibration/display/display_model.h"
#include "calibration/fit/calibration_gate.h"
#include "calibration/fit/fit_diagnostics.h"
#include "calibration/fit/transfer_selection.h"

namespace parallax {

// Where a fit is, for FitOptions::onStep: step `index` (1-based) of `total`, named ("conical:
// final solve"). Under each transfer tried: the camera poses, the first solve, the final
// solve (when one follows) and the uncertainty; then the quality gate.
struct FitStep {
  int index = 0;
  int total = 0;
  std::string what;
};

struct FitOptions {
  std::optional<ScreenTransfer> transfer;  // assumed transfer; default: the nominal model's
  double correspondenceSigmaPx = 0.3;      // module px, first guess (re-estimated)
  double stripeSigmaMm = 0.5;              // first guess (re-estimated)
  double fiducialSigmaPx = 0.2;            // camera px
  double tapeSigmaM = 0.05;
  double robustScale = 3.0;  // Cauchy scale, in units of σ
  // Correspondence residual: true — the camera pixel predicted from the module pixel (the
  // noise stays on the measured side), after a first solve with the other form for a robust
  // start and to find the gross outliers; false — only the camera pixel back-projected into
  // the module (the noise inside the model: an errors-in-variables bias that nearly doubles
  // the ray error on `default`, bench --experiment). Both in module px.
  bool residualInCameraPx = true;
  // A (station, module) decode whose count of gross errors (kOutlierSigmas σ off after the
  // first solve) is this improbable for the display's typical decode (the median decode's
  // share, at least kTypicalGrossErrorShare; binomial upper tail) is left out whole from the
  // final solve: what made them (a module seen at a steep angle, its lobe's strip narrow and
  // packed beside its neighbours') biases its other correspondences too, together, in a way
  // the module's own parameters absorb (72 modules from pictures, seeds 1000–1002, against the
  // truth: the mean error of a decode with 10–40% gross errors is 0.05–0.07 px, where it is
  // 0.015 below 5%, the noise's own 0.013), so neither the residuals nor the σ show it.
  // Independent gross errors, however many, leave every decode at the typical share. 0: keep
  // every decode.
  double unreliableDecodeTail = 1e-3;
  bool reestimateNoise = true;
  bool fitCurvature = true;
  bool fitDistortion = true;
  int maxIterations = 100;
  int threads = 2;
  // Fit under both transfers and keep the one the stripes support (transfer_selection.h).
  bool tryOtherTransfer = true;
  // Stripe residuals this many times the correspondences' noise (both as mm on the screen)
  // mean the screen does not follow the assumed transfer.
  double transferMismatchRatio = 5.0;
  ConditioningOptions conditioning;
  // The gate (calibration_gate.h): fixed limits on every module's predicted worst ray error,
  // over a grid of its pixels.
  GateLimits gate;
  RayUncertaintyOptions rayGrid;
  // Modules held at their starting values (the `nominal` argument, which for a refit is the
  // current calibration): constant in the solve, their correspondences still placing the
  // cameras. Refitting one replaced module holds all the others (`calibrate --module N`);
  // hold the curvature too (fitCurvature = false) when the screen did not change.
  std::vector<int> heldModules;
  std::function<void(int iteration, double cost)> onIteration;  // progress, optional
  std::function<void(const FitStep&)> onStep;                   // as each step starts, optional
  // Polled at every solver iteration, optional: true ends the fit there (FitResult::stopped).
  // A daemon's `cancel` need not wait for a solve of many modules to finish.
  std::function<bool()> stopRequested;

  void validate() const;
};

struct ModuleFit {
  int module = 0;  // index in the model
  bool observed = false;
  int correspondences = 0, stripes = 0, outliers = 0;
  int decodesLeftOut = 0;  // its stations' decodes left out whole (FitResult::unreliableDecodes)
  // Stations whose decode of it the final solve holds, each with a real share of its inlier
  // correspondences (kMinViewShare): a module seen from one alone cannot be bounded
  // (calibration_gate.h).
  int stationsSeeing = 0;
  double rmsPx = 0.0;  // correspondences, robust inliers (module px)
  double stripeRmsMm = 0.0;
  BlockConditioning conditioning;
  // Standard deviations: rotation about x, y, z (deg), position x, y, z (mm), fx, fy, cx, cy
  // (px), k1, k2. +inf where the data cannot determine the parameter.
  std::array<double, 12> stdDev{};
  // The covariance of the module's tangent parameters (12) and the curvature k (last), what
  // the gate carries to its rays; empty when the module was not estimated.
  Eigen::MatrixXd rayCovariance;
  double worstPixelStdDevPx = 0.0;  // σ of its worst grid pixel (module px), from the gate
};

struct CameraFit {
  int camera = 0;
  CameraPose pose;
  int correspondences = 0, fiducials = 0;
  double rmsPx = 0.0;              // its correspondences (module px)
  double fiducialRmsPx = 0.0;      // camera px
  std::array<double, 6> stdDev{};  // rotation (deg), centre (mm)
};

struct Deficiency {
  int module = -1;  // −1: the shared parameters (cameras, k)
  Conditioning state = Conditioning::kGood;
  double reciprocalCondition = 1.0;
  std::vector<std::string> parameters;  // the undetermined combination, largest share first

  std::string describe() const;
};

struct UnreliableDecode {
  int station = 0, module = 0;
  int correspondences = 0, grossErrors = 0;
  double typicalShare = 0.0;  // the share it was judged against
};

struct FitResult {
  DisplayModel model;
  std::vector<CameraFit> cameras;
  std::vector<ModuleFit> modules;
  double curvatureStdDev = 0.0;  // 1/m
  std::vector<Deficiency> deficiencies;
  double correspondenceSigmaPx = 0.0;  // re-estimated noise (module px)
  double correspondenceSigmaMm = 0.0;  // the same as mm on the screen
  double stripeRmsMm = 0.0;
  double stripeSigmaMm = 0.0;             // re-estimated (robust) noise of the stripe centres
  std::vector<double> stripeResidualsMm;  // every stripe centre of an observed module, signed
  double fiducialRmsPx = 0.0;
  // The decoded rows' spread within a (station, module) group and of the groups' common parts,
  // in units of their σ: correspondences u, v, stripes within; then the same between
  // (fit_uncertainty.cpp). A common part widens the σ of what those rows determine.
  std::array<double, 6> sharedErrors{};
  // The σ include the camera intrinsics' uncertainty (CalibrationObservations::
  // intrinsicsCovariance, the checkerboard's), carried through the fit (fit_uncertainty.h).
  bool intrinsicsCarried = false;
  // Decoded from pictures: the lens blur the decoder undid (CalibrationObservations::
  // lensBlurSigmaPx), nullopt when none was stated.
  std::optional<double> lensBlurSigmaPx;
  // Set when the transfer cannot be decided and the choice matters (transfer_selection.h).
  bool transferMismatch = false;
  // Set when camera.json gives no response, the pictures bend, and the decoder cannot tell
  // which end bends (CameraResponseCheck::undecided).
  bool cameraResponseUndecided = false;
  std::optional<TransferEvidence> transferEvidence;  // when both transfers were fitted
  std::optional<double> otherTransferStripeRmsMm;    // when the other transfer was tried
  std::vector<std::string> notes;  // findings a user must read (mismatch, unseen modules, ...)
  int iterations = 0;
  double solveSeconds = 0.0;        // the solves (the fit)
  double diagnosticsSeconds = 0.0;  // residual statistics, covariance and conditioning after it
  bool converged = false;
  // FitOptions::stopRequested ended it: no model and no statistics, only `iterations`.
  bool stopped = false;
  int outliers = 0;
  // The (station, module) decodes left out of the final solve (FitOptions::unreliableDecodeTail).
  std::vector<UnreliableDecode> unreliableDecodes;
  std::vector<int> heldModules;  // FitOptions::heldModules
  GateResult gate;               // calibration_gate.h

  // The quality gate (calibration_gate.h): the fit finished and every module's predicted worst
  // ray error is within the fixed limits (or, with GateLimits::allowPartial, the failing ones
  // are held nominal and named). A calibration that fails it is not installed.
  bool passesQualityChecks() const;
};

// Throws InputError for observations that reference modules/cameras/fiducials that do not
// exist or carry non-finite numbers.
FitResult fitDisplay(const DisplayModel& nominal, const CalibrationObservations& observations,
                     const FitOptions& options);

}  // namespace parallax
