// Photometric calibration: residual non-uniformity against capture count (flat-field levels
// per channel) and gain-map resolution, with the capture's pictures and time, on the simulated
// `demo` display with a seeded photometric truth (calibration/simulation/
// simulated_photometric_rig.h); and what a viewer at the centre sees before and after.

#include <fmt/format.h>

#include <chrono>

#include "calibration/display/display_presets.h"
#include "calibration/photometry/photometric_fit.h"
#include "calibration/simulation/simulated_photometric_rig.h"
#include "common/progress_bar.h"
#include "daemon/report/report.h"
#include "tracer/module_encoder.h"
#include "tracer/observer_view.h"
#include "tracer/viewer_uniformity.h"

namespace parallax::report {
namespace {

Frame frameOf(const cv::Mat& light) {
  Frame f(light.cols, light.rows);
  for (int y = 0; y < light.rows; ++y)
    for (int x = 0; x < light.cols; ++x) {
      const cv::Vec3f v = light.at<cv::Vec3f>(y, x);
      f.at(x, y) = Rgb(v[0], v[1], v[2]);
    }
  return f;
}

// What every module emits for `content` (the same on every module): through the correction,
// or (correction null) through the plain sRGB encode.
std::vector<Frame> emitted(const SimulatedPhotometricRig& rig, const Frame& content,
                           const DisplayColourCorrection* correction) {
  std::vector<Frame> out;
  for (size_t i = 0; i < rig.geometry().modules.size(); ++i) {
    const std::vector<std::uint8_t> bytes =
        correction
            ? ModuleEncoder(correction->modules[i], content.width, content.height).encode(content)
            : content.toSrgb8();
    out.push_back(frameOf(rig.photometry().emittedLight(static_cast<int>(i), content.width,
                                                        content.height, bytes.data())));
  }
  return out;
}

// Colour bars above a grey ramp, in the target space.
Frame testCard(int width, int height) {
  static const Rgb kBars[8] = {{1, 1, 1}, {1, 1, 0}, {0, 1, 1}, {0, 1, 0},
                               {1, 0, 1}, {1, 0, 0}, {0, 0, 1}, {0, 0, 0}};
  Frame f(width, height);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const float ramp = static_cast<float>(x) / static_cast<float>(width - 1);
      f.at(x, y) =
          y < height / 2 ? Rgb(kBars[std::min(7, 8 * x / width)] * 0.75f) : Rgb(ramp, ramp, ramp);
    }
  return f;
}

struct Row {
  int pictures = 0;
  double captureSeconds = 0, fitSeconds = 0;
  ViewerUniformity seen;
};

}  // namespace

