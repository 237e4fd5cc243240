// `parallax camera board|calibrate` (issue 19, item 3): the camera's intrinsics from pictures of
// a board rendered through a known camera model (the datasheet camera with a seeded
// manufacturing spread, pinhole + k1 k2), fed to the command as a picture sequence through
// OpenCV — the way a real camera's frames reach it. A checkerboard (the simulator's renderer)
// and a ChArUco board (its printed sheet, rasterized by the command's own code, photographed
// here): the intrinsics written into camera.json are the truth's within stated tolerances, and
// an existing camera.json keeps its stations. The printed board: PNG with its DPI, PDF at
// true scale.

#include <OpenImageIO/imageio.h>
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <tbb/parallel_for.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <regex>
#include <sstream>

#include "calibration/capture/calibration_board.h"
#include "calibration/simulation/checkerboard_renderer.h"
#include "calibration/simulation/seeded_random.h"
#include "calibration/simulation/simulated_session.h"
#include "shell_command.h"

namespace parallax {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// The camera as built: a 640x360 datasheet camera (fx 700 px) with the simulator's spread.
CameraIntrinsics trueCamera() {
  return cameraAsBuilt(CameraIntrinsics::centred(640, 360, 700.0, -0.05), 11);
}

class CameraCommand : public ::testing::Test {
 protected:
  void SetUp() override {
    folder_ = fs::temp_directory_path() /
              ("plx-camera-" + std::to_string(::getpid()) + "-" +
               ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(folder_);
    fs::create_directories(folder_ / "boards");
  }
  void TearDown() override { fs::remove_all(folder_); }

  void writePictures(const std::vector<cv::Mat>& pictures) {
    for (size_t i = 0; i < pictures.size(); ++i) {
      const fs::path path = folder_ / "boards" / fmt::format("board_{:02d}.png", i);
      ASSERT_TRUE(cv::imwrite(path.string(), pictures[i])) << path;
    }
  }
  // Runs `parallax camera calibrate` on the pictures; returns its output.
  std::string calibrate(const std::string& boardFlags, int views, const fs::path& out) {
    const auto [code, output] = testing::runShellCommand(
        std::string(PARALLAX_PATH) +
        " camera calibrate --camera opencv:" + (folder_ / "boards" / "board_%02d.png").string() +
        " " + boardFlags + " --views " + std::to_string(views) + " --out " + out.string());
    EXPECT_EQ(code, 0) << output;
    return output;
  }
  struct Tolerance {
    double focal, principalPx, k1;
  };
  static void expectNear(const CameraIntrinsics& truth, const fs::path& cameraJson,
                         const std::string& output, const Tolerance& tolerance) {
    std::ifstream in(cameraJson);
    ASSERT_TRUE(in) << cameraJson;
    const json j = json::parse(in);
    const json& intrinsics = j["intrinsics"];
    EXPECT_EQ(intrinsics["width"], truth.width);
    EXPECT_EQ(intrinsics["height"], truth.height);
    const double fx = intrinsics["focal_px"][0], fy = intrinsics["focal_px"][1];
    const double cx = intrinsics["principal_px"][0], cy = intrinsics["principal_px"][1];
    const double k1 = intrinsics["distortion"][0];
    EXPECT_NEAR(fx / truth.fx, 1.0, tolerance.focal) << output;
    EXPECT_NEAR(fy / truth.fy, 1.0, tolerance.focal) << output;
    EXPECT_NEAR(cx, truth.cx, tolerance.principalPx) << output;
    EXPECT_NEAR(cy, truth.cy, tolerance.principalPx) << output;
    EXPECT_NEAR(k1, truth.k1, tolerance.k1) << output;
  }

  fs::path folder_;
};

// The printed sheet photographed: each camera pixel's 4 x 4 samples traced to the board's
// plane (the checkerboard frame checkerboardPoses places: origin at the first inner corner,
// one square and the margin inside the sheet) and read from the sheet's raster.
cv::Mat photographSheet(const cv::Mat& sheet8, double dotsPerMm, double squareMm,
                        const CameraIntrinsics& in, const Eigen::Isometry3d& cameraFromBoard,
                        SeededRandom& random) {
  constexpr int kSamples = 4;
  const Eigen::Matrix3d rotation = cameraFromBoard.linear();
  const Eigen::Vector3d t = cameraFromBoard.translation();
  const Eigen::Vector3d normal = rotation.col(2);
  cv::Mat picture(in.height, in.width, CV_8U);
  std::vector<double> noise(static_cast<size_t>(in.width) * in.height);
  for (double& n : noise) n = random.normal(1.5);  // 8-bit codes
  tbb::parallel_for(0, in.height, [&](int j) {
    for (int i = 0; i < in.width; ++i) {
      double sum = 0.0;
      for (int sy = 0; sy < kSamples; ++sy) {
        for (int sx = 0; sx < kSamples; ++sx) {
          const Eigen::Vector2d n =
              in.normalized({i + (sx + 0.5) / kSamples, j + (sy + 0.5) / kSamples});
          const Eigen::Vector3d d(n.x(), n.y(), 1.0);
          const double lambda = normal.dot(t) / normal.dot(d);
          const Eigen::Vector3d p = rotation.transpose() * (lambda * d - t);
          // Sheet mm of the board point, then the raster's pixel (centres at +0.5).
          const double u = (2.0 * squareMm + 1000.0 * p.x()) * dotsPerMm - 0.5;
          const double v = (2.0 * squareMm + 1000.0 * p.y()) * dotsPerMm - 0.5;
          double reflectance = 0.15 / 0.75;  // the room behind the sheet
          if (u >= 0 && v >= 0 && u < sheet8.cols - 1 && v < sheet8.rows - 1) {
            const int u0 = static_cast<int>(u), v0 = static_cast<int>(v);
            const double a = u - u0, b = v - v0;
            const auto at = [&](int y, int x) { return sheet8.at<uint8_t>(y, x) / 255.0; };
            reflectance = (1 - a) * (1 - b) * at(v0, u0) + a * (1 - b) * at(v0, u0 + 1) +
                          (1 - a) * b * at(v0 + 1, u0) + a * b * at(v0 + 1, u0 + 1);
          }
          sum += 0.05 + 0.7 * reflectance;  // black ink 0.05, white paper 0.75
        }
      }
      const double value =
          255.0 * sum / (kSamples * kSamples) + noise[static_cast<size_t>(j) * in.width + i];
      picture.at<uint8_t>(j, i) = cv::saturate_cast<uint8_t>(value);
    }
  });
  return picture;
}

TEST_F(CameraCommand, CheckerboardPicturesGiveTheTrueIntrinsics) {
  CameraTruth camera;
  camera.intrinsics = trueCamera();
  CalibrationBoard board;  // 10x7 squares
  board.squareMm = 40.0;
  CheckerboardShotOptions shots;
  shots.pictures = 12;
  const CheckerboardCaptures captures =
      simulateCheckerboardCaptures(camera, board.checkerboard(), shots);
  std::vector<cv::Mat> pictures;
  for (const CheckerboardPicture& p : captures.pictures) pictures.push_back(p.recorded);
  pictures.push_back(pictures[0]);  // the board held still: the same view again
  writePictures(pictures);

  // An installer's camera.json: its stations stay.
  const fs::path out = folder_ / "camera.json";
  std::ofstream(out) << R"({"format": "parallax-camera", "version": 1,
    "intrinsics": {"width": 640, "height": 360},
    "stations": [{"tape_centre": [0.1, 0.0, 2.5]}], "fiducials": []})";
  const std::string output = calibrate("--square-mm 40", 20, out);
  // The live lines: each view as it is kept, the repeated one named (not kept).
  EXPECT_NE(output.find("picture 1: 54 corners, kept as view 1;"), std::string::npos) << output;
  EXPECT_NE(output.find("picture 13: 54 corners, where view 1 was"), std::string::npos) << output;
  EXPECT_NE(output.find("13 pictures, the board found in 13"), std::string::npos) << output;
  // A dozen whole views at 640x360 (corners 0.04 px RMS; σ fx 0.1%): focal lengths within
  // 0.5%, the principal point within 3 px, k1 within 0.02.
  expectNear(camera.intrinsics, out, output, {0.005, 3.0, 0.02});
  std::ifstream in(out);
  const json j = json::parse(in);
  EXPECT_EQ(j["stations"].size(), 1u) << j.dump();
}

