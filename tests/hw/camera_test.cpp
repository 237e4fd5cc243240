// The Camera interface: the simulated camera over the link (raw pattern, settings locked and
// carried to the simulator) and the OpenCV backend on an image sequence (colour order, and an
// honest report of the controls a file source cannot lock).

#include "hw/camera/camera.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>

#include "hw/link/link_client.h"
#include "sim_fixture.h"

namespace parallax::hw {
namespace {

TEST(SimulatedCamera, LockedSettingsReachTheSimulatorAndCapturesShowThePattern) {
  SimulatedHardwareOptions o;
  o.modules = 2;
  o.width = 16;
  o.height = 8;
  o.maxChunkSize = 4096;
  InProcessSimhw sim(o);
  {
    LinkClient link(createLinkTransport(sim.spec()));
    auto pattern = std::make_shared<Image>();
    pattern->width = 16;
    pattern->height = 8;
    pattern->pixels.resize(pattern->byteSize());
    for (size_t i = 0; i < pattern->pixels.size(); ++i)
      pattern->pixels[i] = static_cast<uint8_t>(i * 7);
    ASSERT_TRUE(link.setMode(DisplayMode::kPattern));
    link.submit(1, pattern);
    link.flush();

    SimulatedCamera camera(link, 1);
    std::string error;
    EXPECT_FALSE(camera.lock({0, 1.0, 1.0, 1.0}).ok);  // zero exposure is not a setting
    CameraSettings s;
    s.exposureUs = 20000;
    s.gain = 2.5;
    s.whiteBalanceRed = 1.25;
    s.whiteBalanceBlue = 0.8;
    ASSERT_TRUE(camera.lock(s).ok);
    EXPECT_TRUE(camera.locked());
    const Image seen = camera.capture(&error);
    ASSERT_FALSE(seen.empty()) << error;
    EXPECT_EQ(seen.pixels, pattern->pixels);
    camera.setViewModule(0);  // shows nothing yet
    EXPECT_TRUE(camera.capture(&error).empty());
    EXPECT_NE(error.find("module 0"), std::string::npos);
  }
  sim.stop();
  const CameraSettings& got = sim.hardware().cameraSettings();
  EXPECT_EQ(got.exposureUs, 20000u);
  EXPECT_DOUBLE_EQ(got.gain, 2.5);
  EXPECT_DOUBLE_EQ(got.whiteBalanceRed, 1.25);
  EXPECT_DOUBLE_EQ(got.whiteBalanceBlue, 0.8);
}

TEST(OpenCvCamera, MissingSourceIsOneClearLine) {
  OpenCvCamera camera;
  std::string error;
  EXPECT_FALSE(camera.open("/nonexistent/camera_%02d.png", &error));
  EXPECT_NE(error.find("cannot open camera"), std::string::npos) << error;
  EXPECT_EQ(error.find('\n'), std::string::npos);
  EXPECT_TRUE(camera.capture(&error).empty());
}

TEST(OpenCvCamera, ImageSequenceDeliversRgbAndReportsUnlockableControls) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("plx-cam-" + std::to_string(getpid()));
  fs::create_directories(dir);
  cv::Mat bgr(4, 6, CV_8UC3, cv::Scalar(10, 20, 30));  // B=10 G=20 R=30
  ASSERT_TRUE(cv::imwrite((dir / "frame_00.png").string(), bgr));
  ASSERT_TRUE(cv::imwrite((dir / "frame_01.png").string(), bgr));
  OpenCvCamera camera;
  std::string error;
  ASSERT_TRUE(camera.open((dir / "frame_%02d.png").string(), &error)) << error;
  const CameraLockResult lock = camera.lock(CameraSettings{});
  EXPECT_FALSE(lock.ok);  // a file has no exposure control: said, not hidden
  EXPECT_FALSE(lock.unlocked.empty());
  EXPECT_NE(lock.describe().find("exposure"), std::string::npos) << lock.describe();
  // Focus and white balance are locked too, and read back: held where the camera has them.
  EXPECT_NE(lock.describe().find("autofocus off"), std::string::npos) << lock.describe();
  EXPECT_NE(lock.describe().find("focus (the backend refuses the property)"), std::string::npos)
      << lock.describe();
  EXPECT_NE(lock.describe().find("white balance temperature"), std::string::npos)
      << lock.describe();
  EXPECT_FALSE(camera.locked());
  const Image image = camera.capture(&error);
  ASSERT_FALSE(image.empty()) << error;
  EXPECT_EQ(image.width, 6);
  EXPECT_EQ(image.height, 4);
  EXPECT_EQ(image.pixels[0], 30);  // red first
  EXPECT_EQ(image.pixels[1], 20);
  EXPECT_EQ(image.pixels[2], 10);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace parallax::hw
