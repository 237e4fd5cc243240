// Calibration: ray error of the fitted display against solver iterations and the number of
// camera stations (capture count), on synthetic observations of a seeded ground truth of
// `demo` (calibration/simulation/synthetic_observations.h; bench/calibration_fit_bench.cpp has more
// axes).

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>

#include "calibration/display/display_presets.h"
#include "calibration/display/ray_error.h"
#include "calibration/fit/calibration_gate.h"
#include "calibration/fit/display_fit.h"
#include "calibration/simulation/ground_truth.h"
#include "calibration/simulation/synthetic_observations.h"
#include "common/progress_bar.h"
#include "daemon/report/report.h"

namespace parallax::report {
namespace {

struct FitRow {
  double fitSeconds = 0, solveSeconds = 0, cpuSeconds = 0;  // one fitDisplay call
  int iterations = 0;
  size_t correspondences = 0;
  RayErrorStats rays;
  bool passes = false;
  // The predicted σ against the true error, over the modules with a bounded prediction: how
  // many have their true worst ray within 3σ of their predicted worst (px and mm), and the
  // true RMS over the predicted RMS (1: the σ describe the error; above: optimistic).
  int judged = 0, covered = 0;
  double trueOverPredictedRms = 0;
  double predictedBoundPx = 0, trueWorstPx = 0;  // 3σ worst over modules, and the truth's
};

FitRow fitOnce(const DisplayModel& nominal, const DisplayModel& truth, const SyntheticOptions& sim,
               const FitOptions& fit) {
  FitRow row;
  const SyntheticCalibration data = simulateObservations(truth, sim);
  // Wall and CPU time of the same call; Ceres' solve is a part of it (the rest: diagnostics).
  const std::clock_t c0 = std::clock();
  const auto t0 = std::chrono::steady_clock::now();
  const FitResult result = fitDisplay(nominal, data.observations, fit);
  row.fitSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  row.cpuSeconds = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
  row.solveSeconds = std::min(result.solveSeconds, row.fitSeconds);
  row.iterations = result.iterations;
  row.correspondences = data.observations.correspondences.size();
  const std::vector<RayErrorStats> perModule = compareRays(truth, result.model, {16});
  row.rays = totalRayError(perModule);
  row.passes = result.passesQualityChecks();
  double trueSq = 0, predictedSq = 0;
  for (const ModuleGate& g : result.gate.modules) {
    const RayErrorStats& e = perModule[static_cast<size_t>(g.module)];
    if (!g.predicted.bounded || g.predicted.samples == 0 || g.held || e.samples == 0) continue;
    const double k = result.gate.limits.sigmas;
    ++row.judged;
    row.covered +=
        e.maxPx <= k * g.predicted.worstPx && e.maxObserverMm <= k * g.predicted.worstObserverMm;
    trueSq += e.rmsPx * e.rmsPx, predictedSq += g.predicted.rmsPx * g.predicted.rmsPx;
    row.predictedBoundPx = std::max(row.predictedBoundPx, k * g.predicted.worstPx);
    row.trueWorstPx = std::max(row.trueWorstPx, e.maxPx);
  }
  row.trueOverPredictedRms = predictedSq > 0 ? std::sqrt(trueSq / predictedSq) : 0.0;
  return row;
}

std::vector<std::string> cells(const std::string& value, const FitRow& r) {
  return {value,
          std::to_string(r.correspondences),
          fixed(r.fitSeconds, 2),
          fixed(r.solveSeconds, 2),
          fixed(r.cpuSeconds, 2),
          std::to_string(r.iterations),
          general(r.rays.rmsPx),
          general(r.rays.maxPx),
          general(r.rays.rmsScreenMm),
          general(r.rays.rmsObserverMm),
          general(r.predictedBoundPx),
          r.judged ? fmt::format("{} of {}", r.covered, r.judged) : "none bounded",
          general(r.trueOverPredictedRms),
          r.passes ? "pass" : "refused"};
}

const std::vector<std::string> kHeader = {"",
                                          "correspondences",
                                          "fit wall s",
                                          partOf("solve wall s", "fit wall s"),
                                          "fit CPU s (all threads)",
                                          "iterations",
                                          "ray px RMS",
                                          "ray px max",
                                          "screen mm RMS",
                                          "observer mm RMS",
                                          "predicted 3σ worst px",
                                          "modules within 3σ",
                                          "true / predicted RMS px",
                                          "gate"};
const char* const kRule =
    "one fit a row (seconds each, not repeated): wall clock and process CPU time of the same "
    "`fitDisplay` call, Ceres' solve a part of it";

}  // namespace

void writeCalibrationSection(Report& report) {
  const bool quick = report.options().quick;
  NominalDisplayOptions nominalOptions;
  nominalOptions.preset = "demo";
  const DisplayModel nominal = makeNominalDisplay(nominalOptions);
  GroundTruthOptions truthOptions;
  truthOptions.seed = 2026;
  const DisplayModel truth = makeGroundTruth(nominal, truthOptions);
  SyntheticOptions base;
  base.seed = 7;
  base.rig.spanM = 3.2;
  base.noisePx = 0.3;
  base.rowStepPx = quick ? 48.0 : 16.0;
  FitOptions fit;
  fit.threads = 2;
  const std::vector<int> iterations =
      quick ? std::vector<int>{1, 3, 100} : std::vector<int>{1, 2, 3, 5, 10, 100};
  const std::vector<int> stations = quick ? std::vector<int>{3, 5} : std::vector<int>{2, 3, 5, 9};
  ProgressBar progress("calibration",
                       static_cast<std::int64_t>(iterations.size() + stations.size()));

  Table byIterations{kHeader, {}, kRule};
  byIterations.header[0] = "max iterations per solve";
  PlotSeries iterationCurve{"ray px RMS", {}, {}, true};
  for (int n : iterations) {
    FitOptions f = fit;
    f.maxIterations = n;
    const FitRow r = fitOnce(nominal, truth, base, f);
    byIterations.rows.push_back(cells(std::to_string(n), r));
    iterationCurve.add(r.fitSeconds, r.rays.rmsPx, fmt::format("{} it.", n));
    progress.advance();
  }
  Table byStations{kHeader, {}, kRule};
  byStations.header[0] = "camera stations";
  PlotSeries stationCurve{"ray px RMS", {}, {}, true};
  for (int n : stations) {
    SyntheticOptions s = base;
    s.rig.stations = n;
    const FitRow r = fitOnce(nominal, truth, s, fit);
    byStations.rows.push_back(cells(std::to_string(n), r));
    stationCurve.add(n, r.rays.rmsPx);
    progress.advance();
  }
  progress.finish();
  report.heading("Calibration: error against solver time and capture count");
  report.text(fmt::format(
      "`fitDisplay` (Ceres, 2 threads) on synthetic observations of a seeded ground truth of "
      "`demo` ({} modules, "
      "seed 2026): {} camera stations over 3.2 m unless varied, 0.3 px camera noise, rows every "
      "{:.0f} px. Ray "
      "error of the fitted model against the truth on a 16 px grid of every module "
      "(calibration/display/ray_error.h). "
      "The gate is the quality check that decides whether `parallax calibrate` installs a fit. "
      "More axes: "
      "`build/bench/calibration_fit_bench`. Coverage: the fit's predicted σ (carried to every "
      "module's rays, calibration/fit/ray_uncertainty.h) against the true error — `modules within "
      "3σ` counts the modules whose true worst ray (px and mm) is within 3σ of their predicted "
      "worst, `true / predicted RMS px` is 1 when the σ describe the error and above 1 when they "
      "are optimistic. Capture time grows with the stations: each takes the same pattern "
      "pictures (66 a station on `demo` in the README's webcam section, about 60 ms each "
      "through the simulator's link camera).",
      nominal.modules.size(), base.rig.stations, base.rowStepPx));
  report.table("calibration_iterations", byIterations);
  report.table("calibration_stations", byStations);
  report.figure("calibration_iterations",
                {.title = "calibration: ray error against solver time (max iterations varied)",
                 .xLabel = "fit wall s",
                 .yLabel = "ray error RMS (module px)",
                 .logX = true,
                 .logY = true,
                 .series = {iterationCurve}});
  report.figure("calibration_stations", {.title = "calibration: ray error against camera stations",
                                         .xLabel = "camera stations",
                                         .yLabel = "ray error RMS (module px)",
                                         .logY = true,
                                         .integerX = true,
                                         .series = {stationCurve}});
}

}  // namespace parallax::report
