// The fiducial markers found in a station's black picture, against where the true camera sees
// them: every camera pose of a picture calibration hangs on them, so a marker taken from the
// wrong blob moves every camera and every module with it (at 2 px of camera noise the old
// detector took specks of noise 5-38 px from the markers at three of five stations, and the
// fit's σ did not know).

#include "calibration/capture/fiducial_detector.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "calibration/camera/calibration_geometry.h"
#include "calibration/capture/calibration_captures.h"
#include "calibration/display/display_presets.h"
#include "calibration/simulation/camera_renderer.h"
#include "calibration/simulation/ground_truth.h"
#include "calibration/simulation/simulated_session.h"

namespace parallax {
namespace {

struct Detection {
  int sightings = 0, visible = 0;  // visible: markers wholly inside the picture
  double worstPx = 0.0;
};

// Every station's black picture of the demo display, recorded with `noiseSigma` of sensor
// noise (recorded units) and `hotPixels` single saturated pixels, through the detector.
Detection detectAtNoise(std::uint64_t seed, double noiseSigma, int hotPixels = 0) {
  const DisplayModel nominal = resolveDisplay("demo");
  GroundTruthOptions gt;
  gt.seed = seed;
  const DisplayModel truth = makeGroundTruth(nominal, gt);
  CameraRigOptions rig;
  rig.spanM = 4.0;
  rig.intrinsics = CameraIntrinsics::centred(640, 360, 700.0, -0.04);
  CameraRenderOptions sensor;
  sensor.noiseSigma = noiseSigma;
  const SimulatedRig camera = makeSimulatedRig(truth, rig, seed, sensor);
  CalibrationObservations obs;
  obs.intrinsics = camera.metadata.intrinsics;
  obs.stations = camera.metadata.stations;
  obs.fiducials = camera.metadata.fiducials;
  SeededRandom random(seed);
  Detection out;
  for (size_t st = 0; st < camera.truth.poses.size(); ++st) {
    const StationView view =
        viewFromStation(truth, camera.truth.intrinsics, camera.truth.poses[st], sensor);
    cv::Mat recorded =
        renderFrame(view, std::vector<cv::Mat>(truth.modules.size()), sensor, random);
    for (int h = 0; h < hotPixels; ++h) {
      recorded.at<float>(static_cast<int>(random.uniform(0.0, recorded.rows - 1.0)),
                         static_cast<int>(random.uniform(0.0, recorded.cols - 1.0))) = 1.0f;
    }
    cv::Mat bytes;
    recorded.convertTo(bytes, CV_8U, 255.0);
    detectFiducials(linearFromRecorded8(bytes, sensor.gamma), nominal.screen, static_cast<int>(st),
                    FiducialDetectorOptions{}, &obs);
    for (const Eigen::Vector2d& f : obs.fiducials) {
      Eigen::Vector2d px;
      const double margin = 8.0;  // a marker's image is ~7 px across at these distances
      if (projectPhysical(camera.truth.intrinsics, camera.truth.poses[st],
                          truth.screen.pointAt(f.x(), f.y()), &px) &&
          px.x() > margin && px.y() > margin && px.x() < 640 - margin && px.y() < 360 - margin)
        ++out.visible;
    }
  }
  for (const FiducialSighting& f : obs.fiducialSightings) {
    Eigen::Vector2d truePx;
    const Eigen::Vector2d& xy = obs.fiducials[static_cast<size_t>(f.fiducial)];
    EXPECT_TRUE(projectPhysical(camera.truth.intrinsics,
                                camera.truth.poses[static_cast<size_t>(f.camera)],
                                truth.screen.pointAt(xy.x(), xy.y()), &truePx));
    out.worstPx = std::max(out.worstPx, (f.cameraPx - truePx).norm());
  }
  out.sightings = static_cast<int>(obs.fiducialSightings.size());
  return out;
}

// 0.075 is what the picture sweep's 2 px of camera noise means at the sensor
// (bench/picture_sessions.cpp); the default sensor has 0.004.
TEST(FiducialDetector, NoisyPicturesGiveTheMarkersNotTheSpecks) {
  for (std::uint64_t seed : {1008u, 1001u, 77u}) {
    for (double noise : {0.004, 0.075}) {
      const Detection d = detectAtNoise(seed, noise);
      std::printf("    seed %llu, sensor noise %.3f: %d sightings of %d visible, worst %.3f px\n",
                  static_cast<unsigned long long>(seed), noise, d.sightings, d.visible, d.worstPx);
      EXPECT_GE(d.sightings, d.visible) << "seed " << seed << " noise " << noise;
      EXPECT_LT(d.worstPx, noise < 0.01 ? 0.1 : 0.5) << "seed " << seed << " noise " << noise;
    }
  }
}

// A camera's hot pixels are bright but a single pixel: a marker outshines them.
TEST(FiducialDetector, HotPixelsAreNotMarkers) {
  const Detection d = detectAtNoise(5, 0.004, /*hotPixels=*/400);
  EXPECT_GE(d.sightings, d.visible);
  EXPECT_LT(d.worstPx, 0.1);
}

}  // namespace
}  // namespace parallax
