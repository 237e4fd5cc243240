// The calibration camera's own calibration: the simulated camera photographs a checkerboard in
// seeded poses through its true model and sensor (checkerboard_renderer.h), the corners are
// found at subpixel precision and cv::calibrateCamera recovers the camera in our conventions
// (checkerboard_calibration.h); bad pictures and folders are refused with the file named.

#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calibration/capture/calibration_captures.h"
#include "calibration/capture/checkerboard_calibration.h"
#include "calibration/capture/checkerboard_captures.h"
#include "calibration/display/conventions.h"
#include "calibration/simulation/checkerboard_renderer.h"
#include "common/input_error.h"
#include "tests/calibration/input_error_message.h"

namespace parallax {
namespace {

namespace fs = std::filesystem;

// A camera as built, at the image test's resolution: not the round datasheet numbers.
CameraIntrinsics testCamera() {
  CameraIntrinsics in;
  in.width = 640;
  in.height = 360;
  in.fx = 707.3;
  in.fy = 706.1;
  in.cx = 324.6;
  in.cy = 176.2;
  in.k1 = -0.058;
  in.k2 = 0.012;
  return in;
}

std::vector<CheckerboardPicture> photograph(const CameraIntrinsics& camera, int count,
                                            std::uint64_t seed,
                                            std::vector<Eigen::Isometry3d>* posesOut = nullptr) {
  SeededRandom random(seed);
  CheckerboardShotOptions shots;
  shots.pictures = count;
  const auto poses = checkerboardPoses(CheckerboardBoard{}, camera, shots, random);
  const auto pictures = photographCheckerboard(CheckerboardBoard{}, camera, poses,
                                               CameraRenderOptions{}, shots, random);
  if (posesOut) *posesOut = poses;
  std::vector<CheckerboardPicture> out;
  for (size_t i = 0; i < pictures.size(); ++i)
    out.push_back({"board_" + std::to_string(i) + ".png", pictures[i]});
  return out;
}

// A picture of the room with no board in it: background light through the same sensor.
CheckerboardPicture emptyPicture(const CameraIntrinsics& camera, const std::string& name) {
  SeededRandom random(99);
  cv::Mat light(camera.height, camera.width, CV_32F, cv::Scalar(0.15));
  cv::Mat bytes;
  recordThroughSensor(light, CameraRenderOptions{}, random).convertTo(bytes, CV_8U, 255.0);
  return {name, bytes};
}

using test::inputErrorOf;

TEST(Checkerboard, DistortionIsOpenCvsWithHalfPixelCentres) {
  // The mapping calibrateCamera's result goes through: our project() must equal
  // cv::projectPoints with (k1, k2, 0, 0, 0) and the principal point moved by half a pixel.
  const CameraIntrinsics in = testCamera();
  const cv::Matx33d k(in.fx, 0, in.cx - 0.5, 0, in.fy, in.cy - 0.5, 0, 0, 1);
  const std::vector<double> distortion{in.k1, in.k2, 0.0, 0.0, 0.0};
  SeededRandom random(5);
  std::vector<cv::Point3d> points;
  for (int i = 0; i < 200; ++i)
    points.emplace_back(random.uniform(-0.5, 0.5), random.uniform(-0.3, 0.3),
                        random.uniform(0.8, 2.0));
  std::vector<cv::Point2d> projected;
  cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), k, distortion, projected);
  double worst = 0.0;
  for (size_t i = 0; i < points.size(); ++i) {
    Eigen::Vector2d ours;
    ASSERT_TRUE(in.project({points[i].x, points[i].y, points[i].z}, &ours));
    worst = std::max(
        worst, (openCvFromPixel(ours) - Eigen::Vector2d(projected[i].x, projected[i].y)).norm());
  }
  EXPECT_LT(worst, 1e-9);
}

