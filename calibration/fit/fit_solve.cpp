#include "calibration/fit/fit_solve.h"

#include <functional>
#include <memory>

namespace parallax::fit {
namespace {

class ProgressCallback : public ceres::IterationCallback {
 public:
  explicit ProgressCallback(const std::function<void(int, double)>& f) : f_(f) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    if (f_) f_(s.iteration, s.cost);
    return ceres::SOLVER_CONTINUE;
  }

 private:
  const std::function<void(int, double)>& f_;
};

// Ends a solve when the caller asks (FitOptions::stopRequested).
class StopCallback : public ceres::IterationCallback {
 public:
  explicit StopCallback(const std::function<bool()>& stopRequested)
      : stopRequested_(stopRequested) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    return stopRequested_() ? ceres::SOLVER_ABORT : ceres::SOLVER_CONTINUE;
  }

 private:
  const std::function<bool()>& stopRequested_;
};

// Stops a solve once a successful step lowers the cost by less than `tolerance`. The cost is
// ½ Σ (r/σ)², so near the minimum a step that lowers it by ΔC moved the parameters by
// √(2 ΔC) standard deviations (Mahalanobis): 0.01 is 0.14 σ, and the steps still to come
// (each ~10× smaller here) would not change the rays. Ceres' relative tolerance cannot say
// this: the cost grows with the number of observations (1e-10 of it took 2–3 more Jacobians).
class CostChangeTolerance : public ceres::IterationCallback {
 public:
  explicit CostChangeTolerance(double tolerance) : tolerance_(tolerance) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    if (s.iteration > 0 && s.step_is_successful && s.cost_change < tolerance_) {
      return ceres::SOLVER_TERMINATE_SUCCESSFULLY;
    }
    return ceres::SOLVER_CONTINUE;
  }

 private:
  double tolerance_;
};

}  // namespace

SolveOutcome solve(const FitInputs& in, FitProblem& built, FitState& state, double costTolerance) {
  const FitOptions& options = in.options;
  ceres::Solver::Options so;
  so.max_num_iterations = options.maxIterations;
  so.num_threads = options.threads;
  so.function_tolerance = 1e-10;
  so.parameter_tolerance = 1e-10;
  so.gradient_tolerance = 1e-14;
  so.logging_type = ceres::SILENT;
  if (built.withModules) {
    // Modules never share a residual, so they are eliminated first (bundle adjustment's
    // points); the reduced system over cameras and k is tiny and dense.
    so.linear_solver_type = ceres::DENSE_SCHUR;
    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    for (size_t m = 0; m < state.modules.size(); ++m) {
      if (in.observed[m]) ordering->AddElementToGroup(state.modules[m].data(), 0);
    }
    for (auto& cam : state.cameras) ordering->AddElementToGroup(cam.data(), 1);
    ordering->AddElementToGroup(&state.k, 1);
    so.linear_solver_ordering = ordering;
  } else {
    so.linear_solver_type = ceres::DENSE_QR;
  }
  ProgressCallback progress(options.onIteration);
  if (options.onIteration) so.callbacks.push_back(&progress);
  CostChangeTolerance tolerance(costTolerance);
  so.callbacks.push_back(&tolerance);
  StopCallback stop(options.stopRequested);
  if (options.stopRequested) so.callbacks.push_back(&stop);
  // The bounds on k make Ceres follow every trust-region step with a projected line search
  // that evaluates the full Jacobian a second time (half the solve time). The bounds are
  // still kept: Ceres clamps each step into them.
  so.max_num_line_search_step_size_iterations = 0;
  ceres::Solver::Summary summary;
  ceres::Solve(so, built.problem.get(), &summary);

  SolveOutcome outcome;
  outcome.iterations = static_cast<int>(summary.iterations.size());
  // Only StopCallback aborts (USER_FAILURE); the others continue or end successfully.
  outcome.stopped = summary.termination_type == ceres::USER_FAILURE && options.stopRequested;
  outcome.converged = summary.termination_type == ceres::CONVERGENCE ||
                      summary.termination_type == ceres::USER_SUCCESS;
  return outcome;
}

}  // namespace parallax::fit
