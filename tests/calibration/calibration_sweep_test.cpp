// The seed sweep of issue 17: synthetic calibrations over the setups a user may try (stations,
// camera noise, transfers and their mismatches, observer line distance, station span, unseen
// modules, 16 and 72 modules), each on many seeds. For every run, either the gate refuses with
// a reason, or the installed model's true worst ray error is within the gate's limits; and over
// the sweep the predicted σ describes the true error (coverage of the 3σ bound, and the ratio of
// true to predicted RMS). Prints the table for the closing note ("SWEEP | ...").
//
// CalibrationSweep.Fast runs every setup on a few seeds (the regular suite); the full sweep,
// 20 seeds per setup, is CalibrationSweep.Slow (ctest label `slow`). The seeds are consecutive
// from a fixed start: nothing is chosen per seed.

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "calibration/display/display_presets.h"
#include "calibration/display/ray_error.h"
#include "calibration/fit/display_fit.h"
#include "calibration/fit/prediction_coverage.h"
#include "calibration/simulation/ground_truth.h"
#include "calibration/simulation/sweep_setups.h"
#include "calibration/simulation/synthetic_observations.h"

namespace parallax {
namespace {

std::vector<SweepSetup> setups() { return sweepSetups(); }

// How well the predicted σ describes the true error, over a set of modules.
using Accuracy = PredictionCoverage;

struct Tally {
  int runs = 0, accepted = 0, violations = 0;
  double trueWorstPx = 0.0, trueWorstMm = 0.0;  // over accepted runs
  double boundPx = 0.0, boundMm = 0.0;          // the gate's predicted worst, accepted runs
  Accuracy installed;  // the modules of accepted runs: what a user gets, σ in the headline
  Accuracy judged;     // every module with a bounded prediction, refused runs included
  std::vector<std::string> refusals;