TEST(Checkerboard, CornersAreFoundWhereTheTrueCameraSeesThem) {
  const CameraIntrinsics camera = testCamera();
  std::vector<Eigen::Isometry3d> poses;
  const auto pictures = photograph(camera, 4, 11, &poses);
  const CheckerboardBoard board;
  std::vector<double> errors;
  for (size_t p = 0; p < pictures.size(); ++p) {
    const auto corners = findCheckerboardCorners(pictures[p].recorded, board);
    ASSERT_TRUE(corners) << pictures[p].name;
    std::vector<Eigen::Vector2d> truth;
    for (const Eigen::Vector3d& c : board.cornerPoints()) {
      Eigen::Vector2d px;
      ASSERT_TRUE(camera.project(poses[p] * c, &px));
      truth.push_back(px);
    }
    // The detector may number the grid from either end (a half turn): compare both ways.
    double forward = 0.0, backward = 0.0;
    for (size_t i = 0; i < truth.size(); ++i) {
      forward = std::max(forward, ((*corners)[i] - truth[i]).norm());
      backward = std::max(backward, ((*corners)[i] - truth[truth.size() - 1 - i]).norm());
    }
    const bool reversed = backward < forward;
    for (size_t i = 0; i < truth.size(); ++i) {
      errors.push_back(((*corners)[i] - truth[reversed ? truth.size() - 1 - i : i]).norm());
    }
  }
  std::sort(errors.begin(), errors.end());
  const double median = errors[errors.size() / 2], worst = errors.back();
  std::printf("    corners vs truth: median %.3f px, worst %.3f px over %zu corners\n", median,
              worst, errors.size());
  // Measured median 0.041, worst 0.101 px (blur 0.6 px, noise ~1 code, 8-bit, 4 pictures).
  EXPECT_LT(median, 0.08);
  EXPECT_LT(worst, 0.25);
}

TEST(Checkerboard, CalibrationRecoversTheCamera) {
  const CameraIntrinsics truth = testCamera();
  const auto pictures = photograph(truth, 12, 21);
  const CheckerboardCalibration result =
      calibrateFromCheckerboard(pictures, CheckerboardBoard{}, truth.width, truth.height);
  std::printf("%s", formatCheckerboardCalibration(result, &truth).c_str());
  // Measured (seed 21): fx +0.15%, fy +0.11%, cx −0.60 px, cy +0.08 px, k1 −0.0027, 0.050 px RMS.
  // OpenCV's own σ for fx is ~0.14% at this resolution (640×360, 12 pictures), over eight
  // other seeds the fx error was 0.08% RMS, 0.17% worst: the bounds below keep ~2σ of margin.
  const CameraIntrinsics& in = result.intrinsics;
  EXPECT_EQ(result.used.size(), 12u);
  EXPECT_TRUE(result.skipped.empty());
  EXPECT_EQ(in.width, truth.width);
  EXPECT_EQ(in.height, truth.height);
  EXPECT_LT(std::abs(in.fx / truth.fx - 1.0), 0.003);
  EXPECT_LT(std::abs(in.fy / truth.fy - 1.0), 0.003);
  EXPECT_LT(std::abs(in.cx - truth.cx), 2.0);
  EXPECT_LT(std::abs(in.cy - truth.cy), 2.0);
  EXPECT_LT(std::abs(in.k1 - truth.k1), 0.01);
  EXPECT_LT(result.rmsPx, 0.2);
  EXPECT_TRUE(std::isfinite(in.k2));
}

// The intrinsics' covariance, which the display fit carries into its σ: its diagonal is the
// reported σ², its correlations are a covariance's, and over seeds it describes the real error
// (the squared Mahalanobis distance of the error has the χ² mean of its 6 parameters; a
// covariance 2× too narrow would give 24, 2× too wide 1.5).
TEST(Checkerboard, IntrinsicsCovarianceDescribesTheError) {
  const CameraIntrinsics truth = testCamera();
  double sumMahalanobis = 0.0;
  constexpr int kSeeds = 10;
  for (int seed = 0; seed < kSeeds; ++seed) {
    const auto pictures = photograph(truth, 12, 400 + static_cast<std::uint64_t>(seed));
    const CheckerboardCalibration r =
        calibrateFromCheckerboard(pictures, CheckerboardBoard{}, truth.width, truth.height);
    const IntrinsicsCovariance& cov = r.covariance;
    ASSERT_TRUE(cov.allFinite());
    const double sigmas[] = {r.sigmaFx, r.sigmaFy, r.sigmaCx, r.sigmaCy, r.sigmaK1, r.sigmaK2};
    for (int i = 0; i < kIntrinsicsParameters; ++i) {
      EXPECT_DOUBLE_EQ(std::sqrt(cov(i, i)), sigmas[i]) << "parameter " << i;
      for (int j = 0; j < i; ++j) {
        EXPECT_DOUBLE_EQ(cov(i, j), cov(j, i));
        EXPECT_LE(std::abs(cov(i, j)), std::sqrt(cov(i, i) * cov(j, j)));
      }
    }
    Eigen::Matrix<double, 6, 1> error;
    CameraIntrinsics found = r.intrinsics, expected = truth;
    for (int i = 0; i < kIntrinsicsParameters; ++i)
      error[i] = intrinsicsParameter(found, i) - intrinsicsParameter(expected, i);
    sumMahalanobis += error.dot(cov.ldlt().solve(error));
  }
  const double mean = sumMahalanobis / kSeeds;
  std::printf("mean squared Mahalanobis distance of the intrinsics' error: %.2f (χ² mean 6)\n",
              mean);
  EXPECT_GT(mean, 2.0);
  EXPECT_LT(mean, 14.0);
}

