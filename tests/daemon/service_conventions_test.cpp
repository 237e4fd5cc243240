// The pieces of parallaxd's service conventions that need no process: the STATUS= line, the
// journal's priority prefixes, and the once-a-minute frame-loss line.

#include <gtest/gtest.h>
#include <spdlog/spdlog.h>
#include <sys/stat.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>

#include "daemon/parallaxd/frame_loss_report.h"
#include "daemon/parallaxd/journal_log_sink.h"
#include "daemon/parallaxd/systemd_notify.h"

namespace parallax::daemon {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

TEST(ServiceStatus, SaysTheStateAndStageOnOneLine) {
  StateSnapshot s;
  s.state = DaemonState::kPlaying;
  EXPECT_EQ(serviceStatusOf(s), "playing");
  s.state = DaemonState::kCalibrating;
  s.stage = "pictures: 2 of 8";
  EXPECT_EQ(serviceStatusOf(s), "calibrating: pictures: 2 of 8");
  s.state = DaemonState::kError;
  s.stage.clear();
  s.lastErrorStage = "loading the scene";
  s.lastError = "cornel.lua:3: bad\nsecond line";
  EXPECT_EQ(serviceStatusOf(s), "error: loading the scene: cornel.lua:3: bad second line");
}

TEST(JournalLog, EveryLineCarriesItsPriorityAndNoTimestamp) {
  const fs::path path =
      fs::temp_directory_path() / ("journal-" + std::to_string(::getpid()) + ".log");
  std::FILE* out = std::fopen(path.c_str(), "w");
  ASSERT_NE(out, nullptr);
  spdlog::logger logger("test", std::make_shared<JournalLogSink>(out));
  logger.set_level(spdlog::level::debug);
  logger.error("no camera");
  logger.warn("link: down");
  logger.info("installed\nsummary line");
  logger.debug("detail");
  std::fclose(out);
  std::ifstream in(path);
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  fs::remove(path);
  EXPECT_EQ(text, "<3>no camera\n<4>link: down\n<6>installed\n<6>summary line\n<7>detail\n");
}

TEST(JournalLog, StderrIsTheJournalOnlyWhenJournalStreamNamesIt) {
  const fs::path path =
      fs::temp_directory_path() / ("journal-stream-" + std::to_string(::getpid()));
  std::FILE* file = std::fopen(path.c_str(), "w");
  ASSERT_NE(file, nullptr);
  struct stat st {};
  ASSERT_EQ(::fstat(fileno(file), &st), 0);
  const std::string ours = std::to_string(st.st_dev) + ":" + std::to_string(st.st_ino);
  ::setenv("JOURNAL_STREAM", ours.c_str(), 1);
  EXPECT_TRUE(isJournalStream(fileno(file)));
  // Another stream (a child's stderr redirected to a file keeps the variable): not ours.
  ::setenv("JOURNAL_STREAM", (std::to_string(st.st_dev) + ":1").c_str(), 1);
  EXPECT_FALSE(isJournalStream(fileno(file)));
  ::setenv("JOURNAL_STREAM", (ours + "x").c_str(), 1);
  EXPECT_FALSE(isJournalStream(fileno(file)));
  ::unsetenv("JOURNAL_STREAM");
  EXPECT_FALSE(isJournalStream(fileno(file)));
  std::fclose(file);
  fs::remove(path);
}

TEST(FrameLossReport, OneLineAMinuteAndOnlyWhenFramesWereLost) {
  FrameLossReport report(60s);
  const auto t0 = FrameLossReport::Clock::time_point{} + 1000s;
  LoopStats stats;
  stats.droppedFrames = 100;  // before the first period: not this minute's
  EXPECT_EQ(report.take(stats, t0), std::nullopt);
  stats.droppedFrames += 7;
  stats.moduleFramesFailed = 3;
  stats.displayFrames = 1700;
  EXPECT_EQ(report.take(stats, t0 + 30s), std::nullopt);  // not a minute yet
  const std::optional<std::string> line = report.take(stats, t0 + 61s);
  ASSERT_TRUE(line.has_value());
  EXPECT_EQ(*line,
            "frames lost in the last 61 s: 7 dropped (the render fell behind the fps), 3 module "
            "frames failed on the link, 0 renders failed; 1700 frames rendered");
  // A clean minute says nothing; the next loss is counted from the last report.
  EXPECT_EQ(report.take(stats, t0 + 122s), std::nullopt);
  stats.renderFailures = 1;
  EXPECT_EQ(report.take(stats, t0 + 150s), std::nullopt);
  const std::optional<std::string> next = report.take(stats, t0 + 183s);
  ASSERT_TRUE(next.has_value());
  EXPECT_NE(next->find("0 dropped"), std::string::npos) << *next;
  EXPECT_NE(next->find("1 renders failed"), std::string::npos) << *next;
}

}  // namespace
}  // namespace parallax::daemon
