// The real process model: parallax-simhw as a child process, faults armed by flag, a crash
// that kills the process, and recovery when it is started again. Plus --dump.

#include "simhw_process.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <random>
#include <thread>

namespace parallax::hw {
namespace {

namespace fs = std::filesystem;

// The small simulator these tests run: three 32x16 modules, 4 KiB chunks.
std::vector<std::string> small(std::vector<std::string> extra) {
  std::vector<std::string> args = {"--modules", "3",           "--resolution",
                                   "32x16",     "--max-chunk", "4096"};
  args.insert(args.end(), extra.begin(), extra.end());
  return args;
}

std::shared_ptr<const Image> frame(uint32_t seed) {
  auto f = std::make_shared<Image>();
  f->width = 32;
  f->height = 16;
  f->pixels.resize(f->byteSize());
  std::mt19937 rng(seed);
  for (auto& b : f->pixels) b = static_cast<uint8_t>(rng());
  return f;
}

LinkOptions options() {
  LinkOptions o;
  o.chunkSize = 4096;
  o.ackTimeoutMs = 1000;  // generous: the stall fault costs one of these
  o.reconnectAttempts = 2;
  o.reconnectDelayMs = 20;
  o.linkDownRetryMs = 0;
  return o;
}

TEST(SimhwProcess, FlagFaultsAreSurvivedAndDumpWritesPngs) {
  const fs::path dump = fs::temp_directory_path() / ("plx-dump-" + std::to_string(getpid()));
  fs::remove_all(dump);
  SimhwProcess sim(small({"--fault", "0:drop:1", "--fault", "1:flip:1", "--fault", "2:stall:1",
                          "--dump", dump.string()}));
  auto link = connectWhenUp(sim.path(), options());
  ASSERT_TRUE(link);
  for (int m = 0; m < 3; ++m) link->submit(m, frame(m));
  link->flush();
  for (const FrameOutcome& o : link->takeOutcomes()) {
    EXPECT_EQ(o.status, FrameStatus::kDelivered) << "module " << o.module << ": " << o.reason;
    // Each fault cost a retry (more only if the loaded machine missed an ack deadline).
    EXPECT_GE(o.attempts, 2) << "module " << o.module;
  }
  const Image seen = link->capture(1);
  EXPECT_EQ(seen.pixels, frame(1)->pixels);
  link.reset();
  EXPECT_EQ(sim.stop(), 0);
  for (int m = 0; m < 3; ++m) {
    EXPECT_TRUE(fs::exists(dump / ("module_00" + std::to_string(m) + ".png"))) << m;
  }
  fs::remove_all(dump);
}

TEST(SimhwProcess, CrashIsReportedAndTheLinkRecoversWhenRestarted) {
  auto sim = std::make_unique<SimhwProcess>(small({"--fault", "1:crash"}));
  auto link = connectWhenUp(sim->path(), options());
  ASSERT_TRUE(link);
  link->submit(0, frame(10));
  link->flush();
  const uint64_t doomed = link->submit(1, frame(11));
  link->flush();
  const int status = sim->waitExit();
  EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGABRT) << status;
  bool reported = false;
  for (const FrameOutcome& o : link->takeOutcomes()) {
    if (o.ticket != doomed) continue;
    reported = true;
    EXPECT_EQ(o.status, FrameStatus::kFailed);
    EXPECT_NE(o.reason.find("link down"), std::string::npos) << o.reason;
  }
  EXPECT_TRUE(reported);

  // A new simulator on the same socket path; the same client reconnects on its next frame.
  SimhwProcess again(small({}), sim->path());
  bool up = false;
  for (int i = 0; i < 3000 && !up; ++i) {
    SocketTransport probe(again.path());
    std::string error;
    up = probe.open(&error) == TransportStatus::kOk;
    if (!up) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_TRUE(up);
  link->submit(1, frame(12));
  link->flush();
  const auto after = link->takeOutcomes();
  ASSERT_EQ(after.size(), 1u);
  EXPECT_EQ(after[0].status, FrameStatus::kDelivered) << after[0].reason;
}

}  // namespace
}  // namespace parallax::hw