TEST(Checkerboard, PictureWithoutTheBoardIsSkippedAndNamed) {
  const CameraIntrinsics truth = testCamera();
  auto pictures = photograph(truth, 6, 31);
  pictures.insert(pictures.begin() + 2, emptyPicture(truth, "empty_wall.png"));
  const CheckerboardCalibration result =
      calibrateFromCheckerboard(pictures, CheckerboardBoard{}, truth.width, truth.height);
  ASSERT_EQ(result.skipped.size(), 1u);
  EXPECT_EQ(result.skipped[0], "empty_wall.png");
  EXPECT_EQ(result.used.size(), 6u);
  EXPECT_NE(formatCheckerboardCalibration(result).find("skipped empty_wall.png"),
            std::string::npos);
  EXPECT_LT(std::abs(result.intrinsics.fx / truth.fx - 1.0), 0.01);
}

TEST(Checkerboard, TooFewUsablePicturesIsAClearError) {
  const CameraIntrinsics truth = testCamera();
  auto pictures = photograph(truth, 2, 41);
  pictures.push_back(emptyPicture(truth, "a.png"));
  pictures.push_back(emptyPicture(truth, "b.png"));
  const std::string message = inputErrorOf(
      [&] { calibrateFromCheckerboard(pictures, CheckerboardBoard{}, truth.width, truth.height); });
  EXPECT_NE(message.find("pictures"), std::string::npos) << message;
  EXPECT_NE(message.find("found in 2 of 4"), std::string::npos) << message;
  // A picture of another size is named.
  auto wrong = photograph(truth, 4, 41);
  cv::resize(wrong[1].recorded, wrong[1].recorded, cv::Size(320, 180));
  const std::string sized = inputErrorOf(
      [&] { calibrateFromCheckerboard(wrong, CheckerboardBoard{}, truth.width, truth.height); });
  EXPECT_NE(sized.find("board_1.png"), std::string::npos) << sized;
  EXPECT_NE(sized.find("320x180"), std::string::npos) << sized;
}