TEST_F(CameraCommand, CharucoPicturesGiveTheTrueIntrinsics) {
  const CameraIntrinsics truth = trueCamera();
  CalibrationBoard board;
  board.kind = BoardKind::kCharuco;
  board.squareMm = 40.0;
  board.markerMm = 24.0;
  constexpr double kDotsPerMm = 8.0;
  const cv::Mat sheet = rasterizeSheet(boardSheet(board), kDotsPerMm);
  SeededRandom random(5);
  CheckerboardShotOptions shots;
  shots.pictures = 12;
  std::vector<cv::Mat> pictures;
  for (const Eigen::Isometry3d& pose :
       checkerboardPoses(board.checkerboard(), truth, shots, random)) {
    pictures.push_back(photographSheet(sheet, kDotsPerMm, board.squareMm, truth, pose, random));
  }
  writePictures(pictures);
  const fs::path out = folder_ / "camera.json";  // a new file
  const std::string output = calibrate("--board charuco --square-mm 40 --marker-mm 24", 20, out);
  // A view with fewer than 6 identified corners does not count.
  std::smatch found;
  ASSERT_TRUE(std::regex_search(
      output, found, std::regex(R"(12 pictures, the board found in (\d+), (\d+) views kept)")))
      << output;
  EXPECT_GE(std::stoi(found[2].str()), 10) << output;
  // A dozen views, many partial, of a 640x360 camera: ChArUco corners are found to 0.15 px
  // RMS here and far fewer of them, so OpenCV's own σ of fx is ~0.8%: focal lengths within
  // 1.5%, the principal point within 8 px, k1 within 0.05.
  expectNear(truth, out, output, {0.015, 8.0, 0.05});
}

