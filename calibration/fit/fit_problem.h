#pragma once
// The fit's problem, built stage by stage (display_fit.h describes the fit; display_fit.cpp
// runs the stages in order). What a stage puts in its problem is stated by the stage struct it
// is built from, never by state left behind by an earlier stage:
//   CameraPlacementStage — the cameras (and k) from the fiducials and the tape alone;
//   ModuleStage          — modules, cameras and k from every observation, the correspondences
//                          in one of their two forms (CorrespondenceForm).
// The same forms give the unrobustified residuals that the statistics between and after the
// solves read (outliers, noise levels, the report). Internal to parallax_fit.

#include <ceres/ceres.h>

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "calibration/camera/calibration_geometry.h"
#include "calibration/camera/calibration_observations.h"
#include "calibration/display/display_model.h"
#include "calibration/fit/display_fit.h"

namespace parallax::fit {

// A correspondence this many σ off is counted as an outlier in the report (the Cauchy loss has
// already down-weighted it in the fit).
constexpr double kOutlierSigmas = 5.0;
// The share of gross errors a sound decode may have however clean the others are (a few per
// hundred: a pixel on a module's image edge or a lobe's rim): what keeps one or two of them
// from condemning a decode when the typical share is near zero.
constexpr double kTypicalGrossErrorShare = 0.01;
// A station sees a module, for the gate, when the final solve holds at least this share of the
// module's inlier correspondences from it: a sliver at the edge of its picture is no second
// view.
constexpr double kMinViewShare = 0.05;

// P(X ≥ k) for X ~ Binomial(n, p).
double binomialUpperTail(int n, int k, double p);

// What a fit starts from and never changes: the observations, the options and the assumed
// transfer, with what follows from them once.
struct FitInputs {
  FitInputs(const DisplayModel& nominalModel, const CalibrationObservations& observations,
            const FitOptions& fitOptions, ScreenTransfer assumedTransfer);

  const DisplayModel& nominal;
  const CalibrationObservations& obs;
  const FitOptions& options;
  ScreenTransfer transfer;
  std::vector<bool> observed;  // per module: in at least one correspondence
  std::vector<bool> held;      // per module: FitOptions::heldModules
  // Camera pixels in normalized coordinates (the camera intrinsics are fixed: undistortion
  // happens once, here, never inside the solver).
  std::vector<Eigen::Vector2d> correspondenceN, stripeN;
};

// The unknowns as Ceres parameter blocks (calibration_geometry.h's layouts).
struct FitState {
  std::vector<std::array<double, kModuleBlockSize>> modules;
  std::vector<std::array<double, kCameraBlockSize>> cameras;
  double k = 0.0;
};

// The start: nominal modules and k, cameras at their tape marks aimed at the screen centre.
FitState startingState(const FitInputs& in);

// Noise levels (σ) that scale the residuals: from the options, then re-estimated.
struct NoiseLevels {
  double correspondencePx, stripeMm, fiducialPx;
};

// The correspondence residual's two forms (fit_residuals.h), both in module px.
struct CorrespondenceForm {
  enum Kind { kModulePx, kCameraPx };
  Kind kind = kModulePx;
  // kCameraPx only, per correspondence: module px per camera px (fixed from the module-px
  // answer), and the gross outliers of that answer, left out.
  std::vector<double> cameraScale;
  std::vector<bool> excluded;
  // kCameraPx only: the (station, module) decodes excluded whole (FitOptions::
  // unreliableDecodeTail), with their counts.
  std::vector<UnreliableDecode> unreliable;

