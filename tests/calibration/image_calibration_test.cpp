// End to end from images on the demo display: the simulated camera photographs the modules'
// Gray code + phase shift patterns and the fiducial markers from five stations
// (renderSession), the decoder turns the pictures into correspondences, stripe centres and
// fiducial sightings (decodeCaptures), and the fit recovers the ground truth.
// Not from images here (stated): the camera intrinsics are taken as known (the checkerboard
// step is separate).

#include <gtest/gtest.h>

#include <chrono>

#include "calibration/calibration_captures.h"
#include "calibration/display_fit.h"
#include "calibration/display_presets.h"
#include "calibration/ground_truth.h"
#include "calibration/ray_error.h"
#include "calibration/simulated_session.h"

namespace parallax {
namespace {

TEST(ImageCalibration, DemoDisplayFromRenderedPatterns) {
  const auto start = std::chrono::steady_clock::now();
  const DisplayModel nominal = resolveDisplay("demo");
  GroundTruthOptions gt;
  gt.seed = 31;
  const DisplayModel truth = makeGroundTruth(nominal, gt);

  CameraRigOptions rig;
  rig.spanM = 3.2;
  rig.intrinsics.width = 640;
  rig.intrinsics.height = 360;
  rig.intrinsics.fx = rig.intrinsics.fy = 700.0;
  rig.intrinsics.cx = 320.0;
  rig.intrinsics.cy = 180.0;
  rig.intrinsics.k1 = -0.04;
  const SimulatedRig camera = makeSimulatedRig(truth, rig, 32);
  const CalibrationCaptures captures = renderSession(truth, camera.truth, camera.metadata, {});
  CaptureDecoderOptions decoder;
  decoder.pixelStep = 6;  // every 6th camera pixel each way: ~25k correspondences keep the fit fast
  const CalibrationObservations obs = decodeCaptures(captures, nominal, decoder);
  int frames = 0;
  for (const StationCaptures& s : captures.stations) frames += static_cast<int>(s.columnFrames.size() + s.rowFrames.size());
  // Nearly every station sees all eight fiducials of the demo screen (a few fall on or beyond
  // the picture's edge); the detected ones are where the true camera sees them.
  EXPECT_GE(obs.fiducialSightings.size(), 5u * obs.fiducials.size() - 3);
  double worstFiducialPx = 0.0;
  for (const FiducialSighting& f : obs.fiducialSightings) {
    Eigen::Vector2d truePx;
    ASSERT_TRUE(projectPhysical(camera.truth.intrinsics, camera.truth.poses[static_cast<size_t>(f.camera)],
                                truth.screen.pointAt(obs.fiducials[static_cast<size_t>(f.fiducial)].x(),
                                                     obs.fiducials[static_cast<size_t>(f.fiducial)].y()),
                                &truePx));
    worstFiducialPx = std::max(worstFiducialPx, (f.cameraPx - truePx).norm());
  }
  std::printf("    fiducials: %zu sightings, worst %.3f px from the truth\n", obs.fiducialSightings.size(), worstFiducialPx);
  EXPECT_LT(worstFiducialPx, 0.3);
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