TEST_F(CameraCommand, TooFewViewsIsOneLineAndWritesNothing) {
  CameraTruth camera;
  camera.intrinsics = trueCamera();
  CalibrationBoard board;
  board.squareMm = 40.0;
  CheckerboardShotOptions shots;
  shots.pictures = 2;
  const CheckerboardCaptures captures =
      simulateCheckerboardCaptures(camera, board.checkerboard(), shots);
  writePictures({captures.pictures[0].recorded, captures.pictures[1].recorded});
  const fs::path out = folder_ / "camera.json";
  const auto [code, output] = testing::runShellCommand(
      std::string(PARALLAX_PATH) + " -q camera calibrate --camera opencv:" +
      (folder_ / "boards" / "board_%02d.png").string() + " --square-mm 40 --out " + out.string());
  EXPECT_EQ(code, 1) << output;
  EXPECT_NE(output.find("at least 4"), std::string::npos) << output;
  EXPECT_FALSE(fs::exists(out));
  const auto [linkCode, linkOutput] = testing::runShellCommand(
      std::string(PARALLAX_PATH) + " camera calibrate --camera link --out " + out.string());
  EXPECT_EQ(linkCode, 1) << linkOutput;
  EXPECT_NE(linkOutput.find("--camera"), std::string::npos) << linkOutput;
  // Bad camera specs (issue 19): a device that does not exist, a pipeline that does not parse
  // — one line each, naming the camera.
  for (const std::string& spec :
       {std::string("opencv:/dev/video97"), std::string("'opencv:videotestsrc ! ! appsink'")}) {
    const auto [badCode, badOutput] =
        testing::runShellCommand(std::string(PARALLAX_PATH) + " camera calibrate --camera " + spec +
                                 " --out " + out.string());
    EXPECT_EQ(badCode, 1) << badOutput;
    EXPECT_EQ(std::count(badOutput.begin(), badOutput.end(), '\n'), 1) << badOutput;
    EXPECT_NE(badOutput.find("opencv:"), std::string::npos) << badOutput;
  }
  EXPECT_FALSE(fs::exists(out));
}