  bool uses(size_t i) const { return kind == kModulePx || !excluded[i]; }
};

// Stage 0: the fiducials (robust, which finds the misdetected ones) and the tape.
struct CameraPlacementStage {};

// Stages 1 and 2: every observed module added, the correspondences in `form`.
struct ModuleStage {
  const CorrespondenceForm* form = nullptr;
  // Every stride-th correspondence (observations come in scan order, so every module and
  // station keeps its share): a start needs no more than a few tens of thousands.
  size_t stride = 1;
  // Per fiducial sighting, found after stage 0: left out. The others enter without a loss.
  const std::vector<bool>* fiducialOutliers = nullptr;
};

// A built problem and the robust loss its blocks share (owned here, not by the problem; the
// problem is destroyed first). Every residual block is listed in the order it was added, with
// the group whose errors share a common part (groupOf, −1 for none): the decoded
// correspondences, and apart the stripe centres, of one module seen from one station. One
// lobe's stripe centres err together (demo, picture path at the truth: a module's mean stripe
// error at one station up to 0.3 mm against 0.04 mm for independent errors), so they carry
// far less information than their count says (fit_uncertainty.cpp).
struct FitProblem {
  std::unique_ptr<ceres::LossFunction> loss;
  std::unique_ptr<ceres::Problem> problem;
  bool withModules = false;
  std::vector<ceres::ResidualBlockId> residualBlocks;
  std::vector<std::int64_t> groupOf;

  void add(ceres::ResidualBlockId id, std::int64_t group = -1) {
    residualBlocks.push_back(id);
    groupOf.push_back(group);
  }
};

// The group of a decoded observation (FitProblem::groupOf).
enum class DecodedKind { kCorrespondence = 0, kStripe = 1 };
inline std::int64_t decodedGroup(int station, int module, DecodedKind kind) {
  return (static_cast<std::int64_t>(station) * 65536 + module) * 2 + static_cast<int>(kind);
}

FitProblem buildProblem(const FitInputs& in, const NoiseLevels& sigmas,
                        const CameraPlacementStage& stage, FitState* state);
FitProblem buildProblem(const FitInputs& in, const NoiseLevels& sigmas, const ModuleStage& stage,
                        FitState* state);

// ---- unrobustified residuals, in their natural units, through the current state ----

// Correspondence i in `form` (module px); false where it cannot be evaluated.
bool correspondenceResidual(const FitInputs& in, const FitState& state,
                            const CorrespondenceForm& form, size_t i, Eigen::Vector2d* r);
// Stripe i (mm on the screen).
bool stripeResidualMm(const FitInputs& in, const FitState& state, size_t i, double* r);
// Fiducial sighting i (camera px).
bool fiducialResidualPx(const FitInputs& in, const FitState& state, size_t i, Eigen::Vector2d* r);

// ---- between the stages ----

// Fiducial sightings more than kOutlierSigmas σ off once the cameras are placed.
std::vector<bool> findFiducialOutliers(const FitInputs& in, const FitState& state,
                                       const NoiseLevels& sigmas);
// The camera-px form from the module-px answer: scales, gross outliers, and the decodes with
// far more of them than the typical decode (FitOptions::unreliableDecodeTail).
CorrespondenceForm cameraPxForm(const FitInputs& in, const FitState& state,
                                const NoiseLevels& sigmas);
// σ from the residuals (median absolute deviation), floored. With `fiducials`, theirs too:
// only from the first solve's answer, where their a-priori σ (FitOptions::fiducialSigmaPx)
// lets them barely pull the cameras, so their residuals hold their noise and what the other
// data say of the cameras (an upper bound on the noise, not the smaller residuals of a solve
// that follows them). The fixed 0.2 px, 6–20× the decoded fiducials' error, put that much
// noise into every camera's σ and through it into every module's (demo, exact intrinsics:
// modules' true px error 0.21× the predicted; 0.76× with 0.02 px).
NoiseLevels reestimateNoise(const FitInputs& in, const FitState& state,
                            const CorrespondenceForm& form, const NoiseLevels& sigmas,
                            bool fiducials = false);
// Size of a module pixel on the screen (mm), for expressing module-px noise on the screen.
double mmPerModulePx(const FitInputs& in, const FitState& state);

// Robust σ: 1.4826 × median |r| is σ for Gaussian noise and ignores up to half outliers.
double robustSigma(const std::vector<double>& absResiduals);

}  // namespace parallax::fit
