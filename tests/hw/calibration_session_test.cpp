// A calibration session through the link: parallax-simhw's camera with the calibration physics
// of a seeded ground truth, captureCalibration showing the patterns on the modules and taking
// the pictures, decodeCaptures and the fit.
//  - in process, a small display: the link session records the pictures the offline renderer
//    makes of the same truth (nothing lost or reordered on the way), leaves the modules in
//    playback mode, and stops cleanly when cancelled;
//  - the photometric flat fields through the link, from modules that show a photometric truth:
//    the fit finds the weak module and the responses;
// The real process on the demo display (`parallax-simhw --truth --camera`, then `parallax
// calibrate --link`) is the CTest calibrate_through_link (calibrate_link_test.sh).

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>

#include "calibration/display/display_model_json.h"
#include "calibration/display/display_presets.h"
#include "calibration/display/ray_error.h"
#include "calibration/fit/display_fit.h"
#include "calibration/photometry/photometric_fit.h"
#include "calibration/simulation/ground_truth.h"
#include "calibration/simulation/photometric_truth.h"
#include "calibration/simulation/simulated_session.h"
#include "hw/camera/calibration_capture.h"
#include "hw/camera/camera.h"
#include "hw/camera/flat_field_session.h"
#include "hw/link/socket_transport.h"
#include "hw/simulator/calibration_physics.h"
#include "sim_fixture.h"
#include "small_session.h"