void writePhotometrySection(Report& report) {
  const bool quick = report.options().quick;
  SimulatedPhotometricRig rig(resolveDisplay("demo"), 7, PhotometricTruthOptions{});
  const std::vector<std::vector<int>> levelSets =
      quick ? std::vector<std::vector<int>>{{255}, {64, 255}}
            : std::vector<std::vector<int>>{
                  {255}, {64, 255}, {32, 96, 160, 255}, {16, 40, 80, 128, 180, 255}};
  const std::vector<int> grids = quick ? std::vector<int>{4, 16} : std::vector<int>{2, 4, 8, 16};
  std::vector<double> viewers;
  for (int k = 0; k <= 6; ++k) viewers.push_back(-0.6 + 0.2 * k);
  const OpticalModule& module = rig.geometry().modules.front();
  Frame grey(module.width, module.height);
  for (Rgb& p : grey.pixels) p = Rgb(0.5f, 0.5f, 0.5f);
  ProgressBar progress("photometry", static_cast<std::int64_t>(levelSets.size() + grids.size()));

  auto measure = [&](const FlatFieldCaptures& captures, const PhotometricFitOptions& fit) {
    Row row;
    row.pictures = captures.pictures;
    row.captureSeconds = captures.captureSeconds;
    const auto t0 = std::chrono::steady_clock::now();
    const PhotometricCalibration cal = fitPhotometry(captures, fit);
    row.fitSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const ColourTarget& t = cal.correction.target;
    row.seen = measureViewerUniformity(rig.geometry(), emitted(rig, grey, &cal.correction),
                                       t.black + t.primaries * Eigen::Vector3d::Constant(0.5),
                                       t.black + t.primaries * Eigen::Vector3d::Ones(), viewers);
    return std::pair{row, cal};
  };
  auto cells = [](const std::string& first, const Row& r) {
    return std::vector<std::string>{first,
                                    std::to_string(r.pictures),
                                    fixed(r.captureSeconds, 1),
                                    fixed(r.fitSeconds, 2),
                                    fixed(100.0 * r.seen.nonUniformity, 1),
                                    fixed(r.seen.meanDeltaE, 2),
                                    fixed(r.seen.worstDeltaE, 2)};
  };
  const std::vector<std::string> header = {
      "", "pictures", "capture s", "fit s", "non-uniformity %", "ΔE00 mean", "ΔE00 worst"};
  const char* const rule =
      "one capture and one fit a row (not repeated): the simulated camera's rendering time, and "
      "the wall clock of `fitPhotometry`";
  Table byLevels{header, {}, rule};
  byLevels.header[0] = "levels per channel";
  PlotSeries levelCurve{"non-uniformity %", {}, {}, true};
  FlatFieldCaptures richest;
  for (const std::vector<int>& levels : levelSets) {
    FlatFieldOptions options;
    options.levels = levels;
    FlatFieldCaptures captures = rig.capture(options);
    const Row row = measure(captures, PhotometricFitOptions{}).first;
    byLevels.rows.push_back(
        cells(fmt::format("{} ({})", levels.size(), fmt::join(levels, " ")), row));
    levelCurve.add(row.captureSeconds, 100.0 * row.seen.nonUniformity,
                   fmt::format("{} level{}", levels.size(), levels.size() == 1 ? "" : "s"));
    richest = std::move(captures);
    progress.advance();
  }
  Table byGrid{header, {}, rule};
  byGrid.header[0] = "gain map nodes";
  PlotSeries gridCurve{"non-uniformity %", {}, {}, true};
  PhotometricCalibration finest;
  for (int g : grids) {
    PhotometricFitOptions fit;
    fit.gainGridWidth = g;
    fit.gainGridHeight = std::max(2, g * 3 / 4);
    auto [row, cal] = measure(richest, fit);
    byGrid.rows.push_back(cells(fmt::format("{}x{}", fit.gainGridWidth, fit.gainGridHeight), row));
    gridCurve.add(g, 100.0 * row.seen.nonUniformity);
    finest = std::move(cal);
    progress.advance();
  }
  progress.finish();

  // What a viewer at the centre sees, before (geometric calibration only) and after.
  const Frame card = testCard(module.width, module.height);
  ObserverViewOptions view;
  view.width = 640;
  view.height = 360;
  const Eigen::Vector3d centre(0.0, rig.geometry().observer.y, rig.geometry().observer.z);
  writePng(synthesizeObserverView(rig.geometry(), emitted(rig, card, nullptr), centre, view),
           report.path("photometry_before.png"));
  writePng(
      synthesizeObserverView(rig.geometry(), emitted(rig, card, &finest.correction), centre, view),
      report.path("photometry_after.png"));

  report.heading("Photometric calibration: non-uniformity against capture count and gain map");
  report.text(fmt::format(
      "The simulated `demo` display ({} modules) with a seeded photometric truth (gamma 1.8–2.6, "
      "gains, blacks, mixed primaries, 10–30% vignetting, a weak and a tinted module), flat "
      "fields photographed by the colour camera binned to {}x{} from {} stations "
      "(calibration/photometry). A flat grey on every module through the fitted correction, "
      "seen by {} viewers along the observer line: brightness non-uniformity (brightest − "
      "darkest over the mean) and CIEDE2000 against the target grey. The gain map is fitted at "
      "the capture's richest level set. Capture time is the simulated camera's rendering time.",
      rig.geometry().modules.size(), 240, 135, 5, viewers.size()));
  report.table("photometry_levels", byLevels);
  report.table("photometry_gain_map", byGrid);
  report.figure(
      "photometry_levels",
      {.title = "photometry: non-uniformity against capture time (levels per channel varied)",
       .xLabel = "capture s",
       .yLabel = "non-uniformity %",
       .logY = true,
       .series = {levelCurve}});
  report.figure("photometry_gain_map",
                {.title = "photometry: non-uniformity against gain-map nodes across",
                 .xLabel = "gain map nodes across",
                 .yLabel = "non-uniformity %",
                 .logY = true,
                 .integerX = true,
                 .series = {gridCurve}});
  report.images({{"photometry_before.png",
                  "a viewer at x = 0: colour bars and a grey ramp on every module (in module image "
                  "coordinates, not traced: the bars' slanted edges are the modules' own), "
                  "geometric calibration only"},
                 {"photometry_after.png", "the same with the photometric correction"}});
}

}  // namespace parallax::report