  void add(const Tally& o) {
    runs += o.runs;
    accepted += o.accepted;
    violations += o.violations;
    trueWorstPx = std::max(trueWorstPx, o.trueWorstPx);
    trueWorstMm = std::max(trueWorstMm, o.trueWorstMm);
    boundPx = std::max(boundPx, o.boundPx);
    boundMm = std::max(boundMm, o.boundMm);
    installed.add(o.installed);
    judged.add(o.judged);
    refusals.insert(refusals.end(), o.refusals.begin(), o.refusals.end());
  }
};

Tally runOne(const SweepSetup& s, std::uint64_t seed) {
  const DisplayModel nominal = sweepNominal(s);
  GroundTruthOptions gt;
  gt.seed = seed;
  gt.transfer = s.truth;
  const DisplayModel truth = makeGroundTruth(nominal, gt);
  SyntheticOptions sim;
  sim.seed = seed * 7919 + 1;
  sim.noisePx = s.noisePx;
  sim.rig.stations = s.stations;
  sim.rig.spanM = s.spanM;
  sim.hiddenModules = s.unseen;
  if (s.modules != 16) sim.rowStepPx = 8;
  const SyntheticCalibration data = simulateObservations(truth, sim);
  FitOptions options;
  const FitResult fit = fitDisplay(nominal, data.observations, options);
  const std::vector<RayErrorStats> rays = compareRays(truth, fit.model);

  Tally t;
  t.runs = 1;
  const bool accepted = fit.passesQualityChecks();
  t.accepted = accepted ? 1 : 0;
  if (!accepted) {
    const std::vector<std::string> why = fit.gate.describe();
    EXPECT_FALSE(why.empty()) << s.name << " seed " << seed << ": refused without a reason";
    t.refusals.push_back(why.empty() ? "(no reason)" : why.front());
  }
  for (const ModuleGate& g : fit.gate.modules) {
    const RayErrorStats& e = rays[static_cast<size_t>(g.module)];
    const bool heldNominal =
        std::count(fit.gate.heldNominal.begin(), fit.gate.heldNominal.end(), g.module) > 0;
    if (accepted && !heldNominal) {
      t.trueWorstPx = std::max(t.trueWorstPx, e.maxPx);
      t.trueWorstMm = std::max(t.trueWorstMm, e.maxObserverMm);
      t.boundPx = std::max(t.boundPx, g.boundPx);
      t.boundMm = std::max(t.boundMm, g.boundObserverMm);
      if (e.maxPx > options.gate.worstPx || e.maxObserverMm > options.gate.worstObserverMm) {
        t.violations = 1;
        ADD_FAILURE() << fmt::format(
            "{} seed {}: installed module {} is {:.3f} px / {:.2f} mm off at its worst, beyond "
            "the gate's {:.2f} px / {:.1f} mm (predicted {:.3f} px / {:.2f} mm)",
            s.name, seed, g.module, e.maxPx, e.maxObserverMm, options.gate.worstPx,
            options.gate.worstObserverMm, g.boundPx, g.boundObserverMm);
      }
    }
    // Coverage: every module with a bounded prediction, accepted or not, in fits that
    // finished with a decided transfer (the prediction describes noise, not a wrong model).
    if (!fit.gate.reasons.empty() || !g.predicted.bounded || g.predicted.samples == 0 || g.held ||
        e.samples == 0)
      continue;
    const double k = options.gate.sigmas;
    if (std::getenv("PARALLAX_SWEEP_VERBOSE"))
      std::printf(
          "  %s seed %d module %2d: true max %.3f px %.2f mm rms %.3f px %.2f mm | "
          "σ worst %.3f px %.2f mm rms %.3f px %.2f mm\n",
          s.name.c_str(), static_cast<int>(seed), g.module, e.maxPx, e.maxObserverMm, e.rmsPx,
          e.rmsObserverMm, g.predicted.worstPx, g.predicted.worstObserverMm, g.predicted.rmsPx,
          g.predicted.rmsObserverMm);
    const Accuracy one = Accuracy::ofModule(g, e, k);
    t.judged.add(one);
    if (accepted && !heldNominal) t.installed.add(one);
  }
  return t;
}

void row(const char* name, const Tally& t) {
  std::printf(
      "SWEEP | %-30s | %4d | %8d | %7d | %7.3f / %7.2f | %7.3f / %7.2f | %5.1f%% of %d, "
      "%.2f, %.2f | %5.1f%% of %d, %.2f, %.2f\n",
      name, t.runs, t.accepted, t.runs - t.accepted, t.trueWorstPx, t.trueWorstMm, t.boundPx,
      t.boundMm, 100.0 * t.installed.coverage(), t.installed.modules, t.installed.ratioPx(),
      t.installed.ratioMm(), 100.0 * t.judged.coverage(), t.judged.modules, t.judged.ratioPx(),
      t.judged.ratioMm());
}

void sweep(int seeds, const char* label) {
  Tally all;
  std::printf(
      "SWEEP | %-30s | runs | accepted | refused | true worst px / mm (accepted) | "
      "predicted 3σ worst px / mm (accepted) | installed modules: within 3σ, true/pred RMS px, "
      "mm | all judged modules: within 3σ, true/pred RMS px, mm\n",
      label);
  for (const SweepSetup& s : setups()) {
    Tally t;
    for (int i = 0; i < seeds; ++i) t.add(runOne(s, 1000 + static_cast<std::uint64_t>(i)));
    row(s.name.c_str(), t);
    if (!t.refusals.empty())
      std::printf("SWEEP |   first refusal: %s\n", t.refusals.front().c_str());
    std::fflush(stdout);
    all.add(t);
  }
  row("all", all);
  EXPECT_EQ(all.violations, 0) << "installed calibrations beyond the gate's limits";
  // The σ shown for installed calibrations describes their error.
  EXPECT_GE(all.installed.coverage(), 0.95);
  EXPECT_GE(all.installed.ratioPx(), 0.7);
  EXPECT_LE(all.installed.ratioPx(), 1.5);
  EXPECT_GE(all.installed.ratioMm(), 0.7);
  EXPECT_LE(all.installed.ratioMm(), 1.5);
}

TEST(CalibrationSweep, Fast) { sweep(2, "fast: 2 seeds per setup"); }

TEST(CalibrationSweep, Slow) { sweep(20, "slow: 20 seeds per setup"); }

// One setup by name, for looking into it: PARALLAX_SWEEP_SETUP="3 stations" PARALLAX_SWEEP_SEEDS=5.
TEST(CalibrationSweep, One) {
  const char* name = std::getenv("PARALLAX_SWEEP_SETUP");
  if (!name) GTEST_SKIP() << "set PARALLAX_SWEEP_SETUP";
  const char* seeds = std::getenv("PARALLAX_SWEEP_SEEDS");
  for (const SweepSetup& s : setups()) {
    if (s.name != name) continue;
    Tally t;
    for (int i = 0; i < (seeds ? std::atoi(seeds) : 2); ++i)
      t.add(runOne(s, 1000 + static_cast<std::uint64_t>(i)));
    row(name, t);
    for (const std::string& r : t.refusals) std::printf("  refused: %s\n", r.c_str());
  }
}

}  // namespace
}  // namespace parallax
