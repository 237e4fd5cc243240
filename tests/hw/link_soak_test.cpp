// Many frames under a random mix of faults (fixed seed): the property of the link as a whole.
// Every ticket gets exactly one final outcome; every failure or supersession carries a reason;
// and each module ends up showing exactly the newest frame the link reported delivered for it.

#include <gtest/gtest.h>

#include <map>
#include <random>

#include "hw/link/link_client.h"
#include "sim_fixture.h"

namespace parallax::hw {
namespace {

TEST(LinkSoak, RandomFaultsNeverLoseAFrameSilently) {
  constexpr int kModules = 4, kWidth = 48, kHeight = 32, kFrames = 240;
  SimulatedHardwareOptions so;
  so.modules = kModules;
  so.width = kWidth;
  so.height = kHeight;
  so.maxChunkSize = 4096;
  InProcessSimhw sim(so);
  LinkOptions lo;
  lo.chunkSize = 4096;
  lo.ackTimeoutMs = 400;
  lo.maxRetries = 2;
  lo.reconnectDelayMs = 5;
  lo.linkDownRetryMs = 0;
  LinkClient link(createLinkTransport(sim.spec()), lo);

  std::mt19937 rng(20261123);
  std::map<uint64_t, std::pair<int, std::shared_ptr<const Image>>> sent;
  std::vector<FrameOutcome> outcomes;
  int faultsArmed = 0, stalls = 0;
  for (int i = 0; i < kFrames; ++i) {
    const int module = static_cast<int>(rng() % kModules);
    if (rng() % 6 == 0) {
      Fault f;
      const int pick = static_cast<int>(rng() % 10);
      // Stalls cost an ack timeout each: keep them rare so the test stays fast.
      f.kind = pick < 4   ? FaultKind::kDropChunks
               : pick < 8 ? FaultKind::kFlipBytes
               : pick < 9 ? FaultKind::kDisconnect
                          : (stalls < 2 ? FaultKind::kStall : FaultKind::kSlowLink);
      if (f.kind == FaultKind::kStall) ++stalls;
      f.count = 1 + rng() % 3;
      f.param = 500;
      // Armed between bursts: a control request cannot be promised while frames keep
      // dropping the link (it gets one reconnect and one retry), and that is not under test.
      link.flush();
      ASSERT_TRUE(link.injectFault(module, f)) << "fault " << i;
      ++faultsArmed;
    }
    auto frame = std::make_shared<Image>();
    frame->width = kWidth;
    frame->height = kHeight;
    frame->pixels.resize(frame->byteSize());
    for (auto& b : frame->pixels) b = static_cast<uint8_t>(rng());
    if (rng() % 8 == 0 && !sent.empty()) {  // sometimes the same content again
      const auto& previous = sent.rbegin()->second;
      if (previous.first == module) frame->pixels = previous.second->pixels;
    }
    sent[link.submit(module, frame)] = {module, frame};
    if (i % 30 == 29) link.flush();
    for (FrameOutcome& o : link.takeOutcomes()) outcomes.push_back(std::move(o));
  }
  link.flush();
  for (FrameOutcome& o : link.takeOutcomes()) outcomes.push_back(std::move(o));

  std::map<uint64_t, FrameOutcome> byTicket;
  for (const FrameOutcome& o : outcomes) {
    ASSERT_TRUE(byTicket.emplace(o.ticket, o).second) << "ticket " << o.ticket << " twice";
  }
  ASSERT_EQ(byTicket.size(), sent.size()) << "a frame without an outcome";
  std::map<int, uint64_t> newestDelivered;
  std::map<FrameStatus, int> counts;
  for (const auto& [ticket, o] : byTicket) {
    ++counts[o.status];
    ASSERT_NE(o.status, FrameStatus::kPending);
    if (o.status == FrameStatus::kFailed || o.status == FrameStatus::kSuperseded) {
      EXPECT_FALSE(o.reason.empty()) << ticket;
    }
    if (o.status == FrameStatus::kDelivered) newestDelivered[o.module] = ticket;
  }
  EXPECT_GT(faultsArmed, 20);
  EXPECT_GT(counts[FrameStatus::kDelivered], kFrames / 2);
  sim.stop();
  for (int m = 0; m < kModules; ++m) {
    if (!newestDelivered.count(m)) continue;
    // A skipped frame repeats the bytes the module already shows, so the newest delivered
    // frame's content is what it must show.
    EXPECT_EQ(sim.hardware().shownFrame(m).pixels, sent.at(newestDelivered[m]).second->pixels)
        << "module " << m;
  }
  RecordProperty("delivered", counts[FrameStatus::kDelivered]);
  RecordProperty("superseded", counts[FrameStatus::kSuperseded]);
  RecordProperty("failed", counts[FrameStatus::kFailed]);
  RecordProperty("skipped", counts[FrameStatus::kSkippedUnchanged]);
}

}  // namespace
}  // namespace parallax::hw
