#include "calibration/simulation/simulated_photometric_rig.h"

#include <cstring>

#include "calibration/simulation/colour_picture_renderer.h"
#include "calibration/simulation/ground_truth.h"
#include "calibration/simulation/simulated_session.h"

namespace parallax {

SimulatedPhotometricRig::SimulatedPhotometricRig(const DisplayModel& nominal, std::uint64_t seed,
                                                 const PhotometricTruthOptions& truthOptions) {
  GroundTruthOptions g;
  g.seed = seed;
  geometry_ = makeGroundTruth(nominal, g);
  PhotometricTruthOptions p = truthOptions;
  p.seed = seed;
  photometry_ = makePhotometricTruth(static_cast<int>(geometry_.modules.size()), p);
  const SimulatedRig rig = makeSimulatedRig(geometry_, CameraRigOptions{}, seed);
  intrinsics_ = rig.truth.intrinsics;
  constexpr int kBin = 8;
  intrinsics_.width /= kBin;
  intrinsics_.height /= kBin;
  intrinsics_.fx /= kBin;
  intrinsics_.fy /= kBin;
  intrinsics_.cx /= kBin;
  intrinsics_.cy /= kBin;
  poses_ = rig.truth.poses;
  sensor_ = rig.truth.sensor;
  sensor_.blurSigmaPx = 0.0;
  sensor_.fiducialRadiusM = 0.0;
  for (const CameraPose& pose : poses_) {
    views_.push_back(
        std::make_unique<StationView>(viewFromStation(geometry_, intrinsics_, pose, sensor_)));
  }
}

cv::Mat SimulatedPhotometricRig::light(int module, const std::uint8_t* rgb) const {
  const size_t m = static_cast<size_t>(module);
  const OpticalModule& om = geometry_.modules[m];
  const size_t bytes = static_cast<size_t>(om.width) * static_cast<size_t>(om.height) * 3;
  bool uniform = true;
  for (size_t i = 3; i < bytes && uniform; i += 3) uniform = std::memcmp(rgb, rgb + i, 3) == 0;
  if (!uniform) return photometry_.emittedLight(module, om.width, om.height, rgb);
  const bool black = rgb[0] == 0 && rgb[1] == 0 && rgb[2] == 0;
  if (black && !blackLight_[m].empty()) return blackLight_[m];
  const ModulePhotometricTruth& truth = photometry_.modules[m];
  const Eigen::Vector3d l = truth.light(Eigen::Vector3d(rgb[0], rgb[1], rgb[2]), om.width / 2.0,
                                        om.height / 2.0, om.width, om.height);
  const double centre = truth.falloff(om.width / 2.0, om.height / 2.0, om.width, om.height);
  std::vector<cv::Mat> channels;
  for (int c = 0; c < 3; ++c) channels.push_back(falloff_[m] * (l[c] / centre));
  cv::Mat out;
  cv::merge(channels, out);
  if (black) blackLight_[m] = out;
  return out;
}

cv::Mat SimulatedPhotometricRig::take(int station, const std::vector<const std::uint8_t*>& frames,
                                      double exposure) {
  if (blind) return cv::Mat(intrinsics_.height, intrinsics_.width, CV_32FC3, cv::Scalar(0, 0, 0));
  std::vector<cv::Mat> lights;
  for (size_t i = 0; i < frames.size(); ++i)
    lights.push_back(light(static_cast<int>(i), frames[i]));
  SeededRandom random(1000 + static_cast<std::uint64_t>(station) * 7919 + pictures_++);
  return renderColourPicture(*views_[static_cast<size_t>(station)], lights, sensor_,
                             exposure * exposureScale, random);
}

FlatFieldCaptures SimulatedPhotometricRig::capture(FlatFieldOptions options) {
  options.pixelStep = 1;  // the binned camera's every pixel
  // The truth may have changed since the last capture (tests break modules).
  falloff_.clear();
  for (const ModulePhotometricTruth& m : photometry_.modules) {
    const OpticalModule& om = geometry_.modules.front();
    cv::Mat f(om.height, om.width, CV_32F);
    for (int y = 0; y < om.height; ++y)
      for (int x = 0; x < om.width; ++x)
        f.at<float>(y, x) = static_cast<float>(m.falloff(x + 0.5, y + 0.5, om.width, om.height));
    falloff_.push_back(f);
  }
  blackLight_.assign(photometry_.modules.size(), cv::Mat());
  return captureFlatFields(
      geometry_, intrinsics_, poses_, sensor_.gamma,
      [this](int station, const std::vector<const std::uint8_t*>& frames, double exposure) {
        return take(station, frames, exposure);
      },
      options);
}

}  // namespace parallax
