// The camera lens blurs the screen's pictures after the lobe has shaped their brightness, which
// shifts the decoded phase patterns toward each lobe's peak (capture_decoder.h). Left in, the
// fit reads that as every camera nearer the screen, many σ off, with σ that do not count it;
// the decoder undoes the shift when camera.json states the blur.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "calibration/capture/calibration_captures.h"
#include "calibration/display/display_presets.h"
#include "calibration/fit/display_fit.h"
#include "calibration/fit/fit_report.h"
#include "calibration/simulation/ground_truth.h"
#include "calibration/simulation/simulated_session.h"

namespace parallax {
namespace {

struct DepthErrors {
  double meanMm = 0.0;       // signed: negative is nearer the screen than the truth
  double worstSigmas = 0.0;  // the largest |error| along the viewing axis over its σ
};

// Each fitted camera's distance to the screen centre against the truth's.
DepthErrors depthErrors(const FitResult& fit, const CameraTruth& truth) {
  DepthErrors out;
  for (const CameraFit& cf : fit.cameras) {
    const Eigen::Vector3d& t = truth.poses[static_cast<size_t>(cf.camera)].centre;
    const Eigen::Vector3d axis = t.normalized();
    const double error = 1e3 * (cf.pose.centre - t).dot(axis);
    // σ along the axis from the per-axis σ (their correlations left out: an estimate).
    const double sigma =
        std::sqrt(std::pow(cf.stdDev[3] * axis.x(), 2) + std::pow(cf.stdDev[4] * axis.y(), 2) +
                  std::pow(cf.stdDev[5] * axis.z(), 2));
    out.meanMm += error / static_cast<double>(fit.cameras.size());
    out.worstSigmas = std::max(out.worstSigmas, std::abs(error) / sigma);
  }
  return out;
}

TEST(LensBlur, StatedBlurKeepsTheCamerasAtTheirDistance) {
  // 72 modules of 256 × 192 seen by a 640 × 360 camera: narrow lobes, where the shift is
  // largest against their width.
  NominalDisplayOptions options;
  options.modules = 72;
  options.width = 256;
  options.height = 192;
  const DisplayModel nominal = makeNominalDisplay(options);
  GroundTruthOptions gt;
  gt.seed = 57;
  const DisplayModel truth = makeGroundTruth(nominal, gt);
  CameraRigOptions rig;
  rig.spanM = 4.0;
  rig.intrinsics = CameraIntrinsics::centred(640, 360, 700.0, -0.04);
  const CameraRenderOptions sensor;  // its lens blur: σ 0.6 px
  const SimulatedRig camera = makeSimulatedRig(truth, rig, 58, sensor);
  CalibrationCaptures captures = renderSession(truth, camera.truth, camera.metadata, {});
  ASSERT_TRUE(captures.camera.lensBlurSigmaPx);
  EXPECT_EQ(*captures.camera.lensBlurSigmaPx, sensor.blurSigmaPx);

  CaptureDecoderOptions decoder;
  decoder.pixelStep = 6;
  FitOptions fit;
  fit.threads = 2;
  const CalibrationObservations stated = decodeCaptures(captures, nominal, decoder);
  captures.camera.lensBlurSigmaPx.reset();
  const CalibrationObservations unstated = decodeCaptures(captures, nominal, decoder);
  const FitResult corrected = fitDisplay(nominal, stated, fit);
  const FitResult biased = fitDisplay(nominal, unstated, fit);
  const DepthErrors c = depthErrors(corrected, camera.truth);
  const DepthErrors b = depthErrors(biased, camera.truth);
  std::printf(
      "    cameras' distance error: stated blur %+.2f mm (worst %.1fσ), not stated %+.2f mm "
      "(worst %.1fσ)\n",
      c.meanMm, c.worstSigmas, b.meanMm, b.worstSigmas);
  // Not stated: nearer, and beyond what its σ allow (this is what the test guards against).
  EXPECT_LT(b.meanMm, 0.0);
  EXPECT_GT(b.worstSigmas, 3.0);
  // Stated: every camera within 3σ along its axis.
  EXPECT_LT(c.worstSigmas, 3.0);
  EXPECT_LT(std::abs(c.meanMm), std::abs(b.meanMm) / 3.0);
  // The report says which it was.
  EXPECT_NE(formatFitSummary(corrected).find("corrected for the lens blur"), std::string::npos);
  bool noted = false;
  for (const std::string& n : biased.notes)
    noted |= n.find("lens_blur_sigma_px") != std::string::npos;
  EXPECT_TRUE(noted);
}

}  // namespace
}  // namespace parallax
