// End to end from images on the demo display: the simulated camera photographs the modules'
// Gray code + phase shift patterns from five stations, the decoder turns the pictures into
// correspondences and stripe centres, and the fit recovers the ground truth.
// Not from images here (stated): the camera intrinsics are taken as known (the checkerboard
// step is not built yet) and the fiducial sightings are projected with noise rather than
// detected in pictures.

#include <gtest/gtest.h>

#include <chrono>

#include "calibration/camera_renderer.h"
#include "calibration/capture_decoder.h"
#include "calibration/display_fit.h"
#include "calibration/display_presets.h"
#include "calibration/ground_truth.h"
#include "calibration/ray_error.h"
#include "calibration/synthetic_observations.h"

namespace parallax {
namespace {

TEST(ImageCalibration, DemoDisplayFromRenderedPatterns) {
  const auto start = std::chrono::steady_clock::now();
  const DisplayModel nominal = resolveDisplay("demo");
  GroundTruthOptions gt;
  gt.seed = 31;
  const DisplayModel truth = makeGroundTruth(nominal, gt);

  SyntheticOptions rig;
  rig.seed = 32;
  rig.rig.spanM = 3.2;
  rig.rig.intrinsics.width = 640;
  rig.rig.intrinsics.height = 360;
  rig.rig.intrinsics.fx = rig.rig.intrinsics.fy = 700.0;
  rig.rig.intrinsics.cx = 320.0;
  rig.rig.intrinsics.cy = 180.0;
  rig.rig.intrinsics.k1 = -0.04;
  SyntheticCalibration session = simulateObservations(truth, rig);
  CalibrationObservations& obs = session.observations;
  obs.correspondences.clear();  // these come from the pictures below
  obs.stripes.clear();

  CameraRenderOptions render;
  CaptureDecoderOptions decoder;
  decoder.pixelStep = 6;  // every 6th camera pixel each way: ~25k correspondences keep the fit fast
  SeededRandom random(33);
  const int mw = nominal.modules[0].width, mh = nominal.modules[0].height;
  const auto columnPatterns = makePatternFrames(mw, mh, PatternAxis::kColumns, decoder.patterns);
  const auto rowPatterns = makePatternFrames(mw, mh, PatternAxis::kRows, decoder.patterns);
  int frames = 0;
  for (size_t station = 0; station < session.truePoses.size(); ++station) {
    const StationView view = viewFromStation(truth, obs.intrinsics, session.truePoses[station], render);
    for (int g = 0; g < 3; ++g) {  // every third module at once: their lobes do not overlap
      std::vector<int> group;
      for (int m = g; m < static_cast<int>(nominal.modules.size()); m += 3) group.push_back(m);
      auto shoot = [&](const std::vector<cv::Mat>& patterns) {
        std::vector<cv::Mat> out;
        for (const cv::Mat& pattern : patterns) {
          std::vector<cv::Mat> images(nominal.modules.size());
          for (int m : group) images[static_cast<size_t>(m)] = pattern;
          out.push_back(linearFromRecorded(renderFrame(view, images, render, random), render.gamma));
          ++frames;
        }
        return out;
      };
      decodeStation(shoot(columnPatterns), shoot(rowPatterns), group, nominal, static_cast<int>(station), decoder, &obs);
    }
  }
  const double captureSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  FitOptions fit;
  const FitResult result = fitDisplay(nominal, obs, fit);
  RayErrorStats rays = totalRayError(compareRays(truth, result.model));
  std::printf("STABILITY | %-28s | ray px rms %.4f max %.3f | screen mm rms %.3f max %.3f | observer mm rms "
              "%.2f max %.2f | k %.5f (true %.5f) | render+decode %.1f s (%d frames), fit %.2f s | %s\n",
              "end to end from images (demo)", rays.rmsPx, rays.maxPx, rays.rmsScreenMm, rays.maxScreenMm,
              rays.rmsObserverMm, rays.maxObserverMm, result.model.screen.curvature, truth.screen.curvature,
              captureSeconds, frames, result.solveSeconds, result.passesQualityChecks() ? "passes" : "REFUSED");
  std::printf("    %zu correspondences, %zu stripe centres, %d outliers, σ %.3f module px\n",
              obs.correspondences.size(), obs.stripes.size(), result.outliers, result.correspondenceSigmaPx);
  for (const Deficiency& d : result.deficiencies) std::printf("    %s\n", d.describe().c_str());
  for (const std::string& n : result.notes) std::printf("    note: %s\n", n.c_str());
  EXPECT_TRUE(result.passesQualityChecks());
  // Measured 0.22 px RMS (nominal: ~12 px), against 0.03 px from synthetic correspondences at
  // the same noise: the image path has a systematic error not yet tracked down (suspects:
  // ~9% of pixels near stripe borders given to the wrong module, and stripe centroids biased
  // where a stripe runs off a module's image). The tolerance records where it stands.
  EXPECT_LT(rays.rmsPx, 0.4);
  EXPECT_LT(rays.rmsPx, 0.05 * totalRayError(compareRays(truth, nominal)).rmsPx);
  EXPECT_TRUE(std::isfinite(rays.maxPx));
}

}  // namespace
}  // namespace parallax