TEST_F(CameraCommand, BoardsArePrintedAtTrueScale) {
  // PNG: the DPI in the file, the sheet's size in pixels at that DPI, the board named.
  const fs::path png = folder_ / "board.png";
  const auto [code, output] =
      testing::runShellCommand(std::string(PARALLAX_PATH) +
                               " camera board --board charuco --squares 8x6 --square-mm 25 "
                               "--marker-mm 18 --dpi 200 --out " +
                               png.string());
  ASSERT_EQ(code, 0) << output;
  auto in = OIIO::ImageInput::open(png.string());
  ASSERT_TRUE(in) << output;
  const OIIO::ImageSpec& spec = in->spec();
  EXPECT_NEAR(spec.get_float_attribute("XResolution"), 200.0f, 1e-3);
  EXPECT_EQ(spec.get_string_attribute("ResolutionUnit"), "inch");
  // 8x6 squares of 25 mm and a one-square margin: 250 x 200 mm.
  EXPECT_EQ(spec.width, static_cast<int>(std::ceil(250.0 / 25.4 * 200.0)));
  EXPECT_EQ(spec.height, static_cast<int>(std::ceil(200.0 / 25.4 * 200.0)));
  EXPECT_NE(spec.get_string_attribute("ImageDescription").find("ChArUco 8x6 squares of 25 mm"),
            std::string::npos);
  in->close();
  // The printed ChArUco is found again, every corner.
  CalibrationBoard board;
  board.kind = BoardKind::kCharuco;
  board.squaresX = 8;
  board.squaresY = 6;
  board.squareMm = 25.0;
  board.markerMm = 18.0;
  const std::optional<BoardView> view =
      detectBoard(cv::imread(png.string(), cv::IMREAD_GRAYSCALE), board);
  ASSERT_TRUE(view.has_value());
  EXPECT_EQ(view->pixels.size(), static_cast<size_t>(board.cornerCount()));

  // PDF: a page of the ISO size that holds it, the squares in points (72 to the inch).
  const fs::path pdf = folder_ / "board.pdf";
  const auto [pdfCode, pdfOutput] =
      testing::runShellCommand(std::string(PARALLAX_PATH) + " camera board --out " + pdf.string());
  ASSERT_EQ(pdfCode, 0) << pdfOutput;
  std::ifstream file(pdf);
  std::stringstream text;
  text << file.rdbuf();
  const std::string bytes = text.str();
  EXPECT_EQ(bytes.rfind("%PDF-1.4", 0), 0u);
  EXPECT_NE(bytes.find("/MediaBox [0 0 841.890 595.276]"), std::string::npos);  // A4 landscape
  // A 20 mm square (the default) is 56.693 pt a side.
  EXPECT_NE(bytes.find(" 56.693 56.693 re f"), std::string::npos);
  EXPECT_NE(bytes.find("checkerboard 10x7 squares of 20 mm"), std::string::npos);
  EXPECT_NE(bytes.find("%%EOF"), std::string::npos);

  const auto [badCode, badOutput] = testing::runShellCommand(
      std::string(PARALLAX_PATH) + " camera board --out " + (folder_ / "b.jpg").string());
  EXPECT_EQ(badCode, 1) << badOutput;
  EXPECT_NE(badOutput.find("--out"), std::string::npos) << badOutput;
}

}  // namespace
}  // namespace parallax
