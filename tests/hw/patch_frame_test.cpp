// Patch frames (protocol v3) through the link client and the simulated hardware: a display frame
// whose image says which bytes can differ from the frame its module shows (Image::regions) sends
// only those, and every module still shows every frame byte for byte; a module that does not show
// the patch's base, or a damaged patch, gets the frame whole.

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <random>
#include <vector>

#include "hw/link/link_client.h"
#include "sim_fixture.h"

namespace parallax::hw {
namespace {

constexpr int kWidth = 64, kHeight = 48;

SimulatedHardwareOptions twoModules() {
  SimulatedHardwareOptions o;
  o.modules = 2;
  o.width = kWidth;
  o.height = kHeight;
  o.maxChunkSize = 4096;
  return o;
}

// The region a moving object can cover: columns 20..43 of rows 10..37 (a family of images).
std::shared_ptr<const ImageRegions> centreRegions(uint64_t family) {
  auto regions = std::make_shared<ImageRegions>();
  regions->family = family;
  for (uint32_t y = 10; y < 38; ++y)
    regions->spans.push_back({(y * kWidth + 20) * 3, (y * kWidth + 44) * 3});
  return regions;
}

// A backdrop everywhere, seeded random bytes inside the region.
std::shared_ptr<const Image> frameOf(const std::shared_ptr<const ImageRegions>& regions,
                                     uint32_t seed) {
  auto f = std::make_shared<Image>();
  f->width = kWidth;
  f->height = kHeight;
  f->pixels.resize(f->byteSize());
  for (size_t i = 0; i < f->pixels.size(); ++i) f->pixels[i] = static_cast<uint8_t>(i * 7);
  std::mt19937 random(seed);
  for (const auto& [begin, end] : regions->spans)
    for (uint32_t i = begin; i < end; ++i) f->pixels[i] = static_cast<uint8_t>(random());
  f->regions = regions;
  return f;
}

// The module shows these bytes (the first that differs named, not the whole frame printed).
void expectShows(const SimulatedHardware& hardware, int module, const Image& frame) {
  const std::vector<uint8_t>& shown = hardware.shownFrame(module).pixels;
  ASSERT_EQ(shown.size(), frame.pixels.size()) << "module " << module;
  const auto [a, b] = std::mismatch(shown.begin(), shown.end(), frame.pixels.begin());
  EXPECT_TRUE(a == shown.end()) << "module " << module << " shows another byte at "
                                << (a - shown.begin());
}

// One display frame: submitted, awaited until `deadlineMs` (a module late by then is presented
// without), presented.
void play(LinkClient& link, uint32_t n, const std::vector<std::shared_ptr<const Image>>& frames,
          int deadlineMs = 5000) {
  for (size_t m = 0; m < frames.size(); ++m) link.submit(static_cast<int>(m), frames[m], n);
  link.awaitDisplayFrame(n,
                         std::chrono::steady_clock::now() + std::chrono::milliseconds(deadlineMs));
  EXPECT_TRUE(link.present(n));
}

TEST(PatchFrames, OnlyTheBytesThatCanChangeCrossAndEveryModuleShowsItsFrame) {
  InProcessSimhw sim(twoModules());
  const auto regions = centreRegions(7);
  std::vector<std::shared_ptr<const Image>> last;
  {
    LinkClient link(createLinkTransport(sim.spec()), fastLinkOptions());
    for (uint32_t n = 1; n <= 6; ++n) {
      last = {frameOf(regions, n), frameOf(regions, 100 + n)};
      play(link, n, last);
    }
    link.flush();
    // The keep-alive's echo comes after the last Present is in: the simulator shows it.
    EXPECT_TRUE(link.ping());
    const LinkStats& stats = link.stats();
    EXPECT_EQ(stats.delivered, 12u);
    EXPECT_EQ(stats.failed, 0u);
    EXPECT_EQ(stats.nacks, 0u);
    // The first frame of each module goes whole; the five after it as patches: the rows of the
    // region, 57% of the frame (the bytes between a row's span and the next's are sent too).
    EXPECT_EQ(stats.patches, 10u);
    const uint64_t whole = last[0]->pixels.size();
    EXPECT_LT(stats.payloadBytesSent, 2 * whole + 10 * whole * 6 / 10);
    EXPECT_EQ(stats.payloadBytesSent + stats.patchBytesSaved, 12 * whole);
  }
  sim.stop();
  for (int m = 0; m < 2; ++m) expectShows(sim.hardware(), m, *last[m]);
}

TEST(PatchFrames, AModuleNotShowingTheBaseOrADamagedPatchGetsTheWholeFrame) {
  InProcessSimhw sim(twoModules());
  const auto regions = centreRegions(8);
  std::vector<std::shared_ptr<const Image>> last;
  {
    LinkClient link(createLinkTransport(sim.spec()), fastLinkOptions());
    play(link, 1, {frameOf(regions, 1), frameOf(regions, 2)});
    // Module 1 hangs on display frame 2 past its Present (300 ms, the ack timeout 400): it keeps
    // showing frame 1, so display frame 3's patch (of frame 2) does not apply there.
    ASSERT_TRUE(link.injectFault(1, {FaultKind::kStall, 1, 0}));
    play(link, 2, {frameOf(regions, 3), frameOf(regions, 4)}, 300);
    // Module 0's patch for display frame 3 arrives with a byte flipped on the line.
    ASSERT_TRUE(link.injectFault(0, {FaultKind::kFlipBytes, 1, 0}));
    last = {frameOf(regions, 5), frameOf(regions, 6)};
    play(link, 3, last);
    link.flush();
    EXPECT_TRUE(link.ping());
    const LinkStats& stats = link.stats();
    EXPECT_GE(stats.patchesRefused, 1u);
    EXPECT_GE(stats.retries, 2u);
    EXPECT_EQ(stats.failed, 0u);
  }
  sim.stop();
  for (int m = 0; m < 2; ++m) expectShows(sim.hardware(), m, *last[m]);
}

TEST(PatchFrames, ImagesOfAnotherFamilyOrWithoutRegionsGoWhole) {
  InProcessSimhw sim(twoModules());
  LinkClient link(createLinkTransport(sim.spec()), fastLinkOptions());
  play(link, 1, {frameOf(centreRegions(9), 1), frameOf(centreRegions(9), 2)});
  // Another family (a new footprint): its backdrop may differ anywhere.
  play(link, 2, {frameOf(centreRegions(10), 3), frameOf(centreRegions(10), 4)});
  EXPECT_EQ(link.stats().patches, 0u);
  play(link, 3, {frameOf(centreRegions(10), 5), frameOf(centreRegions(10), 6)});
  EXPECT_EQ(link.stats().patches, 2u);
  auto plain = std::make_shared<Image>(*frameOf(centreRegions(10), 7));
  plain->regions = nullptr;
  play(link, 4, {plain, plain});
  link.flush();
  EXPECT_EQ(link.stats().patches, 2u);
  EXPECT_EQ(link.stats().failed, 0u);
}

}  // namespace
}  // namespace parallax::hw
