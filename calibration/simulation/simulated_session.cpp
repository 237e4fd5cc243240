#include "calibration/simulation/simulated_session.h"

#include <algorithm>
#include <cmath>

namespace parallax {

std::vector<cv::Mat> quantisedPatternFrames(int width, int height, PatternAxis axis,
                                            const StructuredLightOptions& patterns) {
  std::vector<cv::Mat> frames = makePatternFrames(width, height, axis, patterns);
  for (cv::Mat& f : frames) {
    cv::Mat bytes;
    f.convertTo(bytes, CV_8U, 255.0);  // rounds, saturates
    bytes.convertTo(f, CV_32F, 1.0 / 255.0);
  }
  return frames;
}

CalibrationCaptures renderSession(const DisplayModel& truth, const CameraTruth& cameraTruth,
                                  const CameraMetadata& camera,
                                  const SimulatedSessionOptions& options) {
  options.patterns.validate();
  CalibrationCaptures captures;
  captures.camera = camera;
  captures.patterns = options.patterns;
  const int mw = truth.modules.front().width, mh = truth.modules.front().height;
  captures.moduleWidth = mw;
  captures.moduleHeight = mh;
  auto columnPatterns = quantisedPatternFrames(mw, mh, PatternAxis::kColumns, options.patterns);
  auto rowPatterns = quantisedPatternFrames(mw, mh, PatternAxis::kRows, options.patterns);
  if (options.moduleGamma != 1.0) {
    for (auto* frames : {&columnPatterns, &rowPatterns})
      for (cv::Mat& f : *frames) cv::pow(f, options.moduleGamma, f);
  }
  // The stride the capture would choose (calibration_capture.cpp), from the tape's stations.
  const auto groups = moduleGroups(static_cast<int>(truth.modules.size()),
                                   groupStrideFor(truth, camera.stations, options.groupStride));
  SeededRandom random(cameraTruth.seed);
  const int total = static_cast<int>(cameraTruth.poses.size() * groups.size() *
                                     (columnPatterns.size() + rowPatterns.size()));
  int done = 0;
  for (size_t station = 0; station < cameraTruth.poses.size(); ++station) {
    const StationView view = viewFromStation(truth, cameraTruth.intrinsics,
                                             cameraTruth.poses[station], cameraTruth.sensor);
    for (const std::vector<int>& group : groups) {
      StationCaptures s;
      s.station = static_cast<int>(station);
      s.group = group;
      auto shoot = [&](const std::vector<cv::Mat>& patterns, std::vector<cv::Mat>* out) {
        for (const cv::Mat& pattern : patterns) {
          std::vector<cv::Mat> images(truth.modules.size());
          for (int m : group) {
            const bool dark = std::find(options.darkModules.begin(), options.darkModules.end(),
                                        m) != options.darkModules.end();
            if (!dark) images[static_cast<size_t>(m)] = pattern;
          }
          cv::Mat recorded = renderFrame(view, images, cameraTruth.sensor, random);
          cv::Mat bytes;
          recorded.convertTo(bytes, CV_8U, 255.0);
          out->push_back(linearFromRecorded8(bytes, camera.responseGamma));
          if (options.onPicture) options.onPicture(++done, total);
        }
      };
      shoot(columnPatterns, &s.columnFrames);
      shoot(rowPatterns, &s.rowFrames);
      captures.stations.push_back(std::move(s));
    }
  }
  return captures;
}

CheckerboardCaptures simulateCheckerboardCaptures(const CameraTruth& camera,
                                                  const CheckerboardBoard& board,
                                                  const CheckerboardShotOptions& options) {
  SeededRandom random(camera.seed ^ 0x636865636b657273ULL);  // "checkers": its own stream
  const std::vector<Eigen::Isometry3d> poses =
      checkerboardPoses(board, camera.intrinsics, options, random);
  const std::vector<cv::Mat> pictures =
      photographCheckerboard(board, camera.intrinsics, poses, camera.sensor, options, random);
  CheckerboardCaptures captures;
  captures.board = board;
  for (size_t i = 0; i < pictures.size(); ++i)
    captures.pictures.push_back({"board " + std::to_string(i), pictures[i]});
  return captures;
}

CameraIntrinsics cameraAsBuilt(const CameraIntrinsics& datasheet, std::uint64_t seed) {
  SeededRandom random(seed ^ 0x6c656e73ULL);  // "lens"
  CameraIntrinsics in = datasheet;
  in.fx = datasheet.fx * (1.0 + random.clippedNormal(0.01, 0.02));
  in.fy = in.fx * (datasheet.fy / datasheet.fx) * (1.0 + random.clippedNormal(0.001, 0.003));
  in.cx = datasheet.cx + random.clippedNormal(0.01 * datasheet.width, 0.02 * datasheet.width);
  in.cy = datasheet.cy + random.clippedNormal(0.01 * datasheet.height, 0.02 * datasheet.height);
  in.k1 = datasheet.k1 + random.clippedNormal(0.015, 0.03);
  in.k2 = datasheet.k2 + random.clippedNormal(0.01, 0.02);
  return in;
}

SimulatedRig makeSimulatedRig(const DisplayModel& truth, const CameraRigOptions& rig,
                              std::uint64_t seed, const CameraRenderOptions& sensor) {
  SyntheticOptions options;
  options.seed = seed;
  options.rig = rig;
  const SyntheticCalibration session = simulateObservations(truth, options);
  SimulatedRig out;
  out.metadata.intrinsics = session.observations.intrinsics;
  out.metadata.stations = session.observations.stations;
  out.metadata.fiducials = session.observations.fiducials;
  out.metadata.responseGamma = sensor.gamma;
  out.metadata.responseGammaStated = true;
  // The screen's pictures are sampled at pixel centres, then blurred: the point spread is the
  // blur alone.
  out.metadata.lensBlurSigmaPx = sensor.blurSigmaPx;
  out.truth.intrinsics = session.observations.intrinsics;
  out.truth.poses = session.truePoses;
  out.truth.sensor = sensor;
  out.truth.seed = seed * 6364136223846793005ULL + 1442695040888963407ULL;
  return out;
}

}  // namespace parallax
