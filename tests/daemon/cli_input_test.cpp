// The `parallax` tool refuses what the daemon refuses, naming the option (issue 18, defects
// 14 and 15): a viewer beyond ±100 m or not a number is blamed on its own option, and
// `parallax calibrate` refuses captures of a different display (module count) before any
// fitting, naming both counts, for a captures folder of pictures and for decoded.json alike.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <sstream>
#include <string>

#include "calibration/display/display_model_json.h"
#include "calibration/display/display_presets.h"
#include "tests/daemon/shell_command.h"

namespace parallax {
namespace {

namespace fs = std::filesystem;

std::pair<int, std::string> run(const std::string& command) {
  return testing::runShellCommand(command);
}

class CliInput : public ::testing::Test {
 protected:
  void SetUp() override {
    folder_ = fs::temp_directory_path() /
              ("plx-cli-" + std::to_string(::getpid()) + "-" +
               ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(folder_);
    fs::create_directories(folder_ / "frames");
  }
  void TearDown() override { fs::remove_all(folder_); }
  std::string displayFile(int modules) const {
    NominalDisplayOptions o;
    o.preset = "demo";
    o.modules = modules;
    o.width = 64;
    o.height = 48;
    const std::string path = (folder_ / ("display_" + std::to_string(modules) + ".json")).string();
    saveDisplayModel(makeNominalDisplay(o), path);
    return path;
  }
  fs::path folder_;
};

TEST_F(CliInput, ViewRefusesAViewerBeyondTheDaemonsRangeNamingTheOption) {
  const std::string view =
      std::string(PARALLAX_PATH) + " view --frames " + (folder_ / "frames").string();
  for (const auto& [option, value] : {std::pair<std::string, std::string>{"--x", "1e30"},
                                      {"--x", "nan"},
                                      {"--x", "-101"},
                                      {"--y", "inf"},
                                      {"--z", "1e9"}}) {
    const std::string x = option == "--x" ? "" : " --x 0";  // --x is required
    const auto [code, out] =
        run(view + x + " " + option + " " + value + " --out " + (folder_ / "v.png").string());
    EXPECT_NE(code, 0) << option << " " << value << ": " << out;
    EXPECT_NE(out.find(option + ": must be a number within ±100 m"), std::string::npos)
        << option << " " << value << ": " << out;
    EXPECT_FALSE(fs::exists(folder_ / "v.png"));
  }
}

TEST_F(CliInput, CalibrateRefusesCapturesOfADifferentDisplay) {
  const std::string four = displayFile(4), six = displayFile(6);
  const std::string parallax = PARALLAX_PATH;
  const fs::path pictures = folder_ / "pictures", decoded = folder_ / "decoded";
  auto [code, out] =
      run(parallax + " simulate --display " + four + " --seed 3 --stations 2 --boards 0 " +
          "--camera-resolution 320x180 --out " + pictures.string());
  ASSERT_EQ(code, 0) << out;
  std::tie(code, out) = run(parallax + " simulate --display " + four +
                            " --seed 3 --stations 3 --synthetic --out " + decoded.string());
  ASSERT_EQ(code, 0) << out;
  for (const fs::path& captures : {pictures, decoded}) {
    const fs::path calibration = folder_ / "calibration.json";
    std::tie(code, out) = run(parallax + " calibrate --captures " + captures.string() +
                              " --nominal " + six + " --out " + calibration.string());
    EXPECT_NE(code, 0) << out;
    EXPECT_NE(out.find("the captures show 4 modules"), std::string::npos) << out;
    EXPECT_NE(out.find("has 6"), std::string::npos) << out;
    EXPECT_FALSE(fs::exists(calibration));
  }
}

// A truncated camera picture stops `parallax calibrate` with one line naming the picture and
// where it ends, and nothing from the image library (issue 18, item 18).
TEST_F(CliInput, ATruncatedPictureIsOneLineNamingIt) {
  const std::string parallax = PARALLAX_PATH;
  const fs::path pictures = folder_ / "pictures";
  auto [code, out] =
      run(parallax + " simulate --display " + displayFile(4) + " --seed 5 --stations 2 " +
          "--boards 0 --camera-resolution 320x180 --out " + pictures.string());
  ASSERT_EQ(code, 0) << out;
  const fs::path victim = pictures / "set001_c02.png";
  ASSERT_TRUE(fs::exists(victim));
  fs::resize_file(victim, fs::file_size(victim) * 2 / 3);
  // stdout is dropped; on stderr, the stage lines (`calibrate [i/n] ...`) come before the error.
  std::tie(code, out) = run("(" + parallax + " calibrate --captures " + pictures.string() +
                            " --out " + (folder_ / "calibration.json").string() + " >/dev/null)");
  EXPECT_NE(code, 0);
  std::istringstream lines(out);
  int errorLines = 0, otherLines = 0;
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("parallax: ", 0) == 0)
      ++errorLines;
    else if (line.rfind("calibrate [", 0) != 0)
      ++otherLines;
  }
  EXPECT_EQ(errorLines, 1) << out;
  EXPECT_EQ(otherLines, 0) << out;
  EXPECT_NE(out.find(victim.string() + ": the PNG is truncated"), std::string::npos) << out;
  EXPECT_EQ(out.find("libpng"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(folder_ / "calibration.json"));
}

}  // namespace
}  // namespace parallax
