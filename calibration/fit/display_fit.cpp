#include "calibration/fit/display_fit.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "calibration/fit/fit_problem.h"
#include "calibration/fit/fit_solve.h"
#include "calibration/fit/fit_statistics.h"
#include "calibration/fit/fit_uncertainty.h"
#include "calibration/fit/intrinsics_sensitivity.h"
#include "common/input_error.h"

namespace parallax {
namespace {

// Correspondences in the first solve when a final one follows (more cost time, not a better
// start); the final one uses all.
constexpr size_t kStartCorrespondences = 40000;

bool finalSolveFollows(const FitOptions& options) {
  return options.residualInCameraPx || options.reestimateNoise;
}

// Numbers the fit's steps for FitOptions::onStep across both transfers and the gate, so the
// caller's count is exact before the first step starts.
class FitSteps {
 public:
  explicit FitSteps(const FitOptions& options)
      : onStep_(options.onStep),
        total_((options.tryOtherTransfer ? 2 : 1) * (finalSolveFollows(options) ? 4 : 3) + 1) {}
  void begin(const std::string& what) {
    if (onStep_) onStep_(FitStep{++index_, total_, what});
  }

 private:
  const std::function<void(const FitStep&)>& onStep_;
  int total_;
  int index_ = 0;
};

void validateObservations(const DisplayModel& nominal, const CalibrationObservations& obs) {
  const int modules = static_cast<int>(nominal.modules.size());
  const int cameras = static_cast<int>(obs.stations.size());
  const int fiducials = static_cast<int>(obs.fiducials.size());
  auto finite2 = [](const Eigen::Vector2d& v) {
    return std::isfinite(v.x()) && std::isfinite(v.y());
  };
  if (cameras == 0) throw InputError({"", "stations", 0}, "no camera stations");
  for (int c = 0; c < cameras; ++c) {
    if (!obs.stations[static_cast<size_t>(c)].tapeCentre.allFinite()) {
      throw InputError({"", fmt::format("stations[{}].tape_centre", c), 0}, "not finite");
    }
  }
  for (size_t i = 0; i < obs.correspondences.size(); ++i) {
    const Correspondence& c = obs.correspondences[i];
    if (c.module < 0 || c.module >= modules || c.camera < 0 || c.camera >= cameras ||
        !finite2(c.cameraPx) || !finite2(c.modulePx)) {
      throw InputError({"", fmt::format("correspondences[{}]", i), 0},
                       "refers to a module or camera that does not exist, or is not finite");
    }
  }
  for (size_t i = 0; i < obs.stripes.size(); ++i) {
    const StripeCentre& s = obs.stripes[i];
    if (s.module < 0 || s.module >= modules || s.camera < 0 || s.camera >= cameras ||
        !finite2(s.cameraPx)) {
      throw InputError({"", fmt::format("stripes[{}]", i), 0},
                       "refers to a module or camera that does not exist, or is not finite");
    }
  }
  for (size_t i = 0; i < obs.fiducialSightings.size(); ++i) {
    const FiducialSighting& f = obs.fiducialSightings[i];
    if (f.fiducial < 0 || f.fiducial >= fiducials || f.camera < 0 || f.camera >= cameras ||
        !finite2(f.cameraPx)) {
      throw InputError({"", fmt::format("fiducial_sightings[{}]", i), 0},
                       "refers to a fiducial or camera that does not exist, or is not finite");
    }
  }
}

// The fit under one transfer: the stages in order, each building its own problem from what the
// previous ones found (fit_problem.h), then the statistics and the uncertainty of the answer.
FitResult runStages(const DisplayModel& nominal, const CalibrationObservations& obs,
                    const FitOptions& options, ScreenTransfer transfer, FitSteps& steps) {
  const std::string name = transferName(transfer);
  const auto start = std::chrono::steady_clock::now();
  const fit::FitInputs in(nominal, obs, options, transfer);
  fit::FitState state = fit::startingState(in);
  fit::NoiseLevels sigmas{options.correspondenceSigmaPx, options.stripeSigmaMm,
                          options.fiducialSigmaPx};
  FitResult result;
  auto solve = [&](fit::FitProblem& problem, double costTolerance) {
    const fit::SolveOutcome outcome = fit::solve(in, problem, state, costTolerance);
    result.iterations += outcome.iterations;
    result.stopped = result.stopped || outcome.stopped;
    if (problem.withModules) result.converged = outcome.converged;
  };

  // Stage 0: camera poses (and k) from fiducials and tape alone, so the full problem starts
  // with cameras that see the screen where it is.
  {
    steps.begin(name + ": camera poses");
    fit::FitProblem cameras = fit::buildProblem(in, sigmas, fit::CameraPlacementStage{}, &state);
    solve(cameras, /*costTolerance=*/0.0);
  }
  if (result.stopped) return result;
  const std::vector<bool> fiducialOutliers = fit::findFiducialOutliers(in, state, sigmas);

  // Stage 1: the module-px residual. It is defined wherever a camera ray meets the screen,
  // so a bad start or a gross decoding error cannot stop the solve; its answer is biased
  // (the camera noise sits inside the model) but close, and it finds the outliers and σ.
  // When a final solve follows, this is a start: it needs no more than
  // kStartCorrespondences.
  const bool finalFollows = finalSolveFollows(options);
  steps.begin(name + ": first solve");
  fit::CorrespondenceForm form;  // module px
  fit::ModuleStage stage1;
  stage1.form = &form;
  stage1.stride =
      finalFollows ? std::max<size_t>(1, obs.correspondences.size() / kStartCorrespondences) : 1;
  stage1.fiducialOutliers = &fiducialOutliers;
  fit::FitProblem problem = fit::buildProblem(in, sigmas, stage1, &state);
  solve(problem, finalFollows ? fit::kStartCostTolerance : fit::kFinalCostTolerance);
  if (result.stopped) return result;
  if (options.reestimateNoise)
    sigmas = fit::reestimateNoise(in, state, form, sigmas, /*fiducials=*/true);

  // Stage 2, the final solve with every correspondence: in camera px from that start,
  // without the gross outliers (fit::cameraPxForm), or again in module px with the
  // re-estimated σ.
  fit::ModuleStage stage2;
  stage2.fiducialOutliers = &fiducialOutliers;
  if (options.residualInCameraPx) form = fit::cameraPxForm(in, state, sigmas);
  stage2.form = &form;
  const fit::ModuleStage& finalStage = finalFollows ? stage2 : stage1;
  if (finalFollows) {
    steps.begin(name + ": final solve");
    problem = {};  // the previous problem's blocks go before the new one is built
    problem = fit::buildProblem(in, sigmas, stage2, &state);
    solve(problem, fit::kFinalCostTolerance);
    if (result.stopped) return result;
  }
  if (options.residualInCameraPx && options.reestimateNoise) {
    sigmas = fit::reestimateNoise(in, state, form, sigmas);
    problem = fit::buildProblem(in, sigmas, stage2, &state);  // the covariance reads the final σ
  }
  result.solveSeconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  steps.begin(name + ": uncertainty");
  const auto diagnosticsStart = std::chrono::steady_clock::now();
  fit::summarizeResiduals(in, state, form, sigmas, &result);
  fit::diagnoseUncertainty(in, state, sigmas, problem,
                           fit::intrinsicsSensitivity(in, sigmas, finalStage, state, problem),
                           &result);
  fit::noteModulesNotEstimated(in, &result);
  result.diagnosticsSeconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - diagnosticsStart).count();
  return result;
}

}  // namespace

