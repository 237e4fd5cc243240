// A captures folder on disk: what `parallax simulate` writes and `parallax calibrate
// --captures` reads. The pictures survive the round trip as the camera recorded them (8-bit),
// and bad folders are refused with the file and field named.

#include "calibration/capture/calibration_captures.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "calibration/display/display_presets.h"
#include "calibration/simulation/ground_truth.h"
#include "calibration/simulation/simulated_session.h"
#include "common/input_error.h"
#include "tests/png_header_bomb.h"

namespace parallax {
namespace {

namespace fs = std::filesystem;

struct Small {
  DisplayModel nominal, truth;
  SimulatedRig rig;
  CalibrationCaptures captures;
};

Small small() {
  NominalDisplayOptions options;
  options.modules = 4;
  options.width = 96;
  options.height = 64;
  Small s;
  s.nominal = makeNominalDisplay(options);
  s.truth = makeGroundTruth(s.nominal, GroundTruthOptions{});
  CameraRigOptions rig;
  rig.stations = 2;
  rig.spanM = 1.0;
  rig.intrinsics = CameraIntrinsics::centred(200, 112, 220.0);
  s.rig = makeSimulatedRig(s.truth, rig, 3);
  SimulatedSessionOptions session;
  session.groupStride = 2;
  s.captures = renderSession(s.truth, s.rig.truth, s.rig.metadata, session);
  return s;
}

fs::path freshDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / (name + "-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  return dir;
}

TEST(CalibrationCaptures, FolderRoundTripKeepsPicturesAndDecodesTheSame) {
  const Small s = small();
  const fs::path dir = freshDir("plx-captures");
  saveCaptures(s.captures, dir.string());
  const CalibrationCaptures loaded = loadCaptures(dir.string());
  EXPECT_EQ(loaded.camera.responseGamma, s.captures.camera.responseGamma);
  ASSERT_TRUE(s.captures.camera.lensBlurSigmaPx);  // the simulated rig states its lens blur
  ASSERT_TRUE(loaded.camera.lensBlurSigmaPx);
  EXPECT_EQ(*loaded.camera.lensBlurSigmaPx, *s.captures.camera.lensBlurSigmaPx);
  EXPECT_EQ(loaded.camera.stations.size(), 2u);
  ASSERT_EQ(loaded.stations.size(), s.captures.stations.size());
  for (size_t i = 0; i < loaded.stations.size(); ++i) {
    EXPECT_EQ(loaded.stations[i].group, s.captures.stations[i].group);
    ASSERT_EQ(loaded.stations[i].columnFrames.size(), s.captures.stations[i].columnFrames.size());
    for (size_t f = 0; f < loaded.stations[i].columnFrames.size(); ++f) {
      // Both already hold 8-bit recorded values: the round trip is exact up to float rounding.
      EXPECT_LT(cv::norm(loaded.stations[i].columnFrames[f], s.captures.stations[i].columnFrames[f],
                         cv::NORM_INF),
                1e-5);
    }
  }
  CaptureDecoderOptions decoder;
  const CalibrationObservations a = decodeCaptures(s.captures, s.nominal, decoder);
  const CalibrationObservations b = decodeCaptures(loaded, s.nominal, decoder);
  EXPECT_GT(a.correspondences.size(), 100u);
  ASSERT_EQ(a.correspondences.size(), b.correspondences.size());
  for (size_t i = 0; i < a.correspondences.size(); ++i) {
    EXPECT_NEAR((a.correspondences[i].modulePx - b.correspondences[i].modulePx).norm(), 0.0, 1e-4);
  }
  fs::remove_all(dir);
}

TEST(CalibrationCaptures, CheckerboardPicturesTravelWithTheFolderAndCameraJsonHasNoIntrinsics) {
  Small s = small();
  CheckerboardShotOptions shots;
  shots.pictures = 3;
  s.captures.checkerboard = simulateCheckerboardCaptures(s.rig.truth, CheckerboardBoard{}, shots);
  s.captures.camera.intrinsicsKnown = false;
  const fs::path dir = freshDir("plx-captures-board");
  saveCaptures(s.captures, dir.string());
  const CalibrationCaptures loaded = loadCaptures(dir.string());
  EXPECT_FALSE(loaded.camera.intrinsicsKnown);
  EXPECT_EQ(loaded.camera.intrinsics.width, s.rig.truth.intrinsics.width);
  EXPECT_FALSE(std::isfinite(loaded.camera.intrinsics.fx));  // nothing plausible-looking to misuse
  ASSERT_TRUE(loaded.checkerboard);
  ASSERT_EQ(loaded.checkerboard->pictures.size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(cv::norm(loaded.checkerboard->pictures[i].recorded,
                       s.captures.checkerboard->pictures[i].recorded, cv::NORM_INF),
              0.0);
  }
  // Not decodable until the camera is calibrated.
  try {
    decodeCaptures(loaded, s.nominal, CaptureDecoderOptions{});
    ADD_FAILURE() << "decoded with unknown intrinsics";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("intrinsics"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

std::string errorOf(const std::string& dir) {
  try {
    loadCaptures(dir);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(CalibrationCaptures, BadFoldersNameTheFileAndField) {
  const Small s = small();
  const fs::path dir = freshDir("plx-captures-bad");
  saveCaptures(s.captures, dir.string());

  // A missing picture.
  fs::rename(dir / "set000_c03.png", dir / "moved.png");
  std::string error = errorOf(dir.string());
  EXPECT_NE(error.find("set000_c03.png"), std::string::npos) << error;
  // A picture of the wrong size.
  cv::imwrite((dir / "set000_c03.png").string(), cv::Mat(10, 10, CV_8U, cv::Scalar(3)));
  error = errorOf(dir.string());
  EXPECT_NE(error.find("10x10"), std::string::npos) << error;
  fs::rename(dir / "moved.png", dir / "set000_c03.png");
  EXPECT_EQ(errorOf(dir.string()), "");

  // patterns.json listing too few pictures, a file outside the folder, a station not in
  // camera.json.
  std::ifstream in(dir / "patterns.json");
  const std::string original((std::istreambuf_iterator<char>(in)),
                             std::istreambuf_iterator<char>());
  auto withPatterns = [&](const std::string& from, const std::string& to) {
    std::string text = original;
    const size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
    std::ofstream(dir / "patterns.json") << text;
    return errorOf(dir.string());
  };
  error = withPatterns("\"set000_c03.png\",", "");
  EXPECT_NE(error.find("patterns.json: stations[0].columns"), std::string::npos) << error;
  error = withPatterns("\"set000_c03.png\"", "\"../set000_c03.png\"");
  EXPECT_NE(error.find("stations[0].columns[3]"), std::string::npos) << error;
  error = withPatterns("\"station\": 0", "\"station\": 7");
  EXPECT_NE(error.find("stations[0].station"), std::string::npos) << error;
  error = withPatterns("\"period_px\": 16", "\"period_px\": \"x\"");
  EXPECT_NE(error.find("period_px"), std::string::npos) << error;
  std::ofstream(dir / "patterns.json") << original;

  // A lens blur that is not a number, negative, or beyond any camera's.
  std::ifstream cameraIn(dir / "camera.json");
  const std::string camera((std::istreambuf_iterator<char>(cameraIn)),
                           std::istreambuf_iterator<char>());
  const size_t blurAt = camera.find("\"lens_blur_sigma_px\"");
  ASSERT_NE(blurAt, std::string::npos);
  for (const char* bad : {"\"lens_blur_sigma_px\": \"soft\",", "\"lens_blur_sigma_px\": -0.5,",
                          "\"lens_blur_sigma_px\": 40,"}) {
    std::string text = camera;
    text.replace(blurAt, text.find('\n', blurAt) - blurAt, bad);
    std::ofstream(dir / "camera.json") << text;
    error = errorOf(dir.string());
    EXPECT_NE(error.find("camera.json"), std::string::npos) << error;
    EXPECT_NE(error.find("lens_blur_sigma_px"), std::string::npos) << error;
  }
  std::ofstream(dir / "camera.json") << camera;
  EXPECT_EQ(errorOf(dir.string()), "");
  fs::remove_all(dir);
}

TEST(CalibrationCaptures, APictureIsSizedFromItsHeaderBeforeItIsDecoded) {
  const Small s = small();
  const fs::path dir = freshDir("plx-captures-header");
  saveCaptures(s.captures, dir.string());
  const fs::path picture = dir / "set000_c03.png";

  // A PNG whose header claims 30000x30000 grey pixels (900 MB decoded) in a few bytes: named
  // by its header's size, never handed to the decoder (which allocated the whole picture first
  // and then said only that it could not read it).
  writePngClaiming30000Squared(picture.string());
  std::string error = errorOf(dir.string());
  EXPECT_NE(error.find("set000_c03.png: is 30000x30000, the camera's pictures are 200x112"),
            std::string::npos)
      << error;

  // A JPEG's size comes from its frame header: the right size is read, another one named.
  const cv::Mat grey(112, 200, CV_8U, cv::Scalar(90));
  std::vector<unsigned char> jpeg;
  ASSERT_TRUE(cv::imencode(".jpg", grey, jpeg));
  std::ofstream(picture, std::ios::binary)
      .write(reinterpret_cast<const char*>(jpeg.data()), static_cast<std::streamsize>(jpeg.size()));
  EXPECT_EQ(errorOf(dir.string()), "");
  ASSERT_TRUE(cv::imencode(".jpg", cv::Mat(64, 80, CV_8U, cv::Scalar(90)), jpeg));
  std::ofstream(picture, std::ios::binary)
      .write(reinterpret_cast<const char*>(jpeg.data()), static_cast<std::streamsize>(jpeg.size()));
  error = errorOf(dir.string());
  EXPECT_NE(error.find("is 80x64"), std::string::npos) << error;

  // Any other format is refused by name (a BMP of the right size included).
  std::vector<unsigned char> bmp;
  ASSERT_TRUE(cv::imencode(".bmp", grey, bmp));
  std::ofstream(picture, std::ios::binary)
      .write(reinterpret_cast<const char*>(bmp.data()), static_cast<std::streamsize>(bmp.size()));
  error = errorOf(dir.string());
  EXPECT_NE(error.find("set000_c03.png: cannot read the picture: not a PNG or JPEG file"),
            std::string::npos)
      << error;
  fs::remove_all(dir);
}

TEST(CalibrationCaptures, ModuleGroupsCoverEveryModuleOnce) {
  const auto groups = moduleGroups(10, 3);
  ASSERT_EQ(groups.size(), 3u);
  EXPECT_EQ(groups[0], (std::vector<int>{0, 3, 6, 9}));
  EXPECT_EQ(groups[2], (std::vector<int>{2, 5, 8}));
  EXPECT_EQ(moduleGroups(2, 5).size(), 2u);  // never an empty group
}

// Stations along the observer line at z, `span` apart end to end (what the tape gives).
std::vector<CameraStation> stationsAcross(const DisplayModel& display, double span, int count) {
  std::vector<CameraStation> out;
  for (int i = 0; i < count; ++i)
    out.push_back({display.observer.pointAt(span * (i / (count - 1.0) - 0.5))});
  return out;
}

// The groups keep every stripe clear of its partners' lobes from every station: the presets'
// many modules keep every third apart; a 4-module display's wide lobes put modules 0 and 3
// within a few σ of each other from the end stations, so each shows its patterns alone.
TEST(CalibrationCaptures, GroupStrideKeepsAGroupsStripesApartFromEveryStation) {
  for (const std::string preset : {"demo", "default"}) {
    NominalDisplayOptions o;
    o.preset = preset;
    const DisplayModel display = makeNominalDisplay(o);
    EXPECT_EQ(groupStrideFor(display, stationsAcross(display, 3.2, 5)), 3) << preset;
  }
  NominalDisplayOptions few;
  few.preset = "demo";
  few.modules = 4;
  const DisplayModel four = makeNominalDisplay(few);
  EXPECT_EQ(groupStrideFor(four, stationsAcross(four, 2.0, 5)), 4);
  EXPECT_EQ(groupStrideFor(four, {}), 3);  // no station: nothing to keep apart
  EXPECT_EQ(groupStrideFor(four, stationsAcross(four, 2.0, 5), 9), 4);  // at most one a group
}

}  // namespace
}  // namespace parallax
