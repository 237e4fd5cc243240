// End to end from images on the demo display: the simulated camera photographs a checkerboard
// (its intrinsics come from those pictures, cv::calibrateCamera: checkerboard_calibration.h,
// never from its truth), then the modules' Gray code + phase shift patterns and the fiducial
// markers from five stations (renderSession); the decoder turns the pictures into
// correspondences, stripe centres and fiducial sightings (decodeCaptures), and the fit
// recovers the ground truth.

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>

#include "calibration/camera/calibration_geometry.h"
#include "calibration/capture/calibration_captures.h"
#include "calibration/capture/checkerboard_calibration.h"
#include "calibration/display/conventions.h"
#include "calibration/display/display_presets.h"
#include "calibration/display/ray_error.h"
#include "calibration/fit/display_fit.h"
#include "calibration/simulation/ground_truth.h"
#include "calibration/simulation/simulated_session.h"

namespace parallax {
namespace {

TEST(ImageCalibration, DemoDisplayFromRenderedPatterns) {
  const auto start = std::chrono::steady_clock::now();
  const DisplayModel nominal = resolveDisplay("demo");
  GroundTruthOptions gt;
  gt.seed = 31;
  const DisplayModel truth = makeGroundTruth(nominal, gt);

  CameraRigOptions rig;
  rig.spanM = 4.0;  // the module row spans ±(W/2)(1+D/Z): outer stations see the outer modules
  rig.intrinsics = CameraIntrinsics::centred(640, 360, 700.0, -0.04);
  const SimulatedRig camera = makeSimulatedRig(truth, rig, 32);
  CalibrationCaptures captures = renderSession(truth, camera.truth, camera.metadata, {});
  // The camera's intrinsics from twelve pictures of the board, as `parallax calibrate` gets them
  // from a captures folder whose camera.json holds only the picture size.
  CheckerboardShotOptions shots;
  shots.pictures = 12;
  captures.checkerboard = simulateCheckerboardCaptures(camera.truth, CheckerboardBoard{}, shots);
  captures.camera.intrinsicsKnown = false;
  const CheckerboardCalibration cameraFit = calibrateCapturesCamera(&captures);
  std::printf("%s", formatCheckerboardCalibration(cameraFit, &camera.truth.intrinsics).c_str());
  const CameraIntrinsics& fitted = captures.camera.intrinsics;
  EXPECT_LT(std::abs(fitted.fx / camera.truth.intrinsics.fx - 1.0), 0.003);
  EXPECT_LT(std::abs(fitted.fy / camera.truth.intrinsics.fy - 1.0), 0.003);
  EXPECT_LT(std::abs(fitted.cx - camera.truth.intrinsics.cx), 2.0);
  EXPECT_LT(std::abs(fitted.cy - camera.truth.intrinsics.cy), 2.0);
  EXPECT_LT(std::abs(fitted.k1 - camera.truth.intrinsics.k1), 0.01);
  CaptureDecoderOptions decoder;
  decoder.pixelStep = 6;  // every 6th camera pixel each way: ~25k correspondences keep the fit fast
  const CalibrationObservations obs = decodeCaptures(captures, nominal, decoder);
  int frames = 0;
  for (const StationCaptures& s : captures.stations)
    frames += static_cast<int>(s.columnFrames.size() + s.rowFrames.size());
  // Nearly every station sees all eight fiducials of the demo screen (a few fall on or beyond
  // the picture's edge); the detected ones are where the true camera sees them.
  EXPECT_GE(obs.fiducialSightings.size(), 5u * obs.fiducials.size() - 3);
  double worstFiducialPx = 0.0;
  for (const FiducialSighting& f : obs.fiducialSightings) {
    Eigen::Vector2d truePx;
    ASSERT_TRUE(
        projectPhysical(camera.truth.intrinsics, camera.truth.poses[static_cast<size_t>(f.camera)],
                        truth.screen.pointAt(obs.fiducials[static_cast<size_t>(f.fiducial)].x(),
                                             obs.fiducials[static_cast<size_t>(f.fiducial)].y()),
                        &truePx));
    worstFiducialPx = std::max(worstFiducialPx, (f.cameraPx - truePx).norm());
  }
  std::printf("    fiducials: %zu sightings, worst %.3f px from the truth\n",
              obs.fiducialSightings.size(), worstFiducialPx);
  EXPECT_LT(worstFiducialPx, 0.3);
  {  // Decoding against the truth: where each decoded module pixel really is.
    std::vector<double> corrErr, stripeErr;
    int wrongModule = 0, misassigned = 0, weak = 0;
    for (const Correspondence& c : obs.correspondences) {
      const auto cam = packCamera(camera.truth.poses[static_cast<size_t>(c.camera)]);
      const Eigen::Vector2d n = camera.truth.intrinsics.normalized(c.cameraPx);
      Vec3<double> s;
      if (!screenPointOfCameraRay(truth.screen.curvature, cam.data(), n.x(), n.y(), &s)) continue;
      Eigen::Vector2d uv;
      const OpticalModule& m = truth.modules[static_cast<size_t>(c.module)];
      if (!ModuleOptics(m).project(s - m.position, &uv)) {
        ++wrongModule;
        continue;
      }
      corrErr.push_back((uv - c.modulePx).norm());
      if (corrErr.back() > 2.0) {
        int owner = -1;
        double best = 1e9;
        for (int g = c.module % 3; g < static_cast<int>(truth.modules.size()); g += 3) {
          const double a =
              std::abs(stripeAngle(truth.screen, s, truth.modules[static_cast<size_t>(g)].position,
                                   camera.truth.poses[static_cast<size_t>(c.camera)].centre));
          if (a < best) {
            best = a;
            owner = g;
          }
        }
        const double sigma = diffusionSigma(truth.screen.diffusionDeg);
        const double own = std::abs(stripeAngle(
            truth.screen, s, m.position, camera.truth.poses[static_cast<size_t>(c.camera)].centre));
        if (owner != c.module) ++misassigned;
        if (own > 2.0 * sigma) ++weak;
      }
    }
    for (const StripeCentre& st : obs.stripes) {
      const auto cam = packCamera(camera.truth.poses[static_cast<size_t>(st.camera)]);
      const OpticalModule& m = truth.modules[static_cast<size_t>(st.module)];
      auto angleAt = [&](double x, double* a) {
        const Eigen::Vector2d n = camera.truth.intrinsics.normalized({x, st.cameraPx.y()});
        Vec3<double> s;
        if (!screenPointOfCameraRay(truth.screen.curvature, cam.data(), n.x(), n.y(), &s))
          return false;
        *a = stripeAngle(truth.screen, s, m.position,
                         camera.truth.poses[static_cast<size_t>(st.camera)].centre);
        return true;
      };
      double lo = st.cameraPx.x() - 30, hi = st.cameraPx.x() + 30, alo, ahi;
      if (!angleAt(lo, &alo) || !angleAt(hi, &ahi) || (alo > 0) == (ahi > 0)) continue;
      for (int i = 0; i < 60; ++i) {
        const double mid = 0.5 * (lo + hi);
        double am;
        if (!angleAt(mid, &am)) break;
        if ((am > 0) == (alo > 0)) {
          lo = mid;
          alo = am;
        } else {
          hi = mid;
        }
      }
      stripeErr.push_back(st.cameraPx.x() - 0.5 * (lo + hi));
    }
    auto pct = [](std::vector<double> v, double q) {
      if (v.empty()) return 0.0;
      std::sort(v.begin(), v.end());
      return v[static_cast<size_t>(q * (v.size() - 1))];
    };
    int far = 0;
    for (double e : corrErr) far += e > 2.0 ? 1 : 0;
    double stripeMean = 0.0;
    for (double e : stripeErr) stripeMean += e / std::max<size_t>(1, stripeErr.size());
    std::vector<double> stripeAbs;
    for (double e : stripeErr) stripeAbs.push_back(std::abs(e));
    std::printf(
        "    decoded vs truth: correspondences median %.3f p90 %.3f p99 %.3f module px, %.1f%% > 2 "
        "px, %d unprojectable;"
        " stripes median |err| %.3f p90 %.3f camera px, mean %.3f\n",
        pct(corrErr, 0.5), pct(corrErr, 0.9), pct(corrErr, 0.99),
        100.0 * far / std::max<size_t>(1, corrErr.size()), wrongModule, pct(stripeAbs, 0.5),
        pct(stripeAbs, 0.9), stripeMean);
    std::printf("    gross: %d given to the wrong module, %d beyond 2 sigma of the lobe\n",
                misassigned, weak);
    // Measured 1.8% gross (> 2 px); stripes 0.33 px p90 with the lobe's peak found in the
    // predicted angle and the neighbours' lobes taken out (stripe_peak.h) — the pixels'
    // centroid gave 1.3 px p90, and the observer-line error of the fit fell from 11.9 to 2.0 mm.
    EXPECT_LT(static_cast<double>(far) / static_cast<double>(corrErr.size()), 0.03);
    EXPECT_LT(pct(corrErr, 0.5), 0.1);
    EXPECT_LT(pct(stripeAbs, 0.9), 0.6);
  }
  const double captureSeconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  FitOptions fit;
  const FitResult result = fitDisplay(nominal, obs, fit);
  RayErrorStats rays = totalRayError(compareRays(truth, result.model));
  std::printf(
      "STABILITY | %-28s | ray px rms %.4f max %.3f | screen mm rms %.3f max %.3f | observer mm "
      "rms "
      "%.2f max %.2f | k %.5f (true %.5f) | render+decode %.1f s (%d frames), fit %.2f s | %s\n",
      "end to end from images (demo)", rays.rmsPx, rays.maxPx, rays.rmsScreenMm, rays.maxScreenMm,
      rays.rmsObserverMm, rays.maxObserverMm, result.model.screen.curvature, truth.screen.curvature,
      captureSeconds, frames, result.solveSeconds,
      result.passesQualityChecks() ? "passes" : "REFUSED");
  std::printf("    %zu correspondences, %zu stripe centres, %d outliers, σ %.3f module px\n",
              obs.correspondences.size(), obs.stripes.size(), result.outliers,
              result.correspondenceSigmaPx);
  for (const Deficiency& d : result.deficiencies) std::printf("    %s\n", d.describe().c_str());
  for (const std::string& n : result.notes) std::printf("    note: %s\n", n.c_str());
  EXPECT_TRUE(result.passesQualityChecks());
  // Measured 0.10 px RMS with the true intrinsics, 0.11 px with the checkerboard's (fx −0.09%,
  // k1 +0.004 off; nominal: ~12 px), against ~0.04 px from synthetic correspondences
  // at the same noise. Fixed on the way: wrong-module pixels and biased stripes from the
  // tape-mark prediction (the decoder predicts from the fiducials' pose). Still reported: the
  // four outermost modules are poorly conditioned (cx / yaw / position), seen from too few
  // stations even over 4 m.
  EXPECT_LT(rays.rmsPx, 0.2);
  EXPECT_LT(rays.rmsPx, 0.05 * totalRayError(compareRays(truth, nominal)).rmsPx);
  EXPECT_TRUE(std::isfinite(rays.maxPx));
}

}  // namespace
}  // namespace parallax
