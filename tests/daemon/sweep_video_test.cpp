// `parallax view --sweep X0:X1 --out sweep.mp4`: the video a viewer walking the observer line
// sees decodes (OpenCV's FFmpeg reader) to the frames and size asked for, and its first and last
// frames differ (the viewer moved); `render --time A:B` sequences play along the sweep; bad ranges
// and extensions are refused naming the option (exit 1, as every InputError), contradictory options
// are usage errors (exit 2).

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>
#include <string>

#include "tests/daemon/shell_command.h"

namespace parallax {
namespace {

namespace fs = std::filesystem;

class SweepVideo : public ::testing::Test {
 protected:
  void SetUp() override {
    folder_ = fs::temp_directory_path() /
              ("plx-sweep-" + std::to_string(::getpid()) + "-" +
               ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(folder_);
    fs::create_directories(folder_);
    display_ = (folder_ / "small.json").string();
    auto [code, out] = testing::runShellCommand(
        std::string(PARALLAX_PATH) + " display --modules 3 --resolution 64x48 --out " + display_);
    ASSERT_EQ(code, 0) << out;
    std::tie(code, out) = testing::runShellCommand(
        std::string(PARALLAX_PATH) + " render --quiet --display " + display_ +
        " --scene cornell --out " + (folder_ / "frames").string());
    ASSERT_EQ(code, 0) << out;
  }
  void TearDown() override { fs::remove_all(folder_); }
  std::pair<int, std::string> view(const std::string& options) {
    return testing::runShellCommand(std::string(PARALLAX_PATH) + " view --quiet --display " +
                                    display_ + " --frames " + (folder_ / "frames").string() + " " +
                                    options);
  }
  fs::path folder_;
  std::string display_;
};

TEST_F(SweepVideo, DecodesToTheFramesAndSizeAskedFor) {
  for (const char* name : {"sweep.mp4", "sweep.avi"}) {
    const std::string path = (folder_ / name).string();
    const auto [code, out] =
        view("--sweep -0.4:0.4 --sweep-frames 12 --fps 24 --size 160x90 --out " + path);
    ASSERT_EQ(code, 0) << out;
    EXPECT_NE(out.find("12 views of 160x90 at 24 fps"), std::string::npos) << out;
    cv::VideoCapture video(path, cv::CAP_FFMPEG);
    ASSERT_TRUE(video.isOpened()) << name;
    EXPECT_NEAR(video.get(cv::CAP_PROP_FPS), 24.0, 1e-6) << name;
    int frames = 0;
    cv::Mat frame, first, last;
    while (video.read(frame)) {
      EXPECT_EQ(frame.cols, 160) << name;
      EXPECT_EQ(frame.rows, 90) << name;
      if (frames == 0) first = frame.clone();
      last = frame.clone();
      ++frames;
    }
    EXPECT_EQ(frames, 12) << name;
    ASSERT_FALSE(first.empty());
    // The viewer walked 0.8 m: the picture moved (beyond the codec's own error).
    EXPECT_GT(cv::norm(first, last, cv::NORM_L1) / static_cast<double>(first.total()), 5.0) << name;
  }
}

TEST_F(SweepVideo, BadSweepsAreRefusedNamingTheOption) {
  const std::string out = " --out " + (folder_ / "s.mp4").string();
  struct Case {
    std::string options, named;
    int code;
  };
  for (const auto& [options, named, exitCode] :
       std::vector<Case>{{"--sweep 0.5" + out, "--sweep", 1},
                         {"--sweep a:b" + out, "--sweep", 1},
                         {"--sweep 0:1e9" + out, "--sweep", 1},
                         {"--sweep 0:1 --sweep-frames 1" + out, "--sweep-frames", 1},
                         {"--sweep 0:1 --out " + (folder_ / "s.gif").string(), "--out", 1},
                         {"--sweep 0:1 --x 0" + out, "--x", 2},
                         {"--out " + (folder_ / "v.png").string(), "--x or --sweep", 2}}) {
    const auto [code, text] = view(options);
    EXPECT_EQ(code, exitCode) << options << "\n" << text;
    EXPECT_NE(text.find(named), std::string::npos) << options << "\n" << text;
  }
  EXPECT_FALSE(fs::exists(folder_ / "s.mp4"));
}

// `render --time A:B --fps F` writes the sequence (frame_NNNN/ folders, both ends included); the
// sweep then plays it, one frame a view, the scene moving as the viewer walks.
TEST_F(SweepVideo, ASequenceFromRenderPlaysAlongTheSweep) {
  const fs::path sequence = folder_ / "orbit";
  auto [code, out] = testing::runShellCommand(
      std::string(PARALLAX_PATH) + " render --quiet --display " + display_ +
      " --scene orbit --time 0:0.5 --fps 8 --out " + sequence.string());
  ASSERT_EQ(code, 0) << out;
  EXPECT_NE(out.find("5 frames of 3 module(s) from t = 0 s at 8 fps, each written to"),
            std::string::npos)
      << out;
  for (int f = 0; f < 5; ++f) {
    const fs::path frame = sequence / ("frame_000" + std::to_string(f));
    EXPECT_TRUE(fs::exists(frame / "module_000.png")) << frame;
    EXPECT_TRUE(fs::exists(frame / "module_002.png")) << frame;
  }
  EXPECT_FALSE(fs::exists(sequence / "frame_0005"));
  // The orbit moved: frame 0 and frame 4 of a module differ.
  const cv::Mat first = cv::imread((sequence / "frame_0000" / "module_001.png").string());
  const cv::Mat last = cv::imread((sequence / "frame_0004" / "module_001.png").string());
  ASSERT_FALSE(first.empty());
  EXPECT_GT(cv::norm(first, last, cv::NORM_L1), 0.0);

  const std::string video = (folder_ / "orbit.mp4").string();
  std::tie(code, out) = testing::runShellCommand(
      std::string(PARALLAX_PATH) + " view --quiet --display " + display_ + " --frames " +
      sequence.string() + " --sweep -0.3:0.3 --size 96x54 --out " + video);
  ASSERT_EQ(code, 0) << out;
  cv::VideoCapture decoded(video, cv::CAP_FFMPEG);
  int frames = 0;
  cv::Mat frame;
  while (decoded.read(frame)) ++frames;
  EXPECT_EQ(frames, 5) << "one view a frame of the sequence";
  // A sequence where one view is asked for, or of another length than --sweep-frames: refused.
  std::tie(code, out) =
      testing::runShellCommand(std::string(PARALLAX_PATH) + " view --display " + display_ +
                               " --frames " + sequence.string() + " --x 0");
  EXPECT_EQ(code, 1) << out;
  EXPECT_NE(out.find("frame_NNNN"), std::string::npos) << out;
  std::tie(code, out) = testing::runShellCommand(std::string(PARALLAX_PATH) + " view --display " +
                                                 display_ + " --frames " + sequence.string() +
                                                 " --sweep 0:1 --sweep-frames 9 --out " + video);
  EXPECT_EQ(code, 1) << out;
  EXPECT_NE(out.find("--sweep-frames"), std::string::npos) << out;
  std::tie(code, out) =
      testing::runShellCommand(std::string(PARALLAX_PATH) + " render --display " + display_ +
                               " --scene orbit --time 0:1 --frames 4 --out " + sequence.string());
  EXPECT_EQ(code, 1) << out;
  EXPECT_NE(out.find("--frames"), std::string::npos) << out;
}

}  // namespace
}  // namespace parallax
