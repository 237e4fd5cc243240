#pragma once
// A simulated display with photometric variation and its colour camera, for the photometric
// calibration tests: the `demo` display's seeded geometric truth, a seeded photometric truth,
// the rig's camera binned 8× (a photometric capture needs no resolution) and a FlatFieldCamera
// that photographs what the modules show through calibration/simulation's physics.

#include <cstring>
#include <map>
#include <memory>
#include <vector>

#include "calibration/display/display_presets.h"
#include "calibration/photometry/flat_field_capture.h"
#include "calibration/simulation/colour_picture_renderer.h"
#include "calibration/simulation/ground_truth.h"
#include "calibration/simulation/photometric_truth.h"
#include "calibration/simulation/simulated_session.h"

namespace parallax::testing {

struct PhotometricRig {
  DisplayModel geometry;  // the truth, taken as the geometric calibration here
  PhotometricTruth photometry;
  CameraIntrinsics intrinsics;  // binned
  std::vector<CameraPose> poses;
  CameraRenderOptions sensor;
  std::vector<std::unique_ptr<StationView>> views;
  std::vector<cv::Mat> falloff;             // per module, CV_32F
  mutable std::vector<cv::Mat> blackLight;  // per module, once asked for
  double exposureScale = 1.0;  // a camera whose exposure is off by this much (saturation)
  bool blind = false;          // a camera that gives black pictures

  PhotometricRig(std::uint64_t seed, const PhotometricTruthOptions& truthOptions) {
    GroundTruthOptions g;
    g.seed = seed;
    geometry = makeGroundTruth(resolveDisplay("demo"), g);
    PhotometricTruthOptions p = truthOptions;
    p.seed = seed;
    photometry = makePhotometricTruth(static_cast<int>(geometry.modules.size()), p);
    const SimulatedRig rig = makeSimulatedRig(geometry, CameraRigOptions{}, seed);
    intrinsics = rig.truth.intrinsics;
    constexpr int kBin = 8;
    intrinsics.width /= kBin;
    intrinsics.height /= kBin;
    intrinsics.fx /= kBin;
    intrinsics.fy /= kBin;
    intrinsics.cx /= kBin;
    intrinsics.cy /= kBin;
    poses = rig.truth.poses;
    sensor = rig.truth.sensor;
    sensor.blurSigmaPx = 0.0;
    sensor.fiducialRadiusM = 0.0;
    for (const CameraPose& pose : poses) {
      views.push_back(
          std::make_unique<StationView>(viewFromStation(geometry, intrinsics, pose, sensor)));
    }
    refreshFalloff();
  }

  void refreshFalloff() {
    falloff.clear();
    blackLight.assign(photometry.modules.size(), cv::Mat());
    for (const ModulePhotometricTruth& m : photometry.modules) {
      const OpticalModule& om = geometry.modules.front();
      cv::Mat f(om.height, om.width, CV_32F);
      for (int y = 0; y < om.height; ++y)
        for (int x = 0; x < om.width; ++x)
          f.at<float>(y, x) = static_cast<float>(m.falloff(x + 0.5, y + 0.5, om.width, om.height));
      falloff.push_back(f);
    }
  }

  // Module i's light for its RGB8 frame (uniform frames the fast way).
  cv::Mat light(int module, const std::uint8_t* rgb) const {
    const OpticalModule& om = geometry.modules[static_cast<size_t>(module)];
    const size_t bytes = static_cast<size_t>(om.width) * static_cast<size_t>(om.height) * 3;
    bool uniform = true;
    for (size_t i = 3; i < bytes && uniform; i += 3) uniform = std::memcmp(rgb, rgb + i, 3) == 0;
    if (!uniform) return photometry.emittedLight(module, om.width, om.height, rgb);
    const bool black = rgb[0] == 0 && rgb[1] == 0 && rgb[2] == 0;
    if (black && !blackLight[static_cast<size_t>(module)].empty())
      return blackLight[static_cast<size_t>(module)];
    const Eigen::Vector3d l = photometry.modules[static_cast<size_t>(module)].light(
        Eigen::Vector3d(rgb[0], rgb[1], rgb[2]), om.width / 2.0, om.height / 2.0, om.width,
        om.height);
    const double centre = photometry.modules[static_cast<size_t>(module)].falloff(
        om.width / 2.0, om.height / 2.0, om.width, om.height);
    std::vector<cv::Mat> channels;
    for (int c = 0; c < 3; ++c)
      channels.push_back(falloff[static_cast<size_t>(module)] * (l[c] / centre));
    cv::Mat out;
    cv::merge(channels, out);
    if (black) blackLight[static_cast<size_t>(module)] = out;
    return out;
  }

  FlatFieldCamera camera() {
    return [this](int station, const std::vector<const std::uint8_t*>& frames, double exposure) {
      if (blind) return cv::Mat(intrinsics.height, intrinsics.width, CV_32FC3, cv::Scalar(0, 0, 0));
      std::vector<cv::Mat> lights;
      for (size_t i = 0; i < frames.size(); ++i)
        lights.push_back(light(static_cast<int>(i), frames[i]));
      SeededRandom random(1000 + static_cast<std::uint64_t>(station) * 7919 + pictures++);
      return renderColourPicture(*views[static_cast<size_t>(station)], lights, sensor,
                                 exposure * exposureScale, random);
    };
  }

  FlatFieldCaptures capture(FlatFieldOptions options) {
    options.pixelStep = 1;                                    // the binned camera's every pixel
    blackLight.assign(photometry.modules.size(), cv::Mat());  // the truth may have changed
    return captureFlatFields(geometry, intrinsics, poses, sensor.gamma, camera(), options);
  }

  std::uint64_t pictures = 0;
};

}  // namespace parallax::testing
