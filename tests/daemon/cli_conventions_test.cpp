// Every Parallax program behaves the same on the command line (README, "Exit codes"): 0 on
// success and for --help / --version, 1 for a runtime failure, 2 for a usage error; --version
// prints the project version; --quiet leaves only the result and the errors; `parallax` with no
// other choice uses the `demo` display and never writes into the current folder unasked.

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "common/progress_bar.h"
#include "tests/daemon/shell_command.h"

namespace parallax {
namespace {

namespace fs = std::filesystem;

std::pair<int, std::string> run(const std::string& command) {
  return testing::runShellCommand(command);
}

class CliConventions : public ::testing::Test {
 protected:
  void SetUp() override {
    folder_ = fs::temp_directory_path() /
              ("plx-conv-" + std::to_string(::getpid()) + "-" +
               ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(folder_);
    fs::create_directories(folder_);
  }
  void TearDown() override { fs::remove_all(folder_); }
  // A 2-module demo display of 32x24, so a render takes a moment.
  std::string smallDisplay() {
    const std::string path = (folder_ / "small.json").string();
    const auto [code, out] =
        run(std::string(PARALLAX_PATH) + " display --modules 2 --resolution 32x24 --out " + path);
    EXPECT_EQ(code, 0) << out;
    return path;
  }
  fs::path folder_;
};

TEST_F(CliConventions, EveryProgramPrintsItsVersion) {
  for (const auto& [program, name] :
       {std::pair{std::string(PARALLAX_PATH), std::string("parallax ")},
        std::pair{std::string(PARALLAXD_PATH), std::string("parallaxd ")},
        std::pair{std::string(PARALLAX_SIMHW_PATH), std::string("parallax-simhw ")}}) {
    const auto [code, out] = run(program + " --version");
    EXPECT_EQ(code, 0) << program << ": " << out;
    EXPECT_EQ(out.rfind(name + PARALLAX_PROJECT_VERSION, 0), 0u) << program << ": " << out;
  }
}

TEST_F(CliConventions, UsageErrorsExit2RuntimeFailuresExit1) {
  const std::string parallax = PARALLAX_PATH;
  // Usage: an unknown option, a missing value, a value of the wrong type, no command at all.
  for (const std::string args : {"render --bogus", "render", "display --modules many", "",
                                 "ctl --socket", "ctl --timeout soon status"}) {
    const auto [code, out] = run(parallax + " " + args);
    EXPECT_EQ(code, 2) << "parallax " << args << ": " << out;
  }
  for (const std::string& program :
       {std::string(PARALLAXD_PATH), std::string(PARALLAX_SIMHW_PATH)}) {
    const auto [code, out] = run(program + " --bogus");
    EXPECT_EQ(code, 2) << program << ": " << out;
  }
  // Runtime: a display file that does not exist, a folder that cannot be written, no daemon.
  const std::string missing = (folder_ / "missing.json").string();
  for (const std::string& args :
       {"render --display " + missing + " --scene cornell --out " + (folder_ / "r").string(),
        "display --out " + (folder_ / "no" / "such" / "folder" / "d.json").string(),
        "ctl --socket " + (folder_ / "nobody.sock").string() + " status"}) {
    const auto [code, out] = run(parallax + " " + args);
    EXPECT_EQ(code, 1) << "parallax " << args << ": " << out;
    EXPECT_NE(out.find("parallax"), std::string::npos) << out;
  }
  // The whole tool takes `ctl` too, its request words its own (no daemon: a runtime failure).
  const auto [toolsCode, toolsOut] = run(std::string(PARALLAX_TOOLS_PATH) + " ctl --socket " +
                                         (folder_ / "nobody.sock").string() + " status");
  EXPECT_EQ(toolsCode, 1) << toolsOut;
  EXPECT_NE(toolsOut.find("no daemon at"), std::string::npos) << toolsOut;
  // Help is not an error.
  EXPECT_EQ(run(parallax + " --help").first, 0);
  EXPECT_EQ(run(parallax + " ctl --help").first, 0);
}

TEST_F(CliConventions, QuietLeavesTheResultAndNoProgress) {
  const std::string display = smallDisplay();
  const std::string render = std::string(PARALLAX_PATH) + " render --display " + display +
                             " --scene cornell --out " + (folder_ / "frames").string();
  const auto [code, out] = run(render);
  ASSERT_EQ(code, 0) << out;
  EXPECT_NE(out.find("render:"), std::string::npos) << out;  // the progress lines
  const auto [quietCode, quietOut] = run(render + " --quiet");
  ASSERT_EQ(quietCode, 0) << quietOut;
  EXPECT_EQ(quietOut.find("render:"), std::string::npos) << quietOut;
  EXPECT_EQ(quietOut.find("render ["), std::string::npos) << quietOut;
  EXPECT_NE(quietOut.find("written to"), std::string::npos) << quietOut;  // the result stays
  EXPECT_TRUE(fs::exists(folder_ / "frames" / "module_001.png"));
  // `parallax -q ctl`: nothing on success would be printed; an error still is, and exits 1.
  const auto [ctlCode, ctlOut] = run(std::string(PARALLAX_PATH) + " ctl -q --socket " +
                                     (folder_ / "none.sock").string() + " status");
  EXPECT_EQ(ctlCode, 1);
  EXPECT_NE(ctlOut.find("none.sock"), std::string::npos) << ctlOut;
}

TEST_F(CliConventions, OneDefaultDisplayAndNoSilentWritesIntoTheCurrentFolder) {
  // `display` and `render` default to the same display: demo.
  const auto [code, out] = run(std::string(PARALLAX_PATH) + " display");
  ASSERT_EQ(code, 0) << out;
  EXPECT_NE(out.find("\"name\": \"demo\""), std::string::npos) << out.substr(0, 400);
  // `render` without --out writes into parallax-render/ of the current folder, and says so.
  const std::string display = smallDisplay();
  const auto [renderCode, renderOut] =
      run("cd " + folder_.string() + " && " + PARALLAX_PATH + " render --quiet --display " +
          display + " --scene cornell");
  ASSERT_EQ(renderCode, 0) << renderOut;
  EXPECT_TRUE(fs::exists(folder_ / "parallax-render" / "module_000.png")) << renderOut;
  EXPECT_FALSE(fs::exists(folder_ / "module_000.png"));
  EXPECT_NE(renderOut.find((folder_ / "parallax-render").string()), std::string::npos) << renderOut;
  // `view` likewise, into parallax-view/.
  const auto [viewCode, viewOut] =
      run("cd " + folder_.string() + " && " + PARALLAX_PATH + " view --display " + display +
          " --frames parallax-render --x 0");
  ASSERT_EQ(viewCode, 0) << viewOut;
  EXPECT_TRUE(fs::exists(folder_ / "parallax-view" / "view.png")) << viewOut;
  EXPECT_FALSE(fs::exists(folder_ / "view.png"));
  EXPECT_NE(viewOut.find((folder_ / "parallax-view" / "view.png").string()), std::string::npos)
      << viewOut;
}

TEST(ProgressTimeLeft, SaysHowLongIsLeftAtTheRateSoFarOnceASecondHasPassed) {
  EXPECT_EQ(ProgressBar::timeLeft(0.25, 10.0), "~30s left");
  EXPECT_EQ(ProgressBar::timeLeft(0.1, 13.0), "~1m57s left");
  EXPECT_EQ(ProgressBar::timeLeft(0.5, 0.5), "");  // too early to say
  EXPECT_EQ(ProgressBar::timeLeft(0.0, 5.0), "");  // no rate yet
  EXPECT_EQ(ProgressBar::timeLeft(1.0, 5.0), "");  // done
}

TEST_F(CliConventions, SimulateShowsItsStepsWithProgress) {
  const std::string display = smallDisplay();
  const std::string simulate = std::string(PARALLAX_PATH) + " simulate --display " + display +
                               " --seed 1 --stations 1 --boards 0 --camera-resolution 160x90" +
                               " --out " + (folder_ / "session").string();
  const auto [code, out] = run(simulate);
  ASSERT_EQ(code, 0) << out;
  // Not a tty: a line every 10% of the pictures, then the step that cannot report progress.
  EXPECT_NE(out.find("simulate [1/2] "), std::string::npos) << out;
  EXPECT_NE(out.find("pattern pictures: 100%"), std::string::npos) << out;
  EXPECT_NE(out.find("simulate [2/2] writing the pictures ... "), std::string::npos) << out;
  const auto [quietCode, quietOut] = run(simulate + " --quiet");
  ASSERT_EQ(quietCode, 0) << quietOut;
  EXPECT_EQ(quietOut.find("simulate ["), std::string::npos) << quietOut;
}

}  // namespace
}  // namespace parallax
