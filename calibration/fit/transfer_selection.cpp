#include "calibration/fit/transfer_selection.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "calibration/display/ray_error.h"
#include "calibration/fit/display_fit.h"

namespace parallax {
namespace {

constexpr double kClipSigmas = 5.0;

double clippedChi2(const std::vector<double>& residualsMm, double sigmaMm) {
  double sum = 0.0;
  for (double r : residualsMm) {
    const double z = std::min(std::abs(r) / sigmaMm, kClipSigmas);
    sum += z * z;
  }
  return sum;
}

}  // namespace

std::string TransferEvidence::describe() const {
  const char* a = transferName(assumed);
  const char* b = transferName(assumed == ScreenTransfer::kConical ? ScreenTransfer::kLinear
                                                                   : ScreenTransfer::kConical);
  std::string verdict;
  if (decided) {
    verdict = fmt::format("the screen follows the {} transfer", transferName(chosen));
  } else {
    verdict = fmt::format("undecided (|Δχ²| < {:.0f})", kDecisiveChi2);
  }
  return fmt::format(
      "transfer: {}; evidence Δχ² = χ²({}) − χ²({}) = {:+.1f} over {} stripe centres (common σ "
      "{:.3f} mm); the two fits' rays differ by up to {:.2f} mm on the observer line, {:.3f} "
      "module px",
      verdict, a, b, deltaChi2, stripes, commonSigmaMm, raysDifferMm, raysDifferPx);
}

FitResult selectTransfer(FitResult assumed, FitResult other, const GateLimits& limits) {
  TransferEvidence e;
  e.assumed = assumed.model.screen.transfer;
  e.stripes = static_cast<int>(assumed.stripeResidualsMm.size());
  const double sa = assumed.stripeSigmaMm, so = other.stripeSigmaMm;
  e.commonSigmaMm = std::max(1e-6, std::min(sa > 0 ? sa : so, so > 0 ? so : sa));
  e.deltaChi2 = clippedChi2(assumed.stripeResidualsMm, e.commonSigmaMm) -
                clippedChi2(other.stripeResidualsMm, e.commonSigmaMm);
  // Rays of the two fits, over the modules both estimated.
  if (assumed.model.modules.size() == other.model.modules.size() && !other.stopped) {
    const std::vector<RayErrorStats> diff = compareRays(assumed.model, other.model);
    for (size_t m = 0; m < diff.size(); ++m) {
      if (!assumed.modules[m].observed) continue;
      e.raysDifferMm = std::max(e.raysDifferMm, diff[m].maxObserverMm);
      e.raysDifferPx = std::max(e.raysDifferPx, diff[m].maxPx);
    }
  }
  const bool otherUsable = other.converged && !other.stopped;
  FitResult* kept = &assumed;
  if (e.deltaChi2 > kDecisiveChi2 && otherUsable) {
    e.decided = true;
    kept = &other;
  } else if (e.deltaChi2 < -kDecisiveChi2 || !otherUsable) {
    e.decided = otherUsable;
  }
  e.chosen = kept->model.screen.transfer;
  const int iterations = assumed.iterations + other.iterations;
  FitResult out = std::move(*kept);
  // The in-fit stripe test (FitOptions::transferMismatchRatio) is superseded by the comparison.
  out.transferMismatch = false;
  std::erase_if(out.notes, [](const std::string& n) {
    return n.rfind("the stripe centres disagree with the assumed", 0) == 0;
  });
  if (!e.decided && (e.raysDifferMm > limits.worstObserverMm || e.raysDifferPx > limits.worstPx)) {
    out.transferMismatch = true;
    out.notes.push_back(fmt::format(
        "the stripes cannot tell the linear from the conical transfer, and the choice moves rays "
        "by up to {:.1f} mm on the observer line ({:.2f} module px): refused",
        e.raysDifferMm, e.raysDifferPx));
  } else if (e.decided && e.chosen != e.assumed) {
    out.notes.push_back(fmt::format("the stripes reject the assumed {} transfer: installed as {}",
                                    transferName(e.assumed), transferName(e.chosen)));
  }
  out.transferEvidence = e;
  out.notes.push_back(e.describe());
  out.iterations = iterations;
  return out;
}

}  // namespace parallax
