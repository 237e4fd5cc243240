// The real process model: parallax-simhw as a child process, faults armed by flag, a crash
// that kills the process, and recovery when it is started again. Plus --dump.

#include "simhw_process.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
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

// A simulator that hangs (SIGSTOP) while frames of 1024x768 fill the socket: the link is down
// within its stall limit (blocked sends, ack waits and reconnects together), turn after turn,
// instead of a send timeout plus every ack timeout of every resend; when the simulator resumes,
// frames are delivered again.
TEST(SimhwProcess, AStoppedSimulatorIsDownWithinTheStallLimitAndBackWhenResumed) {
  SimhwProcess sim({"--modules", "3", "--resolution", "1024x768"});
  LinkOptions o;
  o.stallLimitMs = 1000;
  o.linkDownRetryMs = 100;
  o.linkDownRetryMaxMs = 400;
  auto link = connectWhenUp(sim.path(), o);
  ASSERT_TRUE(link);
  const auto big = [](uint32_t seed) {
    auto f = std::make_shared<Image>();
    f->width = 1024;
    f->height = 768;
    f->pixels.assign(f->byteSize(), static_cast<uint8_t>(seed));
    return std::shared_ptr<const Image>(f);
  };
  // One display frame as the render loop plays it: push, wait briefly, present. Returns how
  // long the caller was held, in seconds.
  uint32_t displayFrame = 0;
  std::vector<FrameOutcome> outcomes;
  const auto turn = [&] {
    const auto started = std::chrono::steady_clock::now();
    ++displayFrame;
    for (int m = 0; m < 3; ++m) link->submit(m, big(displayFrame * 3 + m), displayFrame);
    link->awaitDisplayFrame(displayFrame,
                            std::chrono::steady_clock::now() + std::chrono::milliseconds(100));
    link->present(displayFrame);
    for (FrameOutcome& f : link->takeOutcomes()) outcomes.push_back(std::move(f));
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  };
  turn();
  link->flush();
  ASSERT_EQ(::kill(sim.pid(), SIGSTOP), 0);
  outcomes.clear();
  double longest = 0;
  for (int i = 0; i < 12; ++i) longest = std::max(longest, turn());
  const uint64_t hangs = link->stats().hangs;
  ::kill(sim.pid(), SIGCONT);
  // The limit is 1 s (a reconnect's connect may wait 1 s more for a hung listener); before it,
  // one blocked send alone held the caller 5 s, and each resend 2 s more per ack timeout.
  EXPECT_LT(longest, 4.0);
  EXPECT_GE(hangs, 1u);
  bool namedHung = false;
  for (const FrameOutcome& f : outcomes) {
    if (f.status == FrameStatus::kFailed && f.reason.find("it hangs") != std::string::npos)
      namedHung = true;
  }
  EXPECT_TRUE(namedHung) << (outcomes.empty() ? "no outcome" : outcomes.back().reason);

  // Resumed: the link comes back and frames are delivered again.
  bool delivered = false;
  for (int i = 0; i < 100 && !delivered; ++i) {
    outcomes.clear();
    turn();
    link->flush();
    for (FrameOutcome& f : link->takeOutcomes()) outcomes.push_back(std::move(f));
    delivered = std::any_of(outcomes.begin(), outcomes.end(), [](const FrameOutcome& f) {
      return f.status == FrameStatus::kDelivered;
    });
    if (!delivered) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_TRUE(delivered);
}

}  // namespace
}  // namespace parallax::hw
