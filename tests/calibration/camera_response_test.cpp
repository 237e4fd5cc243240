// The camera's response is measured from the phase pictures (calibration/capture/
// camera_response.h): a γ 2.2 camera whose camera.json gives none is measured at 2.2 and its
// pictures re-linearized, so its stripe centres are as close to the truth as with the right
// camera.json; a stated one is kept, and a disagreement is noted, not acted on; a linear camera
// is measured linear; three phase steps cannot be measured and say so.

#include "calibration/capture/camera_response.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "calibration/camera/calibration_geometry.h"
#include "calibration/display/display_presets.h"
#include "calibration/simulation/ground_truth.h"
#include "calibration/simulation/simulated_session.h"

namespace parallax {
namespace {

struct Session {
  DisplayModel nominal, truth;
  SimulatedRig rig;
  CalibrationCaptures captures;
};

// Six modules seen from three stations by a camera whose sensor has `sensorGamma`, with a
// camera.json that states `statedGamma`, or none (0).
Session session(double sensorGamma, double statedGamma, int phaseSteps = 4,
                double moduleGamma = 1.0) {
  NominalDisplayOptions options;
  options.modules = 6;
  options.width = 128;
  options.height = 96;
  Session s;
  s.nominal = makeNominalDisplay(options);
  s.truth = makeGroundTruth(s.nominal, GroundTruthOptions{});
  CameraRigOptions rig;
  rig.stations = 3;
  rig.spanM = 2.0;
  rig.intrinsics = CameraIntrinsics::centred(320, 180, 350.0);
  CameraRenderOptions sensor;
  sensor.gamma = sensorGamma;
  s.rig = makeSimulatedRig(s.truth, rig, 5, sensor);
  s.rig.metadata.responseGammaStated = statedGamma > 0.0;
  s.rig.metadata.responseGamma = statedGamma > 0.0 ? statedGamma : 1.0;
  SimulatedSessionOptions options2;
  options2.groupStride = 2;
  options2.patterns.phaseSteps = phaseSteps;
  options2.moduleGamma = moduleGamma;
  s.captures = renderSession(s.truth, s.rig.truth, s.rig.metadata, options2);
  return s;
}

// Median distance (mm, on the screen) of the decoded stripe centres from where the truth puts
// them.
double medianStripeErrorMm(const Session& s, const CalibrationObservations& obs) {
  std::vector<double> errors;
  for (const StripeCentre& c : obs.stripes) {
    const auto camera = packCamera(s.rig.truth.poses[static_cast<size_t>(c.camera)]);
    const Eigen::Vector2d n = s.rig.truth.intrinsics.normalized(c.cameraPx);
    Vec3<double> point;
    if (!screenPointOfCameraRay(s.truth.screen.curvature, camera.data(), n.x(), n.y(), &point))
      continue;
    const Eigen::Vector3d p = s.truth.modules[static_cast<size_t>(c.module)].position;
    const Eigen::Vector3d centre = s.rig.truth.poses[static_cast<size_t>(c.camera)].centre;
    errors.push_back(
        1e3 * std::abs(stripeMismatch<double>(s.truth.screen.transfer, s.truth.screen.curvature,
                                              point, Vec3<double>(p), Vec3<double>(centre))));
  }
  if (errors.empty()) return INFINITY;
  std::nth_element(errors.begin(), errors.begin() + static_cast<long>(errors.size() / 2),
                   errors.end());
  return errors[errors.size() / 2];
}

TEST(CameraResponse, AGammaCameraWhoseCameraJsonGivesNoneIsMeasuredAndCorrected) {
  const Session right = session(2.2, 2.2);
  const Session unstated = session(2.2, 0.0);
  const CameraResponseCheck r = checkCameraResponse(right.captures);
  const CameraResponseCheck u = checkCameraResponse(unstated.captures);
  std::printf("right camera.json: %s\nunstated: %s\n", describeCameraResponse(r).c_str(),
              describeCameraResponse(u).c_str());
  ASSERT_TRUE(r.measured);
  EXPECT_NEAR(r.measuredGamma, 2.2, 0.05);
  EXPECT_FALSE(r.corrected) << "a right camera.json is used as it is";
  ASSERT_TRUE(u.measured);
  EXPECT_NEAR(u.measuredGamma, 2.2, 0.05);
  EXPECT_TRUE(u.corrected);
  EXPECT_GT(u.pixels, 1000);
  EXPECT_LT(u.sigma, 0.02);

  // Decoded through the correction, the stripe centres are as good as with the right file.
  CaptureDecoderOptions decoder;
  decoder.pixelStep = 3;
  const CalibrationObservations withRight = decodeCaptures(right.captures, right.nominal, decoder);
  const CalibrationObservations corrected =
      decodeCaptures(unstated.captures, unstated.nominal, decoder);
  ASSERT_TRUE(corrected.cameraResponse && corrected.cameraResponse->corrected);
  EXPECT_FALSE(corrected.cameraResponse->modulesBend) << "the lobes say the camera bends";
  EXPECT_FALSE(corrected.cameraResponse->undecided()) << "the re-linearized lobes fit the nominal";
  const double rightMm = medianStripeErrorMm(right, withRight);
  const double correctedMm = medianStripeErrorMm(unstated, corrected);
  std::printf(
      "stripe centres, median from the truth: %.3f mm (right camera.json), %.3f mm "
      "(unstated, corrected); %zu and %zu centres\n",
      rightMm, correctedMm, withRight.stripes.size(), corrected.stripes.size());
  EXPECT_LT(correctedMm, 1.25 * rightMm + 0.02);
  EXPECT_GT(corrected.stripes.size(), withRight.stripes.size() * 9 / 10);
  EXPECT_GT(corrected.correspondences.size(), withRight.correspondences.size() * 9 / 10);
}

// The same γ in the modules instead (projectors driven without linearization) and a linear
// camera: the phase pictures measure the same chain, but now the lobes, lit by white modules,
// are right as recorded. Re-linearizing them as a camera's would widen every lobe by 1/√0.45
// and, through the neighbours' subtracted tails, move the stripe centres (demo through the
// link with a photometric truth: 110 mm worst on the observer line, installed).
TEST(CameraResponse, GammaModulesUnderALinearCameraBendOnlyThePatterns) {
  const Session right = session(1.0, 1.0);
  const Session bent = session(1.0, 0.0, 4, 2.2);
  CaptureDecoderOptions decoder;
  decoder.pixelStep = 3;
  const CalibrationObservations reference = decodeCaptures(right.captures, right.nominal, decoder);
  const CalibrationObservations obs = decodeCaptures(bent.captures, bent.nominal, decoder);
  ASSERT_TRUE(obs.cameraResponse && obs.cameraResponse->corrected);
  const CameraResponseCheck& r = *obs.cameraResponse;
  std::printf("%s\n", describeCameraResponse(r).c_str());
  // The chain, far from linear (the modules' γ seen through the blur that mixes neighbouring
  // pattern pixels in linear light is not a plain power of 1/2.2).
  EXPECT_LT(r.measuredGamma, 0.6);
  EXPECT_TRUE(r.modulesBend);
  EXPECT_NEAR(r.lobeWidthRecorded, 1.0, 0.2);
  EXPECT_DOUBLE_EQ(r.cameraGamma(), 1.0);
  EXPECT_FALSE(r.undecided()) << "the recorded lobes fit the nominal";
  // The modules' response measured above their black, not the chain's (whose blur-mixed
  // neighbouring pattern pixels bend it further: γ 3.5 for these γ 2.2 modules).
  EXPECT_GT(r.modulesGamma(), 1.5);
  EXPECT_LT(r.modulesGamma(), 1.0 / r.measuredGamma);
  const double referenceMm = medianStripeErrorMm(right, reference);
  const double bentMm = medianStripeErrorMm(bent, obs);
  std::printf("stripe centres, median from the truth: %.3f mm (linear modules), %.3f mm (γ 2.2)\n",
              referenceMm, bentMm);
  EXPECT_LT(bentMm, 1.25 * referenceMm + 0.02);
  EXPECT_GT(obs.stripes.size(), reference.stripes.size() * 9 / 10);
  EXPECT_GT(obs.correspondences.size(), reference.correspondences.size() * 9 / 10);
}

TEST(CameraResponse, ALinearCameraIsMeasuredLinearAndAStatedGammaIsKeptButQuestioned) {
  const CameraResponseCheck check = checkCameraResponse(session(1.0, 0.0).captures);
  ASSERT_TRUE(check.measured);
  EXPECT_NEAR(check.measuredGamma, 1.0, 0.03);
  EXPECT_FALSE(check.disagrees);
  EXPECT_FALSE(check.corrected);
  // A camera.json that states γ 2.2 for it: the phase pictures cannot tell a wrong file from
  // modules with a response curve of their own, so the stated γ stays and the note says so.
  const CameraResponseCheck claimed = checkCameraResponse(session(1.0, 2.2).captures);
  ASSERT_TRUE(claimed.measured);
  EXPECT_NEAR(claimed.measuredGamma, 1.0, 0.05);
  EXPECT_TRUE(claimed.disagrees);
  EXPECT_FALSE(claimed.corrected);
  EXPECT_DOUBLE_EQ(claimed.usedGamma(), 2.2);
  EXPECT_NE(describeCameraResponse(claimed).find("disagree"), std::string::npos);
}

TEST(CameraResponse, ThreePhaseStepsCannotShowItAndSaySo) {
  const CameraResponseCheck check = checkCameraResponse(session(2.2, 0.0, 3).captures);
  EXPECT_FALSE(check.measured);
  EXPECT_FALSE(check.corrected);
  EXPECT_NE(describeCameraResponse(check).find("taken on trust"), std::string::npos);
}

}  // namespace
}  // namespace parallax
