// Calibration: capture time against accuracy (issue 25 item 5). Unlike the stations table of
// report_calibration.cpp (synthetic observations, no pictures), this runs the picture path on a
// small seeded display: the simulated camera's pictures of the patterns (renderSession), the
// decoder (decodeCaptures), the fit (fitDisplay), then the fitted model's true ray error against
// the ground truth beside the fit's own predicted σ.

#include <fmt/format.h>

#include <algorithm>
#include <chrono>

#include "calibration/capture/calibration_captures.h"
#include "calibration/display/display_presets.h"
#include "calibration/display/ray_error.h"
#include "calibration/fit/calibration_gate.h"
#include "calibration/fit/display_fit.h"
#include "calibration/simulation/ground_truth.h"
#include "calibration/simulation/simulated_session.h"
#include "common/progress_bar.h"
#include "daemon/report/report.h"

namespace parallax::report {
namespace {

// Small enough for the whole section to take seconds a row in --quick: `demo`'s screen and
// module row with 8 modules of 256x192 and a 320x180 camera.
constexpr int kModules = 8, kModuleWidth = 256, kModuleHeight = 192;
constexpr int kCameraWidth = 640, kCameraHeight = 360;
constexpr double kCameraFocalPx = 700.0, kSpanM = 4.0;
constexpr int kPixelStep = 4;
// The link camera's pace on demo from the README (issue 19's closing figures): 390 pictures in
// 26.7 s through `parallax calibrate --link` against parallax-simhw.
constexpr double kLinkMsPerPicture = 26.7e3 / 390.0;

double secondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

struct CaptureRow {
  int stations = 0, pictures = 0;
  double captureSeconds = 0, decodeSeconds = 0, fitSeconds = 0;
  RayErrorStats rays;
  // The largest 3σ worst ray over the modules with a bounded σ (module px, observer-line mm).
  double predictedBoundPx = 0, predictedBoundMm = 0;
  int bounded = 0;
  bool passes = false;
  double total() const { return captureSeconds + decodeSeconds + fitSeconds; }
};

CaptureRow runSession(const DisplayModel& nominal, const DisplayModel& truth, int stations) {
  CaptureRow row;
  row.stations = stations;
  CameraRigOptions rig;
  rig.stations = stations;
  rig.spanM = kSpanM;
  rig.intrinsics = CameraIntrinsics::centred(kCameraWidth, kCameraHeight, kCameraFocalPx, -0.04);
  const SimulatedRig camera = makeSimulatedRig(truth, rig, 32);

  auto t0 = std::chrono::steady_clock::now();
  const CalibrationCaptures captures = renderSession(truth, camera.truth, camera.metadata, {});
  row.captureSeconds = secondsSince(t0);
  for (const StationCaptures& s : captures.stations)
    row.pictures += static_cast<int>(s.columnFrames.size() + s.rowFrames.size());

  CaptureDecoderOptions decoder;
  decoder.pixelStep = kPixelStep;
  t0 = std::chrono::steady_clock::now();
  const CalibrationObservations observations = decodeCaptures(captures, nominal, decoder);
  row.decodeSeconds = secondsSince(t0);

  FitOptions fit;
  fit.threads = 2;
  t0 = std::chrono::steady_clock::now();
  const FitResult result = fitDisplay(nominal, observations, fit);
  row.fitSeconds = secondsSince(t0);
  row.passes = result.passesQualityChecks();

  row.rays = totalRayError(compareRays(truth, result.model, {16}));
  for (const ModuleGate& g : result.gate.modules) {
    if (!g.predicted.bounded || g.predicted.samples == 0 || g.held) continue;
    ++row.bounded;
    const double k = result.gate.limits.sigmas;
    row.predictedBoundPx = std::max(row.predictedBoundPx, k * g.predicted.worstPx);
    row.predictedBoundMm = std::max(row.predictedBoundMm, k * g.predicted.worstObserverMm);
  }
  return row;
}

}  // namespace

void writeCaptureSection(Report& report) {
  const bool quick = report.options().quick;
  NominalDisplayOptions nominalOptions;
  nominalOptions.preset = "demo";
  nominalOptions.modules = kModules;
  nominalOptions.width = kModuleWidth;
  nominalOptions.height = kModuleHeight;
  const DisplayModel nominal = makeNominalDisplay(nominalOptions);
  GroundTruthOptions truthOptions;
  truthOptions.seed = 2026;
  const DisplayModel truth = makeGroundTruth(nominal, truthOptions);
  const std::vector<int> stations = quick ? std::vector<int>{3, 5} : std::vector<int>{2, 3, 5, 9};
  ProgressBar progress("calibration capture", static_cast<std::int64_t>(stations.size()));

  const std::string total = "total s";
  Table table{{"stations", "pictures", partOf("capture s", total), partOf("decode s", total),
               partOf("fit s", total), total, "true px RMS", "true px worst", "observer mm RMS",
               "observer mm worst", "predicted 3σ worst px", "predicted 3σ worst mm", "gate"},
              {},
              "one session a row (seconds each, not repeated: a session is seconds to a minute, "
              "and its parts are timed within the same run, so they add up to the total): wall "
              "clock of renderSession, decodeCaptures and fitDisplay"};
  PlotSeries curve{"true px RMS", {}, {}, true};
  for (int n : stations) {
    const CaptureRow r = runSession(nominal, truth, n);
    table.rows.push_back(
        {std::to_string(n), std::to_string(r.pictures), fixed(r.captureSeconds, 2),
         fixed(r.decodeSeconds, 2), fixed(r.fitSeconds, 2), fixed(r.total(), 2),
         general(r.rays.rmsPx), general(r.rays.maxPx), general(r.rays.rmsObserverMm),
         general(r.rays.maxObserverMm), r.bounded ? general(r.predictedBoundPx) : "none bounded",
         r.bounded ? general(r.predictedBoundMm) : "none bounded", r.passes ? "pass" : "refused"});
    curve.add(r.total(), r.rays.rmsPx, fmt::format("{} stations", n));
    progress.advance();
  }
  progress.finish();

  report.heading("Calibration: capture time against accuracy");
  report.text(fmt::format(
      "The picture path end to end on a small seeded display (`{}`: `demo`'s screen and module "
      "row with {} modules of {}x{}, ground truth seed 2026), photographed by the simulated "
      "camera ({}x{}, f {:.0f} px, known intrinsics) from stations spread over {:.1f} m: "
      "`renderSession` takes the pattern pictures, `decodeCaptures` decodes them (every {} "
      "camera px), `fitDisplay` (Ceres, 2 threads) fits the display; the fitted model's ray "
      "error against the truth on a 16 px grid of every module (module px, and mm on the "
      "observer line), beside the fit's predicted 3σ worst ray (the largest over its modules, px "
      "and mm). "
      "*Capture s* here is the simulator rendering the pictures on this machine's cores, not a "
      "real camera's exposure and settle time: through the link (`parallax calibrate --link` "
      "against parallax-simhw, README's webcam section) a picture takes about {:.0f} ms, so a "
      "real session's capture is the pictures times that.",
      nominal.name, kModules, kModuleWidth, kModuleHeight, kCameraWidth, kCameraHeight,
      kCameraFocalPx, kSpanM, kPixelStep, kLinkMsPerPicture));
  report.table("calibration_capture", table);
  report.figure("calibration_capture",
                {.title = "calibration: true ray error against session time (stations varied)",
                 .xLabel = "capture + decode + fit s",
                 .yLabel = "true ray error RMS (module px)",
                 .logY = true,
                 .series = {curve}});
}

}  // namespace parallax::report