TEST(Checkerboard, SameSeedSameBytes) {
  const CameraIntrinsics truth = testCamera();
  const auto a = photograph(truth, 2, 51), b = photograph(truth, 2, 51),
             c = photograph(truth, 2, 52);
  for (size_t i = 0; i < a.size(); ++i)
    EXPECT_EQ(cv::norm(a[i].recorded, b[i].recorded, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(a[0].recorded, c[0].recorded, cv::NORM_INF), 0.0);
}

fs::path freshDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / (name + "-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

TEST(CheckerboardCaptures, FolderRoundTripAndErrorsNameTheFile) {
  const CameraIntrinsics truth = testCamera();
  CheckerboardCaptures captures;
  captures.pictures = photograph(truth, 4, 61);
  const fs::path dir = freshDir("plx-checkerboard");
  saveCheckerboardCaptures(captures, dir.string());
  ASSERT_TRUE(hasCheckerboardCaptures(dir.string()));
  const CheckerboardCaptures back =
      loadCheckerboardCaptures(dir.string(), truth.width, truth.height);
  ASSERT_EQ(back.pictures.size(), 4u);
  EXPECT_EQ(back.board.innerColumns, captures.board.innerColumns);
  EXPECT_EQ(back.board.squareM, captures.board.squareM);
  for (size_t i = 0; i < 4; ++i)
    EXPECT_EQ(cv::norm(back.pictures[i].recorded, captures.pictures[i].recorded, cv::NORM_INF),
              0.0);
  EXPECT_NE(back.pictures[2].name.find("checkerboard/board_02.png"), std::string::npos);

  // Wrong size for the camera: the picture is named.
  std::string message = inputErrorOf([&] { loadCheckerboardCaptures(dir.string(), 800, 600); });
  EXPECT_NE(message.find("board_00.png"), std::string::npos) << message;
  EXPECT_NE(message.find("640x360"), std::string::npos) << message;
  // Unreadable: not an image.
  { std::ofstream(dir / "checkerboard/board_01.png") << "not a png"; }
  message =
      inputErrorOf([&] { loadCheckerboardCaptures(dir.string(), truth.width, truth.height); });
  EXPECT_NE(message.find("board_01.png"), std::string::npos) << message;
  EXPECT_NE(message.find("cannot read"), std::string::npos) << message;
  // Missing.
  fs::remove(dir / "checkerboard/board_01.png");
  message =
      inputErrorOf([&] { loadCheckerboardCaptures(dir.string(), truth.width, truth.height); });
  EXPECT_NE(message.find("board_01.png"), std::string::npos) << message;
  // A bad board description names checkerboard.json and the field; a path out of the folder too.
  {
    std::ofstream(dir / "checkerboard.json")
        << R"({"format": "parallax-checkerboard", "version": 1, "inner_corners": [9, 1], "square_m": 0.04, "pictures": ["x.png"]})";
  }
  message =
      inputErrorOf([&] { loadCheckerboardCaptures(dir.string(), truth.width, truth.height); });
  EXPECT_NE(message.find("checkerboard.json: inner_corners"), std::string::npos) << message;
  {
    std::ofstream(dir / "checkerboard.json")
        << R"({"format": "parallax-checkerboard", "version": 1, "inner_corners": [9, 6], "square_m": 0.04, "pictures": ["../x.png"]})";
  }
  message =
      inputErrorOf([&] { loadCheckerboardCaptures(dir.string(), truth.width, truth.height); });
  EXPECT_NE(message.find("checkerboard.json: pictures[0]"), std::string::npos) << message;
  fs::remove_all(dir);
}

TEST(CheckerboardCaptures, CameraJsonWithoutIntrinsicsNeedsTheBoard) {
  const fs::path dir = freshDir("plx-camera-size-only");
  CameraMetadata camera;
  camera.intrinsics = testCamera();
  camera.intrinsicsKnown = false;
  camera.stations.push_back({{0.0, 0.0, 2.0}});
  saveCameraMetadata(camera, (dir / "camera.json").string());
  std::ifstream text(dir / "camera.json");
  const std::string json((std::istreambuf_iterator<char>(text)), std::istreambuf_iterator<char>());
  EXPECT_EQ(json.find("focal_px"), std::string::npos) << json;  // no true intrinsics written
  const CameraMetadata back = loadCameraMetadata((dir / "camera.json").string());
  EXPECT_FALSE(back.intrinsicsKnown);
  EXPECT_EQ(back.intrinsics.width, 640);
  EXPECT_EQ(back.intrinsics.height, 360);
  // Without checkerboard pictures the folder cannot be calibrated: camera.json is named.
  std::string message = inputErrorOf([&] { loadCaptures(dir.string()); });
  EXPECT_NE(message.find("camera.json: intrinsics.focal_px"), std::string::npos) << message;
  EXPECT_NE(message.find("checkerboard"), std::string::npos) << message;
  // The link path needs known intrinsics too.
  message = inputErrorOf(
      [&] { requireKnownIntrinsics(back, "camera.json", "calibrating through the link"); });
  EXPECT_NE(message.find("camera.json: intrinsics.focal_px"), std::string::npos) << message;
  // Decoding with unknown intrinsics is refused rather than run on NaN.
  CalibrationCaptures captures;
  captures.camera = back;
  message =
      inputErrorOf([&] { decodeCaptures(captures, DisplayModel{}, CaptureDecoderOptions{}); });
  EXPECT_NE(message.find("intrinsics"), std::string::npos) << message;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace parallax
