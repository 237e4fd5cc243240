// Calibration: ray error of the fitted display against solver iterations and the number of
// camera stations (capture count), on synthetic observations of a seeded ground truth of
// `demo` (calibration/simulation/synthetic_observations.h; bench/calibration_fit_bench.cpp has more
// axes).

#include <fmt/format.h>

#include <chrono>
#include <ctime>

#include "calibration/display/display_presets.h"
#include "calibration/display/ray_error.h"
#include "calibration/fit/display_fit.h"
#include "calibration/simulation/ground_truth.h"
#include "calibration/simulation/synthetic_observations.h"
#include "common/progress_bar.h"
#include "daemon/report/report.h"

namespace parallax::report {
namespace {

struct FitRow {
  double fitSeconds = 0, cpuSeconds = 0;
  int iterations = 0;
  size_t correspondences = 0;
  RayErrorStats rays;
  bool passes = false;
};

FitRow fitOnce(const DisplayModel& nominal, const DisplayModel& truth, const SyntheticOptions& sim,
               const FitOptions& fit) {
  FitRow row;
  const SyntheticCalibration data = simulateObservations(truth, sim);
  const std::clock_t c0 = std::clock();
  const FitResult result = fitDisplay(nominal, data.observations, fit);
  row.cpuSeconds = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
  row.fitSeconds = result.solveSeconds;
  row.iterations = result.iterations;
  row.correspondences = data.observations.correspondences.size();
  row.rays = totalRayError(compareRays(truth, result.model, {16}));
  row.passes = result.passesQualityChecks();
  return row;
}

std::vector<std::string> cells(const std::string& value, const FitRow& r) {
  return {value,
          std::to_string(r.correspondences),
          fixed(r.fitSeconds, 2),
          fixed(r.cpuSeconds, 2),
          std::to_string(r.iterations),
          general(r.rays.rmsPx),
          general(r.rays.maxPx),
          general(r.rays.rmsScreenMm),
          general(r.rays.rmsObserverMm),
          r.passes ? "pass" : "refused"};
}

const std::vector<std::string> kHeader = {
    "",           "correspondences", "fit wall s",    "fit CPU s",       "iterations",
    "ray px RMS", "ray px max",      "screen mm RMS", "observer mm RMS", "gate"};

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

  Table byIterations{kHeader, {}};
  byIterations.header[0] = "max iterations per solve";
  PlotSeries iterationCurve{"ray px RMS", {}, {}, true};
  for (int n : iterations) {
    FitOptions f = fit;
    f.maxIterations = n;
    const FitRow r = fitOnce(nominal, truth, base, f);
    byIterations.rows.push_back(cells(std::to_string(n), r));
    iterationCurve.x.push_back(r.fitSeconds);
    iterationCurve.y.push_back(r.rays.rmsPx);
    progress.advance();
  }
  Table byStations{kHeader, {}};
  byStations.header[0] = "camera stations";
  PlotSeries stationCurve{"ray px RMS", {}, {}, true};
  for (int n : stations) {
    SyntheticOptions s = base;
    s.rig.stations = n;
    const FitRow r = fitOnce(nominal, truth, s, fit);
    byStations.rows.push_back(cells(std::to_string(n), r));
    stationCurve.x.push_back(n);
    stationCurve.y.push_back(r.rays.rmsPx);
    progress.advance();
  }
  progress.finish();
  report.md() << fmt::format(
      "\n## Calibration: error against solver time and capture count\n\n"
      "`fitDisplay` (Ceres, 2 threads) on synthetic observations of a seeded ground truth of "
      "`demo` ({} modules, "
      "seed 2026): {} camera stations over 3.2 m unless varied, 0.3 px camera noise, rows every "
      "{:.0f} px. Ray "
      "error of the fitted model against the truth on a 16 px grid of every module "
      "(calibration/display/ray_error.h). "
      "The gate is the quality check that decides whether `parallax calibrate` installs a fit. "
      "More axes: "
      "`build/bench/calibration_fit_bench`.\n",
      nominal.modules.size(), base.rig.stations, base.rowStepPx);
  report.table("calibration_iterations", byIterations);
  report.table("calibration_stations", byStations);
  SvgPlot a;
  a.title = "calibration: ray error against solver time (max iterations varied)";
  a.xLabel = "fit wall s";
  a.yLabel = "ray error RMS (module px)";
  a.logY = true;
  a.series = {iterationCurve};
  report.figure("calibration_iterations", a);
  SvgPlot b;
  b.title = "calibration: ray error against camera stations";
  b.xLabel = "camera stations";
  b.yLabel = "ray error RMS (module px)";
  b.logY = true;
  b.series = {stationCurve};
  report.figure("calibration_stations", b);
}

}  // namespace parallax::report