namespace parallax::hw {
namespace {

TEST(CalibrationSession, LinkSessionRecordsWhatTheOfflineRendererMakes) {
  const SmallSession s = twoStationSession();
  InProcessSimhw sim(modulesOf(s.truth),
                     std::make_unique<CalibrationPhysics>(s.truth, s.rig.truth));
  int calls = 0, lastDone = -1, lastTotal = -1;
  CalibrationCaptures viaLink;
  {
    LinkClient link(std::make_unique<SocketTransport>(sim.path()));
    SimulatedCamera camera(link);
    CalibrationCaptureOptions options;
    viaLink = captureCalibration(link, camera, s.nominal, s.rig.metadata, options,
                                 [&](int done, int total) {
                                   ++calls;
                                   EXPECT_GE(done, lastDone);
                                   lastDone = done;
                                   lastTotal = total;
                                 });
  }
  sim.stop();
  const CalibrationCaptures offline = renderSession(s.truth, s.rig.truth, s.rig.metadata, {});
  ASSERT_EQ(viaLink.stations.size(), offline.stations.size());
  EXPECT_EQ(lastDone, lastTotal);
  EXPECT_EQ(calls, lastTotal + 1);  // 0 first, then one per picture
  EXPECT_EQ(sim.hardware().mode(), DisplayMode::kPlayback);
  // Same truth, same sensor noise stream, same order: equal up to a rounding tie of one 8-bit
  // level (at most ~0.01 in linear light near white), except where the link's frames carry the
  // picture sync code (sync_code.h), a band near the screen's top edge the offline patterns
  // do not have.
  double worstShare = 0.0;
  const auto differingShare = [](const cv::Mat& a, const cv::Mat& b) {
    cv::Mat differs = cv::abs(a - b) > 0.02;
    return static_cast<double>(cv::countNonZero(differs)) / static_cast<double>(a.total());
  };
  for (size_t i = 0; i < offline.stations.size(); ++i) {
    EXPECT_EQ(viaLink.stations[i].station, offline.stations[i].station);
    EXPECT_EQ(viaLink.stations[i].group, offline.stations[i].group);
    ASSERT_EQ(viaLink.stations[i].columnFrames.size(), offline.stations[i].columnFrames.size());
    ASSERT_EQ(viaLink.stations[i].rowFrames.size(), offline.stations[i].rowFrames.size());
    for (size_t f = 0; f < offline.stations[i].columnFrames.size(); ++f) {
      worstShare = std::max(worstShare, differingShare(viaLink.stations[i].columnFrames[f],
                                                       offline.stations[i].columnFrames[f]));
    }
    for (size_t f = 0; f < offline.stations[i].rowFrames.size(); ++f) {
      worstShare = std::max(worstShare, differingShare(viaLink.stations[i].rowFrames[f],
                                                       offline.stations[i].rowFrames[f]));
    }
  }
  // That band takes a third of these small modules' visible rows (16% of the pictures); a frame
  // lost or out of order differs over the half of the screen its stripes change.
  EXPECT_LT(worstShare, 0.2);
  // And the pictures are of the display, not blank: they decode to correspondences for every
  // module.
  CaptureDecoderOptions decoder;
  const CalibrationObservations obs = decodeCaptures(viaLink, s.nominal, decoder);
  std::vector<int> perModule(s.nominal.modules.size(), 0);
  for (const Correspondence& c : obs.correspondences) ++perModule[static_cast<size_t>(c.module)];
  for (size_t m = 0; m < perModule.size(); ++m) EXPECT_GT(perModule[m], 20) << "module " << m;
  EXPECT_FALSE(obs.fiducialSightings.empty());
}

TEST(CalibrationSession, CancelStopsAndLeavesPlaybackMode) {
  const SmallSession s = twoStationSession();
  InProcessSimhw sim(modulesOf(s.truth),
                     std::make_unique<CalibrationPhysics>(s.truth, s.rig.truth));
  std::atomic<bool> cancel{false};
  int pictures = 0;
  {
    LinkClient link(std::make_unique<SocketTransport>(sim.path()));
    SimulatedCamera camera(link);
    EXPECT_THROW(captureCalibration(
                     link, camera, s.nominal, s.rig.metadata, {},
                     [&](int done, int) {
                       pictures = done;
                       if (done == 5) cancel = true;
                     },
                     &cancel),
                 CalibrationCancelled);
    EXPECT_FALSE(camera.locked());
  }
  sim.stop();
  EXPECT_EQ(pictures, 5);
  EXPECT_EQ(sim.hardware().mode(), DisplayMode::kPlayback);
}

TEST(CalibrationSession, AStationTheCameraDoesNotHaveIsAClearError) {
  SmallSession s = twoStationSession();
  CameraTruth oneStation = s.rig.truth;
  oneStation.poses.resize(1);  // the simulator's camera knows one station, the metadata two
  InProcessSimhw sim(modulesOf(s.truth), std::make_unique<CalibrationPhysics>(s.truth, oneStation));
  LinkClient link(std::make_unique<SocketTransport>(sim.path()));
  SimulatedCamera camera(link);
  CalibrationCaptureOptions options;
  options.stations = {1};
  try {
    captureCalibration(link, camera, s.nominal, s.rig.metadata, options);
    ADD_FAILURE() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("station 1"), std::string::npos) << e.what();
  }
}

TEST(CalibrationSession, PhotometricFlatFieldsThroughTheLinkFindTheModulesPhotometry) {
  const SmallSession s = twoStationSession();
  PhotometricTruthOptions p;
  p.seed = 9;
  const PhotometricTruth photometry = makePhotometricTruth(6, p);
  InProcessSimhw sim(modulesOf(s.truth),
                     std::make_unique<CalibrationPhysics>(s.truth, s.rig.truth, photometry));
  FlatFieldCaptures captures;
  {
    LinkClient link(std::make_unique<SocketTransport>(sim.path()));
    SimulatedCamera camera(link);
    FlatFieldSession session(link, camera, CameraSettings{});
    FlatFieldOptions options;
    options.levels = {40, 128, 255};
    options.pixelStep = 1;
    captures = captureFlatFields(s.truth, s.rig.truth.intrinsics, s.rig.truth.poses,
                                 s.rig.metadata.responseGamma, session.camera(), options);
  }
  sim.stop();
  EXPECT_EQ(sim.hardware().mode(), DisplayMode::kPlayback);
  PhotometricFitOptions fitOptions;
  fitOptions.minSamples = 30;
  const PhotometricCalibration cal = fitPhotometry(captures, fitOptions);
  ASSERT_TRUE(cal.excluded().empty()) << cal.describe();
  std::vector<double> whites;
  for (const ModulePhotometricFigures& f : cal.modules) whites.push_back(f.whiteLuminance);
  const double brightest = *std::max_element(whites.begin(), whites.end());
  for (const ModulePhotometricFigures& f : cal.modules) {
    const ModulePhotometricTruth& t = photometry.modules[static_cast<size_t>(f.module)];
    const bool weak = t.primaries.colwise().sum().maxCoeff() < 0.75;
    EXPECT_EQ(f.whiteLuminance < 0.8 * brightest, weak) << cal.describe();
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(f.gamma[c], t.gamma[c], 0.15) << "module " << f.module;
  }
}

}  // namespace
}  // namespace parallax::hw
