#include "calibration/fit/fit_report.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "calibration/display/ray_error.h"

namespace parallax {
namespace {

std::string sd(double v, int precision) {
  if (!std::isfinite(v)) return "undet.";
  return fmt::format("{:.{}f}", v, precision);
}

}  // namespace

PredictedRays predictedRays(const FitResult& r) {
  PredictedRays p;
  double sumPx = 0.0, sumMm = 0.0;
  for (const ModuleGate& g : r.gate.modules) {
    if (g.held || g.predicted.samples == 0 || !g.predicted.bounded) continue;
    ++p.modules;
    sumPx += g.predicted.rmsPx * g.predicted.rmsPx;
    sumMm += g.predicted.rmsObserverMm * g.predicted.rmsObserverMm;
    p.worstPx = std::max(p.worstPx, g.predicted.worstPx);
    p.worstObserverMm = std::max(p.worstObserverMm, g.predicted.worstObserverMm);
    p.boundPx = std::max(p.boundPx, g.boundPx);
    p.boundObserverMm = std::max(p.boundObserverMm, g.boundObserverMm);
  }
  if (p.modules) {
    p.rmsPx = std::sqrt(sumPx / p.modules);
    p.rmsObserverMm = std::sqrt(sumMm / p.modules);
  }
  return p;
}

std::string formatTruthHeadline(const FitResult& r, const DisplayModel& truth,
                                const DisplayModel& nominal) {
  const std::vector<RayErrorStats> errors = compareRays(truth, r.model);
  RayErrorStats installed;
  for (const ModuleGate& g : r.gate.modules) {
    const bool heldNominal = std::find(r.gate.heldNominal.begin(), r.gate.heldNominal.end(),
                                       g.module) != r.gate.heldNominal.end();
    if (!heldNominal && r.modules[static_cast<size_t>(g.module)].observed)
      installed.merge(errors[static_cast<size_t>(g.module)]);
  }
  const PredictedRays p = predictedRays(r);
  const RayErrorStats before = totalRayError(compareRays(truth, nominal));
  return fmt::format(
      "against the ground truth (fitted modules): ray error {:.4f} module px RMS, {:.3f} worst "
      "(predicted σ {:.4f} RMS, {:.3f} worst); observer line {:.2f} mm RMS, {:.2f} worst "
      "(predicted σ {:.2f} RMS, {:.2f} worst); the nominal was {:.3f} px, {:.1f} mm RMS\n",
      installed.rmsPx, installed.maxPx, p.rmsPx, p.worstPx, installed.rmsObserverMm,
      installed.maxObserverMm, p.rmsObserverMm, p.worstObserverMm, before.rmsPx,
      before.rmsObserverMm);
}

std::string formatFitSummary(const FitResult& r) {
  const PredictedRays p = predictedRays(r);
  std::string out = fmt::format(
      "rays (predicted σ over {} modules): {:.4f} module px RMS, worst pixel {:.3f}; observer "
      "line {:.2f} mm RMS, worst {:.2f}\n",
      p.modules, p.rmsPx, p.worstPx, p.rmsObserverMm, p.worstObserverMm);
  out += fmt::format(
      "fit: {} iterations, {:.2f} s, {}; k = {:.6f} ± {:.6f} 1/m ({} transfer)\n"
      "noise: correspondences σ = {:.3f} module px ({:.3f} mm on the screen), stripes {:.3f} mm "
      "RMS, "
      "fiducials {:.3f} camera px RMS; {} outliers\n",
      r.iterations, r.solveSeconds, r.converged ? "converged" : "NOT converged",
      r.model.screen.curvature, r.curvatureStdDev, transferName(r.model.screen.transfer),
      r.correspondenceSigmaPx, r.correspondenceSigmaMm, r.stripeRmsMm, r.fiducialRmsPx, r.outliers);
  if (r.intrinsicsCarried)
    out += "σ include the camera intrinsics' uncertainty (their checkerboard covariance)\n";
  if (r.lensBlurSigmaPx && *r.lensBlurSigmaPx > 0.0)
    out += fmt::format(
        "correspondences corrected for the lens blur (σ {:.2f} camera px, camera.json)\n",
        *r.lensBlurSigmaPx);
  const auto& se = r.sharedErrors;
  if (se[3] > 0.0 || se[4] > 0.0 || se[5] > 0.0) {
    out += fmt::format(
        "errors shared by one module's decoded rows at one station (in σ, counted in the σ "
        "above): correspondences {:.2f}, {:.2f}; stripes {:.2f}\n",
        se[3], se[4], se[5]);
  }
  for (const Deficiency& d : r.deficiencies) out += "  " + d.describe() + "\n";
  for (const std::string& n : r.notes) out += "  note: " + n + "\n";
  for (const std::string& g : r.gate.describe()) out += "  gate: " + g + "\n";
  const GateLimits& limits = r.gate.limits;
  out += fmt::format(
      "gate: every module's {:.0f}σ worst ray error ≤ {:.2f} module px and ≤ {:.1f} mm on the "
      "observer line (largest: {:.3f} px, {:.2f} mm): ",
      limits.sigmas, limits.worstPx, limits.worstObserverMm, p.boundPx, p.boundObserverMm);
  out += r.passesQualityChecks() ? "passed\n" : "FAILED\n";
  return out;
}

std::string formatFitReport(const FitResult& r, const DisplayModel* truth) {
  std::vector<RayErrorStats> errors;
  if (truth) errors = compareRays(*truth, r.model);
  std::string out =
      "module  corr  strp  out  rms_px  strp_mm  sd_pos_mm(x,y,z)      sd_rot_deg(x,y,z)       "
      "sd_f_px  sd_c_px     cond";
  if (truth) out += "  | ray_px_rms  ray_px_max  screen_mm  observer_mm";
  out += "\n";
  for (const ModuleFit& m : r.modules) {
    if (!m.observed) {
      out += fmt::format("{:6d}  not seen: kept nominal\n", m.module);
      continue;
    }
    const auto& s = m.stdDev;
    out += fmt::format(
        "{:6d} {:5d} {:5d} {:4d}  {:6.3f}  {:7.3f}  {:>6} {:>6} {:>6}  {:>7} {:>7} {:>7}  {:>7}  "
        "{:>7}  {:>7.1e}",
        m.module, m.correspondences, m.stripes, m.outliers, m.rmsPx, m.stripeRmsMm, sd(s[3], 2),
        sd(s[4], 2), sd(s[5], 2), sd(s[0], 4), sd(s[1], 4), sd(s[2], 4),
        sd(std::max(s[6], s[7]), 2), sd(std::max(s[8], s[9]), 2),
        m.conditioning.reciprocalCondition);
    if (truth) {
      const RayErrorStats& e = errors[static_cast<size_t>(m.module)];
      out += fmt::format("  | {:10.4f}  {:10.3f}  {:9.3f}  {:11.2f}", e.rmsPx, e.maxPx,
                         e.rmsScreenMm, e.rmsObserverMm);
    }
    out += "\n";
  }
  out +=
      "camera  corr  fid  rms_px  fid_rms_px  centre (m)                    sd_centre_mm(x,y,z)\n";
  for (const CameraFit& c : r.cameras) {
    out += fmt::format(
        "{:6d} {:5d} {:4d}  {:6.3f}  {:10.3f}  ({:+.4f}, {:+.4f}, {:+.4f})  {:>6} {:>6} {:>6}\n",
        c.camera, c.correspondences, c.fiducials, c.rmsPx, c.fiducialRmsPx, c.pose.centre.x(),
        c.pose.centre.y(), c.pose.centre.z(), sd(c.stdDev[3], 2), sd(c.stdDev[4], 2),
        sd(c.stdDev[5], 2));
  }
  if (truth) {
    RayErrorStats total;
    for (size_t m = 0; m < errors.size(); ++m) {
      if (r.modules[m].observed) total.merge(errors[m]);
    }
    out += fmt::format(
        "against the ground truth (observed modules): ray error {:.4f} module px RMS, {:.3f} max; "
        "screen {:.3f} mm RMS, {:.3f} max; observer line {:.2f} mm RMS, {:.2f} max; k {:+.6f} "
        "(truth {:+.6f})\n",
        total.rmsPx, total.maxPx, total.rmsScreenMm, total.maxScreenMm, total.rmsObserverMm,
        total.maxObserverMm, r.model.screen.curvature, truth->screen.curvature);
  }
  return out;
}

}  // namespace parallax
