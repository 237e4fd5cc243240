#include "calibration/camera/observations_json.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>

#include "calibration/display/display_presets.h"
#include "calibration/simulation/ground_truth.h"
#include "calibration/simulation/synthetic_observations.h"
#include "common/input_error.h"
#include "tests/calibration/input_error_message.h"

namespace parallax {
namespace {

CalibrationObservations sample() {
  SyntheticOptions options;
  options.rig.stations = 2;
  options.rowStepPx = 64;
  return simulateObservations(makeGroundTruth(resolveDisplay("demo"), {}), options).observations;
}

using test::inputErrorOf;

TEST(ObservationsJson, RoundTripsThroughAFolderExactly) {
  const CalibrationObservations o = sample();
  const std::string dir = testing::TempDir() + "/obs_roundtrip";
  std::filesystem::create_directories(dir);
  saveObservations(o, dir);
  const CalibrationObservations back = loadObservations(dir);
  ASSERT_EQ(back.correspondences.size(), o.correspondences.size());
  ASSERT_EQ(back.stripes.size(), o.stripes.size());
  ASSERT_EQ(back.fiducialSightings.size(), o.fiducialSightings.size());
  EXPECT_EQ(back.correspondences[7].cameraPx, o.correspondences[7].cameraPx);
  EXPECT_EQ(back.correspondences[7].modulePx, o.correspondences[7].modulePx);
  EXPECT_EQ(back.stations[1].tapeCentre, o.stations[1].tapeCentre);
  EXPECT_EQ(back.intrinsics.fx, o.intrinsics.fx);
  EXPECT_EQ(back.fiducials, o.fiducials);
}

// The camera intrinsics' covariance (from the checkerboard) survives camera.json, and one that
// is not a covariance is refused with its entry named.
TEST(ObservationsJson, IntrinsicsCovarianceRoundTripsAndIsChecked) {
  CalibrationObservations o = sample();
  o.intrinsicsCovariance.setZero();
  EXPECT_FALSE(cameraMetadataToJson(o)["intrinsics"].contains("covariance"));
  IntrinsicsCovariance cov = IntrinsicsCovariance::Zero();
  const double sigma[] = {0.9, 0.8, 0.45, 0.6, 0.003, 0.014};
  for (int i = 0; i < kIntrinsicsParameters; ++i) cov(i, i) = sigma[i] * sigma[i];
  cov(0, 1) = cov(1, 0) = 0.9 * sigma[0] * sigma[1];
  o.intrinsicsCovariance = cov;
  CalibrationObservations back;
  cameraMetadataFromJson(cameraMetadataToJson(o), &back);
  EXPECT_EQ(back.intrinsicsCovariance, cov);

  nlohmann::json c = cameraMetadataToJson(o);
  c["intrinsics"]["covariance"][2][2] = -1.0;
  EXPECT_NE(
      inputErrorOf([&] { cameraMetadataFromJson(c, &back); }).find("intrinsics.covariance[2][2]"),
      std::string::npos);
  c = cameraMetadataToJson(o);
  c["intrinsics"]["covariance"][1][0] = 0.5;  // no longer symmetric
  EXPECT_NE(
      inputErrorOf([&] { cameraMetadataFromJson(c, &back); }).find("intrinsics.covariance[1][0]"),
      std::string::npos);
  c = cameraMetadataToJson(o);
  c["intrinsics"]["covariance"][3] = {1.0, 2.0};
  EXPECT_NE(
      inputErrorOf([&] { cameraMetadataFromJson(c, &back); }).find("intrinsics.covariance[3]"),
      std::string::npos);
  c = cameraMetadataToJson(o);
  c["intrinsics"]["covariance"].erase(5);
  EXPECT_NE(inputErrorOf([&] { cameraMetadataFromJson(c, &back); }).find("intrinsics.covariance"),
            std::string::npos);
}

TEST(ObservationsJson, NamesTheBadField) {
  CalibrationObservations o = sample();
  nlohmann::json j = decodedToJson(o);
  j["correspondences"][3][4] = "left";
  EXPECT_NE(inputErrorOf([&] { decodedFromJson(j, &o); }).find("correspondences[3][4]"),
            std::string::npos);
  j = decodedToJson(o);
  j["stripes"][0][0] = -1;
  EXPECT_NE(inputErrorOf([&] { decodedFromJson(j, &o); }).find("stripes[0][0]"), std::string::npos);
  j = decodedToJson(o);
  j["correspondences"][1] = nlohmann::json::array({0, 1});
  EXPECT_NE(inputErrorOf([&] { decodedFromJson(j, &o); }).find("correspondences[1]"),
            std::string::npos);
  nlohmann::json c = cameraMetadataToJson(o);
  c["intrinsics"]["focal_px"] = {0.0, 100.0};
  EXPECT_NE(inputErrorOf([&] { cameraMetadataFromJson(c, &o); }).find("intrinsics.focal_px"),
            std::string::npos);
  c = cameraMetadataToJson(o);
  c["format"] = "parallax-display";
  EXPECT_NE(inputErrorOf([&] { cameraMetadataFromJson(c, &o); }).find("format"), std::string::npos);
}

TEST(ObservationsJson, SyntaxErrorsCarryFileAndLine) {
  const std::string dir = testing::TempDir() + "/obs_broken";
  std::filesystem::create_directories(dir);
  saveObservations(sample(), dir);
  {
    std::ofstream out(dir + "/camera.json");
    out << "{\n  \"format\": \"parallax-camera\",\n  \"version\": 1,\n  oops\n}\n";
  }
  const std::string message = inputErrorOf([&] { loadObservations(dir); });
  EXPECT_NE(message.find("camera.json:4"), std::string::npos) << message;
  const std::string missing = inputErrorOf([&] { loadObservations(dir + "/nowhere"); });
  EXPECT_NE(missing.find("cannot open"), std::string::npos) << missing;
}

}  // namespace
}  // namespace parallax
