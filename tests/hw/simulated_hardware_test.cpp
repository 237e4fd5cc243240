// The simulated module's receive state machine, packet by packet (no transport): chunk order,
// overlaps, damaged chunks and a frame that must never replace the shown one.

#include "hw/simulator/simulated_hardware.h"

#include <gtest/gtest.h>

#include <numeric>
#include <optional>

#include "hw/link/crc32c.h"

namespace parallax::hw {
namespace {

constexpr int kW = 16, kH = 8;
constexpr size_t kSize = kW * kH * 3;  // 384 bytes

SimulatedHardware makeSim() {
  SimulatedHardwareOptions o;
  o.modules = 1;
  o.width = kW;
  o.height = kH;
  o.maxChunkSize = 4096;
  return SimulatedHardware(o);
}

std::vector<uint8_t> pixels(uint8_t seed) {
  std::vector<uint8_t> p(kSize);
  for (size_t i = 0; i < p.size(); ++i) p[i] = static_cast<uint8_t>(seed + i * 13);
  return p;
}

struct Chunk {
  uint32_t offset, size;
};

// A patch frame's fields: its base's content hash, the display frame it belongs to.
struct PatchOf {
  uint64_t baseHash = 0;
  uint32_t displayFrame = 0;
};

// Feeds one frame as packets; returns the Ack status (or nullopt when none came). With `patch`,
// a patch frame of those chunks (frameCrc over their data).
std::optional<AckStatus> upload(SimulatedHardware& sim, uint32_t seq,
                                const std::vector<uint8_t>& frame, const std::vector<Chunk>& chunks,
                                uint32_t declaredChunks = 0, std::optional<PatchOf> patch = {},
                                uint64_t contentHash = 0) {
  std::vector<uint8_t> replies;
  FrameBegin b;
  b.width = kW;
  b.height = kH;
  b.totalSize = kSize;
  b.chunkCount = declaredChunks ? declaredChunks : static_cast<uint32_t>(chunks.size());
  b.frameCrc = crc32c(frame.data(), frame.size());
  b.contentHash = contentHash;
  if (patch) {
    b.flags = kFramePatch;
    b.baseHash = patch->baseHash;
    b.displayFrame = patch->displayFrame;
    std::vector<uint8_t> sent;
    for (const Chunk& c : chunks)
      sent.insert(sent.end(), frame.begin() + c.offset, frame.begin() + c.offset + c.size);
    b.frameCrc = crc32c(sent.data(), sent.size());
  }
  sim.handlePacket({PacketType::kFrameBegin, 0, 0, seq, kFrameBeginSize,
                    crc32c(encodeFrameBegin(b).data(), kFrameBeginSize)},
                   encodeFrameBegin(b), &replies);
  for (const Chunk& c : chunks) {
    const auto prefix = encodeChunkPrefix(seq, c.offset);
    std::vector<uint8_t> payload(prefix.begin(), prefix.end());
    payload.insert(payload.end(), frame.begin() + c.offset, frame.begin() + c.offset + c.size);
    sim.handlePacket({PacketType::kFrameChunk, 0, 0, seq, static_cast<uint32_t>(payload.size()),
                      crc32c(payload.data(), payload.size())},
                     payload, &replies);
  }
  sim.handlePacket({PacketType::kFrameEnd, 0, 0, seq, 0, 0}, {}, &replies);
  if (replies.size() < kHeaderSize + kAckSize) return std::nullopt;
  Ack ack;
  EXPECT_EQ(decodeAck({replies.data() + replies.size() - kAckSize, kAckSize}, &ack),
            ProtocolError::kOk);
  EXPECT_EQ(ack.ackedSequence, seq);
  return ack.status;
}

TEST(SimulatedHardware, TakesContiguousChunksOfAnySizeInOrderOnly) {
  SimulatedHardware sim = makeSim();
  const auto frame = pixels(1);
  EXPECT_EQ(upload(sim, 1, frame, {{0, 100}, {100, 7}, {107, 277}}), AckStatus::kOk);
  EXPECT_EQ(sim.shownFrame(0).pixels, frame);
  EXPECT_EQ(upload(sim, 2, pixels(2), {{256, 128}, {0, 128}, {128, 128}}),
            AckStatus::kMissingChunks);
  EXPECT_EQ(sim.shownFrame(0).pixels, frame);
}

TEST(SimulatedHardware, IncompleteOrOverlappingFramesNeverShow) {
  SimulatedHardware sim = makeSim();
  const auto good = pixels(3);
  ASSERT_EQ(upload(sim, 1, good, {{0, 384}}), AckStatus::kOk);
  const auto bad = pixels(4);
  // A gap.
  EXPECT_EQ(upload(sim, 2, bad, {{0, 128}, {256, 128}}, 3), AckStatus::kMissingChunks);
  // Overlaps that add up to the right byte count but leave a hole.
  EXPECT_EQ(upload(sim, 3, bad, {{0, 128}, {0, 128}, {128, 128}}), AckStatus::kMissingChunks);
  // Right chunk count and byte count, and the hole holds the right bytes left over from the
  // earlier attempts: still refused, since those bytes did not come with this frame.
  EXPECT_EQ(upload(sim, 4, bad, {{0, 192}, {0, 192}}, 2), AckStatus::kMissingChunks);
  EXPECT_EQ(sim.shownFrame(0).pixels, good);
  EXPECT_EQ(sim.counters(0).framesRejected, 3u);
}

TEST(SimulatedHardware, APatchWritesItsChunksOverTheFrameShownAndNothingElse) {
  SimulatedHardware sim = makeSim();
  const std::vector<uint8_t> base = pixels(1);
  ASSERT_EQ(upload(sim, 1, base, {{0, 384}}, 0, {}, 0xABC), AckStatus::kOk);
  // Bytes 40..79 and 200..259 change; the rest is the base's.
  std::vector<uint8_t> next = base;
  for (uint32_t i = 40; i < 80; ++i) next[i] ^= 0x5A;
  for (uint32_t i = 200; i < 260; ++i) next[i] = static_cast<uint8_t>(i);
  const std::vector<Chunk> chunks = {{40, 40}, {200, 60}};
  // Not the base the module shows: refused, and the module keeps showing the base.
  EXPECT_EQ(upload(sim, 2, next, chunks, 0, PatchOf{0xABD, 1}, 0xDEF), AckStatus::kBaseMismatch);
  // Chunks that go back, or fewer than declared: never shown.
  EXPECT_EQ(upload(sim, 3, next, {{200, 60}, {40, 40}}, 0, PatchOf{0xABC, 1}, 0xDEF),
            AckStatus::kMissingChunks);
  EXPECT_EQ(upload(sim, 4, next, chunks, 3, PatchOf{0xABC, 1}, 0xDEF), AckStatus::kMissingChunks);
  std::vector<uint8_t> replies;
  sim.handlePacket({PacketType::kPresent, 0, kAllModules, 5, kPresentSize,
                    crc32c(encodePresent({1}).data(), kPresentSize)},
                   encodePresent({1}), &replies);
  EXPECT_EQ(sim.shownFrame(0).pixels, base);
  // The right base: shown on its Present, byte for byte the new frame.
  EXPECT_EQ(upload(sim, 6, next, chunks, 0, PatchOf{0xABC, 2}, 0xDEF), AckStatus::kOk);
  sim.handlePacket({PacketType::kPresent, 0, kAllModules, 7, kPresentSize,
                    crc32c(encodePresent({2}).data(), kPresentSize)},
                   encodePresent({2}), &replies);
  EXPECT_EQ(sim.shownFrame(0).pixels, next);
  EXPECT_EQ(sim.shownContentHash(0), 0xDEFu);
}

void present(SimulatedHardware& sim, uint32_t seq, uint32_t displayFrame) {
  std::vector<uint8_t> replies;
  const auto body = encodePresent({displayFrame});
  sim.handlePacket(
      {PacketType::kPresent, 0, kAllModules, seq, kPresentSize, crc32c(body.data(), kPresentSize)},
      body, &replies);
}

// The upload buffer is brought to a patch's base by copying only what the patches since its
// own frame wrote: over a run of patches in different places, with a damaged one, one late for
// its Present and a whole frame among them, every frame shown is still byte for byte the one
// sent, and most patches copy less than half the frame.
TEST(SimulatedHardware, PatchesOverRotatingBuffersShowEveryFrameExactly) {
  SimulatedHardware sim = makeSim();
  std::vector<uint8_t> frame = pixels(1);
  uint64_t hash = 100;
  uint32_t seq = 1, displayFrame = 1;
  ASSERT_EQ(upload(sim, seq++, frame, {{0, 384}}, 0, std::nullopt, hash), AckStatus::kOk);
  int partial = 0;
  for (int k = 0; k < 16; ++k) {
    // Two spans that move from frame to frame.
    const uint32_t a = static_cast<uint32_t>(17 * k % 300), b = a + 40;
    std::vector<uint8_t> next = frame;
    for (uint32_t i = a; i < a + 20; ++i) next[i] = static_cast<uint8_t>(k * 7 + i);
    for (uint32_t i = b; i < b + 30; ++i) next[i] ^= static_cast<uint8_t>(0x11 * (k + 1));
    const std::vector<Chunk> chunks = {{a, 20}, {b, 30}};
    ++hash;
    if (k == 10) {  // a whole frame among the patches, shown at once
      ASSERT_EQ(upload(sim, seq++, next, {{0, 200}, {200, 184}}, 0, std::nullopt, hash),
                AckStatus::kOk);
      ASSERT_EQ(sim.shownFrame(0).pixels, next);
      frame = next;
      continue;
    }
    if (k == 5) {  // damaged on the line: refused
      sim.arm(0, {FaultKind::kFlipBytes, 1, 0});
      EXPECT_EQ(upload(sim, seq++, next, chunks, 0, PatchOf{sim.shownContentHash(0), displayFrame},
                       hash + 5000),
                AckStatus::kCrcMismatch);
    }
    if (k == 8) {  // complete only after its Present: never shown
      present(sim, seq++, displayFrame);
      EXPECT_EQ(upload(sim, seq++, next, chunks, 0, PatchOf{sim.shownContentHash(0), displayFrame},
                       hash + 8000),
                AckStatus::kOk);
      ++displayFrame;
    }
    const uint64_t copied = sim.counters(0).patchBaseBytes;
    ASSERT_EQ(
        upload(sim, seq++, next, chunks, 0, PatchOf{sim.shownContentHash(0), displayFrame}, hash),
        AckStatus::kOk)
        << "patch " << k;
    present(sim, seq++, displayFrame++);
    ASSERT_EQ(sim.shownFrame(0).pixels, next) << "patch " << k;
    ASSERT_EQ(sim.shownContentHash(0), hash);
    partial += sim.counters(0).patchBaseBytes - copied < kSize / 2 ? 1 : 0;
    frame = next;
  }
  EXPECT_EQ(sim.counters(0).framesLate, 1u);
  EXPECT_GE(partial, 9);
}

// The base is laid under a patch's chunks at its FrameEnd: a module whose frame shown changed
// in between (here it went dark, two display frames behind) answers that it does not show the
// patch's base, and shows nothing of it.
TEST(SimulatedHardware, APatchWhoseBaseWentAwayBeforeItsEndIsRefused) {
  SimulatedHardware sim = makeSim();
  const std::vector<uint8_t> base = pixels(2);
  std::vector<uint8_t> next = base;
  for (uint32_t i = 100; i < 140; ++i) next[i] ^= 0x3C;
  ASSERT_EQ(upload(sim, 1, base, {{0, 384}}, 0, std::nullopt, 0x100), AckStatus::kOk);
  ASSERT_EQ(upload(sim, 2, next, {{100, 40}}, 0, PatchOf{0x100, 1}, 0x101), AckStatus::kOk);
  present(sim, 3, 1);
  ASSERT_EQ(sim.shownContentHash(0), 0x101u);
  // The patch for display frame 2 starts; Present(3) comes before its end: the module lags two
  // display frames and goes dark.
  std::vector<uint8_t> replies;
  FrameBegin b;
  b.width = kW;
  b.height = kH;
  b.totalSize = kSize;
  b.chunkCount = 1;
  b.flags = kFramePatch;
  b.baseHash = 0x101;
  b.displayFrame = 2;
  b.contentHash = 0x102;
  b.frameCrc = crc32c(base.data() + 100, 40);
  const auto body = encodeFrameBegin(b);
  sim.handlePacket(
      {PacketType::kFrameBegin, 0, 0, 4, kFrameBeginSize, crc32c(body.data(), kFrameBeginSize)},
      body, &replies);
  present(sim, 5, 3);
  EXPECT_EQ(sim.shownContentHash(0), 0u);  // dark
  const auto prefix = encodeChunkPrefix(4, 100);
  std::vector<uint8_t> payload(prefix.begin(), prefix.end());
  payload.insert(payload.end(), base.begin() + 100, base.begin() + 140);
  sim.handlePacket({PacketType::kFrameChunk, 0, 0, 4, static_cast<uint32_t>(payload.size()),
                    crc32c(payload.data(), payload.size())},
                   payload, &replies);
  replies.clear();
  sim.handlePacket({PacketType::kFrameEnd, 0, 0, 4, 0, 0}, {}, &replies);
  ASSERT_EQ(replies.size(), kHeaderSize + kAckSize);
  Ack ack;
  ASSERT_EQ(decodeAck({replies.data() + kHeaderSize, kAckSize}, &ack), ProtocolError::kOk);
  EXPECT_EQ(ack.status, AckStatus::kBaseMismatch);
}

TEST(SimulatedHardware, WrongResolutionIsOneBadFrameAck) {
  SimulatedHardware sim = makeSim();
  std::vector<uint8_t> replies;
  FrameBegin b;
  b.width = kW + 1;
  b.height = kH;
  b.totalSize = (kW + 1) * kH * 3;
  b.chunkCount = 1;
  const std::vector<uint8_t> body = encodeFrameBegin(b);
  sim.handlePacket(
      {PacketType::kFrameBegin, 0, 0, 7, kFrameBeginSize, crc32c(body.data(), body.size())}, body,
      &replies);
  EXPECT_TRUE(replies.empty());
  sim.handlePacket({PacketType::kFrameEnd, 0, 0, 7, 0, 0}, {}, &replies);
  ASSERT_EQ(replies.size(), kHeaderSize + kAckSize);
  Ack ack;
  ASSERT_EQ(decodeAck({replies.data() + kHeaderSize, kAckSize}, &ack), ProtocolError::kOk);
  EXPECT_EQ(ack.status, AckStatus::kBadFrame);
}

TEST(SimulatedHardware, FaultsAreCountedWhereTheyHappen) {
  SimulatedHardware sim = makeSim();
  sim.arm(0, {FaultKind::kDropChunks, 1, 0});
  EXPECT_EQ(upload(sim, 1, pixels(5), {{0, 192}, {192, 192}}), AckStatus::kMissingChunks);
  sim.arm(0, {FaultKind::kFlipBytes, 1, 0});
  EXPECT_EQ(upload(sim, 2, pixels(5), {{0, 192}, {192, 192}}), AckStatus::kCrcMismatch);
  sim.arm(0, {FaultKind::kStall, 1, 0});
  EXPECT_EQ(upload(sim, 3, pixels(5), {{0, 384}}), std::nullopt);  // shown, but never acked
  EXPECT_EQ(sim.shownFrame(0).pixels, pixels(5));
  const ModuleCounters& c = sim.counters(0);
  EXPECT_EQ(c.chunksDropped, 1u);
  EXPECT_EQ(c.bytesFlipped, 1u);
  EXPECT_EQ(c.acksStalled, 1u);
  EXPECT_EQ(c.framesShown, 1u);
}

}  // namespace
}  // namespace parallax::hw
