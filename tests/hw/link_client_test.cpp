// The link end to end against the simulated hardware: delivery, dedupe, and every injected
// fault. The property under test: each submitted frame ends delivered intact (the module's
// shown bytes equal what was sent) or reported failed with a reason; nothing is lost silently.

#include "hw/link/link_client.h"

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <map>
#include <random>
#include <thread>
#include <vector>

#include "common/input_error.h"
#include "hw/link/socket_transport.h"
#include "random_frame.h"
#include "sim_fixture.h"

namespace parallax::hw {
namespace {

constexpr int kWidth = 64, kHeight = 48;  // 9216 bytes: three 4 KiB chunks and a bit

SimulatedHardwareOptions smallDisplay(int modules = 4) {
  SimulatedHardwareOptions o;
  o.modules = modules;
  o.width = kWidth;
  o.height = kHeight;
  o.maxChunkSize = 4096;
  return o;
}

LinkOptions fastOptions() { return fastLinkOptions(); }

std::shared_ptr<const Image> makeFrame(uint32_t seed) { return randomFrame(kWidth, kHeight, seed); }

std::unique_ptr<LinkClient> connect(const InProcessSimhw& sim,
                                    LinkOptions options = fastOptions()) {
  return std::make_unique<LinkClient>(createLinkTransport(sim.spec()), options);
}

// Every ticket has exactly one final outcome.
std::map<uint64_t, FrameOutcome> byTicket(const std::vector<FrameOutcome>& outcomes) {
  std::map<uint64_t, FrameOutcome> m;
  for (const FrameOutcome& o : outcomes) {
    EXPECT_TRUE(m.emplace(o.ticket, o).second) << "ticket " << o.ticket << " reported twice";
    EXPECT_NE(o.status, FrameStatus::kPending);
  }
  return m;
}

TEST(LinkClient, HelloReportsEveryModule) {
  InProcessSimhw sim(smallDisplay(5));
  auto link = connect(sim);
  ASSERT_EQ(link->modules().size(), 5u);
  EXPECT_EQ(link->modules()[4].info.serial, "SIM0004");
  EXPECT_EQ(link->modules()[0].info.width, static_cast<uint32_t>(kWidth));
  EXPECT_TRUE(link->ping());
  EXPECT_TRUE(link->setMode(DisplayMode::kPattern));
  link.reset();
  sim.stop();
  EXPECT_EQ(sim.hardware().mode(), DisplayMode::kPattern);
}

TEST(LinkClient, DeliversFramesIntactToEachModule) {
  InProcessSimhw sim(smallDisplay(4));
  auto link = connect(sim);
  std::vector<std::shared_ptr<const Image>> frames;
  for (int m = 0; m < 4; ++m) {
    frames.push_back(makeFrame(100 + m));
    link->submit(m, frames.back());
  }
  link->flush();
  const auto outcomes = byTicket(link->takeOutcomes());
  ASSERT_EQ(outcomes.size(), 4u);
  for (const auto& [ticket, o] : outcomes) EXPECT_EQ(o.status, FrameStatus::kDelivered);
  link.reset();
  sim.stop();
  for (int m = 0; m < 4; ++m) {
    EXPECT_EQ(sim.hardware().shownFrame(m).pixels, frames[m]->pixels) << "module " << m;
  }
}

TEST(LinkClient, UnchangedFramesAreNotResent) {
  InProcessSimhw sim(smallDisplay(2));
  auto link = connect(sim);
  auto a = makeFrame(1);
  auto copyOfA = std::make_shared<Image>(*a);  // same bytes, another buffer
  link->submit(0, a);
  link->submit(0, copyOfA);
  link->submit(1, copyOfA);  // other module: does not show it yet
  link->submit(0, makeFrame(2));
  link->flush();
  const auto outcomes = link->takeOutcomes();
  int skipped = 0;
  for (const FrameOutcome& o : outcomes) skipped += o.status == FrameStatus::kSkippedUnchanged;
  EXPECT_EQ(skipped, 1);
  EXPECT_EQ(link->stats().attempts, 3u);
  link.reset();
  sim.stop();
  EXPECT_EQ(sim.hardware().counters(0).framesShown, 2u);
  EXPECT_EQ(sim.hardware().counters(1).framesShown, 1u);
}

TEST(LinkClient, ANewSessionSendsTheSameBytesAgain) {
  // A device that says Hello again may have restarted with a blank image: after a reconnect
  // the same content is delivered, not skipped, and sessions() tells the caller to resubmit.
  InProcessSimhw sim(smallDisplay(1));
  auto link = connect(sim);
  EXPECT_EQ(link->sessions(), 1u);
  auto a = makeFrame(7);
  link->submit(0, a);
  link->flush();
  sim.stop();
  sim.start();
  EXPECT_TRUE(link->ping());
  EXPECT_EQ(link->sessions(), 2u);
  link->takeOutcomes();
  link->submit(0, a);
  link->flush();
  const auto outcomes = link->takeOutcomes();
  ASSERT_EQ(outcomes.size(), 1u);
  EXPECT_EQ(outcomes[0].status, FrameStatus::kDelivered) << outcomes[0].reason;
  link.reset();
  sim.stop();
  EXPECT_EQ(sim.hardware().counters(0).framesShown, 2u);
}

TEST(LinkClient, RejectsFramesTheModuleCannotTake) {
  InProcessSimhw sim(smallDisplay(1));
  auto link = connect(sim);
  auto wrong = std::make_shared<Image>();
  wrong->width = 10;
  wrong->height = 10;
  wrong->pixels.resize(300);
  EXPECT_THROW(link->submit(0, wrong), InputError);
  EXPECT_THROW(link->submit(5, makeFrame(1)), InputError);
}

// One fault, armed through the control channel on module 1 while modules 0..3 get frames.
struct FaultCase {
  const char* name;
  Fault fault;
  bool expectRetries;
};

class LinkClientFault : public ::testing::TestWithParam<FaultCase> {};

TEST_P(LinkClientFault, EveryFrameDeliveredOrReported) {
  const FaultCase& c = GetParam();
  InProcessSimhw sim(smallDisplay(4));
  auto link = connect(sim);
  ASSERT_TRUE(link->injectFault(1, c.fault));
  std::map<uint64_t, std::pair<int, std::shared_ptr<const Image>>> sent;
  std::vector<std::shared_ptr<const Image>> last(4);
  for (int round = 0; round < 3; ++round) {
    for (int m = 0; m < 4; ++m) {
      auto f = makeFrame(1000 * round + m);
      sent[link->submit(m, f)] = {m, f};
      last[m] = f;
    }
  }
  link->flush();
  const auto outcomes = byTicket(link->takeOutcomes());
  ASSERT_EQ(outcomes.size(), sent.size());  // nothing lost silently
  // Faults of a few packets are absorbed: every frame is delivered, or - when it needed a
  // resend after a newer frame for its module had been submitted - superseded, with a reason.
  // The newest frame of every module is delivered.
  std::map<int, uint64_t> newest;
  for (const auto& [ticket, o] : outcomes) newest[o.module] = std::max(newest[o.module], ticket);
  for (const auto& [ticket, o] : outcomes) {
    if (o.status == FrameStatus::kSuperseded) {
      EXPECT_NE(o.reason.find("is newer"), std::string::npos) << o.reason;
      EXPECT_NE(ticket, newest[o.module]);
    } else {
      EXPECT_EQ(o.status, FrameStatus::kDelivered) << o.reason;
    }
  }
  if (c.expectRetries) {  // the fault was felt, and handled
    EXPECT_GT(link->stats().retries + link->stats().superseded, 0u);
  }
  // After the fault the link still works: one more frame arrives on the faulty module.
  auto after = makeFrame(99);
  link->submit(1, after);
  link->flush();
  const auto tail = link->takeOutcomes();
  ASSERT_EQ(tail.size(), 1u);
  EXPECT_EQ(tail[0].status, FrameStatus::kDelivered) << tail[0].reason;
  last[1] = after;
  link.reset();
  sim.stop();
  for (int m = 0; m < 4; ++m) {
    EXPECT_EQ(sim.hardware().shownFrame(m).pixels, last[m]->pixels) << "module " << m;
  }
}

INSTANTIATE_TEST_SUITE_P(
    Faults, LinkClientFault,
    ::testing::Values(FaultCase{"drop", {FaultKind::kDropChunks, 2, 0}, true},
                      FaultCase{"flip", {FaultKind::kFlipBytes, 2, 0}, true},
                      FaultCase{"stall", {FaultKind::kStall, 1, 0}, true},
                      FaultCase{"slow", {FaultKind::kSlowLink, 6, 2000}, false},
                      FaultCase{"disconnect", {FaultKind::kDisconnect, 1, 0}, true}),
    [](const auto& param) { return std::string(param.param.name); });

TEST(LinkClient, PersistentFaultFailsTheFrameWithItsReason) {
  InProcessSimhw sim(smallDisplay(2));
  LinkOptions options = fastOptions();
  options.maxRetries = 2;
  auto link = connect(sim, options);
  ASSERT_TRUE(link->injectFault(0, {FaultKind::kFlipBytes, 100, 0}));
  const uint64_t bad = link->submit(0, makeFrame(1));
  const uint64_t good = link->submit(1, makeFrame(2));
  link->flush();
  const auto outcomes = byTicket(link->takeOutcomes());
  ASSERT_EQ(outcomes.at(bad).status, FrameStatus::kFailed);
  EXPECT_EQ(outcomes.at(bad).attempts, 3);
  EXPECT_NE(outcomes.at(bad).reason.find("CRC mismatch"), std::string::npos)
      << outcomes.at(bad).reason;
  EXPECT_EQ(outcomes.at(good).status, FrameStatus::kDelivered);
  // A failed frame is not "unchanged" next time: submitting it again sends it again.
  link->submit(0, makeFrame(1));
  link->flush();
  EXPECT_EQ(link->takeOutcomes().at(0).status, FrameStatus::kFailed);
  link.reset();
  sim.stop();
  EXPECT_TRUE(sim.hardware().shownFrame(0).empty());  // a damaged frame never shows
}

TEST(LinkClient, CrashFailsPendingFramesThenRecoversWhenTheSimulatorIsBack) {
  InProcessSimhw sim(smallDisplay(2));
  LinkOptions options = fastOptions();
  options.reconnectAttempts = 1;
  auto link = connect(sim, options);
  ASSERT_TRUE(link->injectFault(0, {FaultKind::kCrash, 1, 0}));
  const uint64_t doomed = link->submit(0, makeFrame(1));
  link->flush();
  ASSERT_TRUE(sim.waitForEnd(2000));
  EXPECT_EQ(sim.end(), ConnectionEnd::kCrashRequested);
  const auto outcomes = byTicket(link->takeOutcomes());
  ASSERT_EQ(outcomes.at(doomed).status, FrameStatus::kFailed);
  EXPECT_NE(outcomes.at(doomed).reason.find("link down"), std::string::npos)
      << outcomes.at(doomed).reason;

  // The simulator restarts (the crash fault is spent); the next frame gets through.
  sim.hardware().resetSession();
  sim.start();
  auto next = makeFrame(2);
  link->submit(0, next);
  link->flush();
  const auto after = link->takeOutcomes();
  ASSERT_EQ(after.size(), 1u);
  EXPECT_EQ(after[0].status, FrameStatus::kDelivered) << after[0].reason;
  link.reset();
  sim.stop();
  EXPECT_EQ(sim.hardware().shownFrame(0).pixels, next->pixels);
}

TEST(LinkClient, KeepAliveNoticesADeadSimulatorAndReconnectsWhenItIsBack) {
  InProcessSimhw sim(smallDisplay(1));
  LinkOptions options = fastOptions();
  options.reconnectAttempts = 1;
  auto link = connect(sim, options);
  EXPECT_TRUE(link->ping());
  sim.stop();  // closes the connection and stops listening
  EXPECT_FALSE(link->ping());
  sim.start();
  EXPECT_TRUE(link->ping());
  EXPECT_GE(link->stats().reconnects, 2u);
}

TEST(LinkClient, ADeadLinkFailsFramesAtOnceInsteadOfRetryingEachOne) {
  InProcessSimhw sim(smallDisplay(1));
  LinkOptions options = fastOptions();
  options.reconnectAttempts = 2;
  options.linkDownRetryMs = 60000;  // longer than this test
  options.linkDownRetryMaxMs = 60000;
  auto link = connect(sim, options);
  sim.stop();
  for (int i = 0; i < 10; ++i) link->submit(0, makeFrame(i));
  link->flush();
  const auto outcomes = link->takeOutcomes();
  ASSERT_EQ(outcomes.size(), 10u);
  for (const FrameOutcome& o : outcomes) {
    EXPECT_EQ(o.status, FrameStatus::kFailed);
    EXPECT_NE(o.reason.find("link down"), std::string::npos) << o.reason;
  }
  // One round of reconnect attempts (1 + reconnectAttempts), not one per frame.
  EXPECT_EQ(link->stats().reconnects, 3u);
}

// A hung device in the simulator's place: a socket at its path that takes connections (into its
// listen queue) and never answers. Returns the socket, for the caller to close.
int listenWithoutAnswering(InProcessSimhw& sim) {
  sim.stop();
  std::filesystem::remove(sim.path());
  const int hung = ::socket(AF_UNIX, SOCK_STREAM, 0);
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  std::strncpy(address.sun_path, sim.path().c_str(), sizeof address.sun_path - 1);
  EXPECT_EQ(::bind(hung, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
  EXPECT_EQ(::listen(hung, 64), 0);
  return hung;
}

// A hung device: its socket takes connections and never answers Hello. One reconnect costs at
// most its budget (not 1 + reconnectAttempts Hello waits: in a cluster every rank waits for it),
// and the pauses between reconnects grow, up to their maximum.
TEST(LinkClient, AReconnectToAHungDeviceStopsAtItsBudgetAndThePausesGrow) {
  InProcessSimhw sim(smallDisplay(1));
  LinkOptions options = fastOptions();
  options.reconnectAttempts = 10;  // 11 Hello waits of 400 ms without the budget
  options.stallLimitMs = 600;
  options.linkDownRetryMs = 50;
  options.linkDownRetryMaxMs = 150;
  auto link = connect(sim, options);
  const int hung = listenWithoutAnswering(sim);

  // Each frame after the pause of the last failed reconnect: a new reconnect, which fails.
  std::vector<std::string> reasons;
  for (int pause : {0, 60, 110, 160}) {
    std::this_thread::sleep_for(std::chrono::milliseconds(pause));
    const uint64_t before = link->stats().reconnects;
    link->submit(0, makeFrame(static_cast<uint32_t>(pause)));
    link->flush();
    const auto outcomes = link->takeOutcomes();
    ASSERT_EQ(outcomes.size(), 1u);
    EXPECT_EQ(outcomes[0].status, FrameStatus::kFailed);
    reasons.push_back(outcomes[0].reason);
    // 400 ms, then what is left of 600 ms: two Hello waits at most.
    EXPECT_GE(link->stats().reconnects - before, 1u);
    EXPECT_LE(link->stats().reconnects - before, 2u) << outcomes[0].reason;
  }
  EXPECT_NE(reasons[0].find("the device did not answer Hello"), std::string::npos) << reasons[0];
  EXPECT_NE(reasons[0].find("next try in 50 ms"), std::string::npos) << reasons[0];
  EXPECT_NE(reasons[1].find("next try in 100 ms"), std::string::npos) << reasons[1];
  EXPECT_NE(reasons[2].find("next try in 150 ms"), std::string::npos) << reasons[2];
  EXPECT_NE(reasons[3].find("next try in 150 ms"), std::string::npos) << reasons[3];
  link.reset();
  ::close(hung);
}

// Once the link is down (its device hung), a later reconnect try only asks whether the device
// is back: it waits on it downRetryBudgetMs, not a whole stall limit of Hello waits (in a
// cluster the whole display stands still that long, each try).
TEST(LinkClient, ATryOnALinkThatIsDownWaitsOnlyItsBudget) {
  InProcessSimhw sim(smallDisplay(1));
  LinkOptions options = fastOptions();
  options.ackTimeoutMs = 1000;
  options.stallLimitMs = 3000;
  options.downRetryBudgetMs = 200;
  options.linkDownRetryMs = 50;
  options.linkDownRetryMaxMs = 50;
  auto link = connect(sim, options);
  const int hung = listenWithoutAnswering(sim);
  using Clock = std::chrono::steady_clock;
  const auto tryToSend = [&](uint32_t seed) {
    const auto started = Clock::now();
    link->submit(0, makeFrame(seed));
    link->flush();
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - started).count();
    const auto outcomes = link->takeOutcomes();
    EXPECT_EQ(outcomes.size(), 1u);
    if (!outcomes.empty()) {
      EXPECT_EQ(outcomes[0].status, FrameStatus::kFailed);
      EXPECT_NE(outcomes[0].reason.find("the device did not answer Hello"), std::string::npos)
          << outcomes[0].reason;
    }
    return ms;
  };
  // The link drops and the reconnect finds a device that hangs: the stall limit's Hello waits.
  EXPECT_GE(tryToSend(1), 2000.0);
  for (uint32_t seed : {2, 3}) {
    std::this_thread::sleep_for(std::chrono::milliseconds(60));  // past the pause
    const uint64_t before = link->stats().reconnects;
    // 200 ms and what it takes to fail the frame; the whole stall limit (3000 ms) before.
    EXPECT_LT(tryToSend(seed), 1500.0);
    EXPECT_EQ(link->stats().reconnects - before, 1u);
  }
  link.reset();
  ::close(hung);
}

TEST(LinkClient, CameraCaptureReturnsTheRawPattern) {
  InProcessSimhw sim(smallDisplay(3));
  auto link = connect(sim);
  auto pattern = makeFrame(5);
  link->submit(2, pattern);
  link->flush();
  const Image seen = link->capture(2);
  EXPECT_EQ(seen.width, kWidth);
  EXPECT_EQ(seen.pixels, pattern->pixels);
  EXPECT_TRUE(link->capture(1).empty());  // module 1 shows nothing yet
}

// A peer that does not take the connection (a hung simulator whose listen queue is full) is
// given up on after [link] connect_timeout_ms, not a fixed second, and the error says how long.
TEST(LinkClient, ConnectTimeoutBoundsTheWaitForAPeerThatDoesNotAccept) {
  const std::string path =
      (std::filesystem::temp_directory_path() / ("parallax-hung-" + std::to_string(::getpid())))
          .string();
  ::unlink(path.c_str());
  const int listener = ::socket(AF_UNIX, SOCK_STREAM, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::strncpy(addr.sun_path, path.c_str(), sizeof addr.sun_path - 1);
  ASSERT_EQ(::bind(listener, reinterpret_cast<const sockaddr*>(&addr), sizeof addr), 0);
  ASSERT_EQ(::listen(listener, 0), 0);
  // Fill the queue: it never accepts, so the next blocking connect() waits.
  std::vector<int> queued;
  for (int i = 0; i < 8; ++i) {
    const int c = ::socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK, 0);
    if (::connect(c, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
      ::close(c);
      break;
    }
    queued.push_back(c);
  }
  ASSERT_FALSE(queued.empty());
  LinkOptions options;
  options.connectTimeoutMs = 200;
  const auto started = std::chrono::steady_clock::now();
  std::string error;
  try {
    LinkClient link(createLinkTransport("simhw:" + path), options);
  } catch (const std::runtime_error& e) {
    error = e.what();
  }
  const double waitedMs =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started).count();
  EXPECT_NE(error.find("does not accept connections within 200 ms"), std::string::npos) << error;
  EXPECT_LT(waitedMs, 900.0);
  for (int c : queued) ::close(c);
  ::close(listener);
  ::unlink(path.c_str());
}

}  // namespace
}  // namespace parallax::hw
