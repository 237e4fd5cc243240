#include "calibration/fit/calibration_gate.h"

#include <fmt/format.h>

#include <cmath>
#include <limits>

#include "calibration/fit/display_fit.h"
#include "common/input_error.h"

namespace parallax {

void GateLimits::validate() const {
  auto positive = [](double v, const char* name) {
    if (!(std::isfinite(v) && v > 0.0))
      throw InputError({"", name, 0}, fmt::format("must be > 0, got {}", v));
  };
  positive(worstPx, "gate_worst_px");
  positive(worstObserverMm, "gate_worst_observer_mm");
  positive(sigmas, "gate_sigmas");
}

int GateResult::failingModules() const {
  int n = 0;
  for (const ModuleGate& m : modules) n += m.passes ? 0 : 1;
  return n;
}

std::vector<std::string> GateResult::describe() const {
  std::vector<std::string> out;
  for (const std::string& r : reasons) out.push_back("the fit: " + r);
  for (const ModuleGate& m : modules) {
    if (!m.passes) out.push_back(fmt::format("module {}: {}", m.module, m.reason));
  }
  return out;
}

namespace {

ModuleGate judgeModule(const DisplayModel& fitted, const ModuleFit& fit, bool held, bool converged,
                       const GateLimits& limits, const RayUncertaintyOptions& grid) {
  ModuleGate g;
  g.module = fit.module;
  g.held = held;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  if (held) {
    // Not estimated: it keeps the calibration it had, which passed its own gate.
    g.passes = true;
    return g;
  }
  if (!fit.observed) {
    g.boundPx = g.boundObserverMm = kInf;
    g.reason = "no camera saw it: its rays are unknown";
    return g;
  }
  // Why its data may be thin: stations whose view of it decoded badly (a station that sees it
  // less steeply may serve it better).
  const std::string leftOut =
      fit.decodesLeftOut > 0
          ? fmt::format(
                "; {} station(s)' decodes of it left out (far more gross errors than "
                "the typical decode)",
                fit.decodesLeftOut)
          : "";
  if (fit.conditioning.state == Conditioning::kRankDeficient || fit.rayCovariance.size() == 0) {
    g.boundPx = g.boundObserverMm = kInf;
    g.predicted.bounded = false;
    g.reason = "rank deficient: the data cannot bound its rays" + leftOut;
    return g;
  }
  // One station's decode alone: whatever that decode shares across the module (a steep view's
  // bias, 0.03-0.07 px in the picture path) moves its 12 parameters and leaves no residual, so
  // no σ can hold it (2 stations from pictures: such modules 2-3× their σ, up to 33 px off).
  if (fit.stationsSeeing < 2) {
    g.boundPx = g.boundObserverMm = kInf;
    g.predicted.bounded = false;
    g.reason =
        "seen from one station only: its decode's own error cannot be told from its "
        "parameters (a station that sees it too would bound it)" +
        leftOut;
    return g;
  }
  g.predicted = predictRayUncertainty(fitted, fit.module, fit.rayCovariance, grid);
  if (!g.predicted.bounded || g.predicted.samples == 0) {
    g.boundPx = g.boundObserverMm = kInf;
    g.reason = g.predicted.bounded ? "none of its pixels reaches the observer line"
                                   : "its covariance is not finite: its rays cannot be bounded";
    return g;
  }
  // The covariance describes a minimum; short of one it bounds nothing, and a refused fit
  // should not still quote bounds (the sweeps' coverage leaves such fits out for the same
  // reason). The σ stay in the report, marked unbounded.
  if (!converged) {
    g.predicted.bounded = false;
    g.boundPx = g.boundObserverMm = kInf;
    g.reason = "the fit did not converge: its σ describe no minimum, so nothing bounds its rays";
    return g;
  }
  g.boundPx = limits.sigmas * g.predicted.worstPx;
  g.boundObserverMm = limits.sigmas * g.predicted.worstObserverMm;
  std::string why;
  if (!(g.boundPx <= limits.worstPx)) {
    why = fmt::format("predicted worst error {:.2f} module px > {:.2f} allowed", g.boundPx,
                      limits.worstPx);
  }
  if (!(g.boundObserverMm <= limits.worstObserverMm)) {
    why += fmt::format("{}predicted worst error {:.1f} mm on the observer line > {:.1f} allowed",
                       why.empty() ? "" : "; ", g.boundObserverMm, limits.worstObserverMm);
  }
  g.passes = why.empty();
  if (!g.passes) why += fmt::format(" ({:.0f}σ at its worst pixel)", limits.sigmas);
  g.reason = g.passes ? why : why + leftOut;
  return g;
}

}  // namespace

void applyGate(const DisplayModel& nominal, const GateLimits& limits,
               const RayUncertaintyOptions& grid, FitResult* result) {
  limits.validate();
  GateResult gate;
  gate.limits = limits;
  if (result->stopped) gate.reasons.push_back("stopped before it finished");
  if (!result->converged) gate.reasons.push_back("the solver did not converge");
  if (result->transferMismatch) gate.reasons.push_back("the screen transfer is not decided");
  if (result->cameraResponseUndecided) {
    gate.reasons.push_back(
        "the camera's response is not decided (camera.json gives none and the pictures cannot "
        "tell the camera's bend from the modules'): state response_gamma in camera.json");
  }
  for (const Deficiency& d : result->deficiencies) {
    if (d.module < 0 && d.state == Conditioning::kRankDeficient)
      gate.reasons.push_back("the cameras or the curvature are undetermined");
  }
  if (!std::isfinite(result->model.screen.curvature))
    gate.reasons.push_back("the curvature is not finite");
  std::vector<bool> held(result->modules.size(), false);
  for (int m : result->heldModules) held[static_cast<size_t>(m)] = true;
  for (size_t m = 0; m < result->modules.size(); ++m) {
    ModuleGate g =
        judgeModule(result->model, result->modules[m], held[m], result->converged, limits, grid);
    const OpticalModule& om = result->model.modules[m];
    if (g.passes && !(om.position.allFinite() && std::isfinite(om.fx) && std::isfinite(om.fy) &&
                      std::isfinite(om.cx) && std::isfinite(om.cy) && std::isfinite(om.k1) &&
                      std::isfinite(om.k2))) {
      g.passes = false;
      g.reason = "its fitted parameters are not finite";
    }
    result->modules[m].worstPixelStdDevPx = g.predicted.worstPx;
    gate.modules.push_back(g);
  }
  const int failing = gate.failingModules();
  const int count = static_cast<int>(gate.modules.size());
  if (!gate.reasons.empty() || failing == 0) {
    gate.passes = gate.reasons.empty();
  } else if (!limits.allowPartial) {
    gate.passes = false;
  } else if (failing == count) {
    gate.passes = false;
    gate.reasons.push_back("no module passes: --allow-partial has nothing to install");
  } else {
    gate.passes = true;
    std::string names;
    for (const ModuleGate& g : gate.modules) {
      if (g.passes) continue;
      gate.heldNominal.push_back(g.module);
      gate.heldEstimates.push_back(result->model.modules[static_cast<size_t>(g.module)]);
      result->model.modules[static_cast<size_t>(g.module)] =
          nominal.modules[static_cast<size_t>(g.module)];
      names += fmt::format("{}{}", names.empty() ? "" : ", ", g.module);
    }
    result->notes.push_back(fmt::format(
        "partial calibration (--allow-partial): {} of {} modules failed the gate and are held "
        "at their nominal calibration: {}",
        failing, count, names));
  }
  result->gate = std::move(gate);
}

}  // namespace parallax