void FitOptions::validate() const {
  auto positive = [](double v, const char* name) {
    if (!(std::isfinite(v) && v > 0.0))
      throw InputError({"", name, 0}, fmt::format("must be > 0, got {}", v));
  };
  positive(correspondenceSigmaPx, "correspondence_sigma_px");
  positive(stripeSigmaMm, "stripe_sigma_mm");
  positive(fiducialSigmaPx, "fiducial_sigma_px");
  positive(tapeSigmaM, "tape_sigma_m");
  positive(robustScale, "robust_scale");
  positive(transferMismatchRatio, "transfer_mismatch_ratio");
  if (!(unreliableDecodeTail >= 0.0 && unreliableDecodeTail < 1.0))
    throw InputError({"", "unreliable_decode_tail", 0},
                     fmt::format("must be in [0, 1), got {}", unreliableDecodeTail));
  gate.validate();
  rayGrid.validate();
  if (maxIterations < 1 || maxIterations > 10000)
    throw InputError({"", "max_iterations", 0}, "must be 1..10000");
  if (threads < 1 || threads > 256) throw InputError({"", "threads", 0}, "must be 1..256");
  conditioning.validate();
}

std::string Deficiency::describe() const {
  std::string who = module < 0 ? "shared parameters" : fmt::format("module {}", module);
  std::string params;
  for (size_t i = 0; i < parameters.size(); ++i) params += (i ? ", " : "") + parameters[i];
  return fmt::format("{}: {} (reciprocal condition {:.2e}); the data cannot separate: {}", who,
                     conditioningName(state), reciprocalCondition, params);
}

bool FitResult::passesQualityChecks() const { return !stopped && gate.passes; }

FitResult fitDisplay(const DisplayModel& nominal, const CalibrationObservations& observations,
                     const FitOptions& options) {
  options.validate();
  nominal.validate();
  validateObservations(nominal, observations);
  for (int m : options.heldModules) {
    if (m < 0 || m >= static_cast<int>(nominal.modules.size())) {
      throw InputError({"", "held_modules", 0},
                       fmt::format("no module {} (the display has {})", m, nominal.modules.size()));
    }
  }
  const ScreenTransfer transfer = options.transfer.value_or(nominal.screen.transfer);
  FitSteps steps(options);
  FitResult result = runStages(nominal, observations, options, transfer, steps);
  if (options.tryOtherTransfer && !result.stopped) {
    FitOptions other = options;
    other.tryOtherTransfer = false;
    other.transfer =
        transfer == ScreenTransfer::kConical ? ScreenTransfer::kLinear : ScreenTransfer::kConical;
    FitResult alt = runStages(nominal, observations, other, *other.transfer, steps);
    if (alt.stopped) return alt;
    result = selectTransfer(std::move(result), std::move(alt), options.gate);
  }
  result.heldModules = options.heldModules;
  if (!result.stopped) {
    steps.begin("quality gate");
    applyGate(nominal, options.gate, options.rayGrid, &result);
  }
  return result;
}

}  // namespace parallax
