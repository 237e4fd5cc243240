// A display frame rendered while its modules' images go out (renderWhileSending): every
// module's image is handed to the sender once, one call at a time (the link takes one user), all
// before the call returns; and the frame the caller gets is byte for byte the one rendering it
// alone gives. A render that fails still hands out what it finished and then
// throws; a sender that fails stops being called and the frame still comes back whole.

#include "daemon/parallaxd/render_while_sending.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <set>
#include <stdexcept>
#include <thread>

#include "tests/scripts/small_display.h"
#include "tracer/scene_fixtures.h"

namespace parallax::daemon {
namespace {

const testing::SmallDisplay& display() {
  static const testing::SmallDisplay d = testing::makeSmallDisplay(64, 8);
  return d;
}

TEST(RenderWhileSending, EveryModuleIsSentOnceOneAtATimeAndTheFrameIsTheWholeOnes) {
  const PhysicalScene scene(makeShapesScene(), display().model.displayableBox);
  const DisplayFrame alone = renderDisplayFrame(scene, display().textures, RenderOptions{});
  for (int round = 0; round < 3; ++round) {
    std::multiset<size_t> sent;
    std::atomic<int> inside{0};
    bool overlapped = false;
    std::exception_ptr sendError;
    const DisplayFrame frame = renderWhileSending(
        [&](const ModuleDone& done) {
          return renderDisplayFrame(scene, display().textures, RenderOptions{}, {}, nullptr,
                                    nullptr, &done);
        },
        [&](size_t module, std::shared_ptr<const hw::Image> image) {
          overlapped = overlapped || ++inside > 1;
          sent.insert(module);
          std::this_thread::sleep_for(std::chrono::microseconds(200));  // as a socket would
          EXPECT_TRUE(image && image->pixels == alone.images[module]->pixels)
              << "module " << module;
          --inside;
        },
        &sendError);
    EXPECT_FALSE(sendError);
    EXPECT_FALSE(overlapped);
    ASSERT_EQ(frame.images.size(), alone.images.size());
    for (size_t m = 0; m < alone.images.size(); ++m) {
      EXPECT_EQ(sent.count(m), 1u) << "module " << m << ", round " << round;
      EXPECT_EQ(frame.images[m]->pixels, alone.images[m]->pixels) << "module " << m;
    }
  }
}

TEST(RenderWhileSending, AFailedRenderHandsOutWhatItFinishedThenThrows) {
  std::set<size_t> sent;
  std::exception_ptr sendError;
  EXPECT_THROW(renderWhileSending(
                   [&](const ModuleDone& done) -> DisplayFrame {
                     auto image = std::make_shared<hw::Image>();
                     done(0, image);
                     done(1, image);
                     throw std::runtime_error("module 2 failed");
                   },
                   [&](size_t module, std::shared_ptr<const hw::Image>) { sent.insert(module); },
                   &sendError),
               std::runtime_error);
  EXPECT_EQ(sent, (std::set<size_t>{0, 1}));
  EXPECT_FALSE(sendError);
}

TEST(RenderWhileSending, AFailedSendStopsTheSendingNotTheRender) {
  const PhysicalScene scene(makeShapesScene(), display().model.displayableBox);
  int calls = 0;
  std::exception_ptr sendError;
  const DisplayFrame frame = renderWhileSending(
      [&](const ModuleDone& done) {
        return renderDisplayFrame(scene, display().textures, RenderOptions{}, {}, nullptr, nullptr,
                                  &done);
      },
      [&](size_t, std::shared_ptr<const hw::Image>) {
        ++calls;
        throw std::runtime_error("the link is down");
      },
      &sendError);
  EXPECT_EQ(calls, 1);
  ASSERT_TRUE(sendError);
  EXPECT_THROW(std::rethrow_exception(sendError), std::runtime_error);
  ASSERT_EQ(frame.images.size(), display().textures.size());
  for (const auto& image : frame.images) EXPECT_TRUE(image);
}

}  // namespace
}  // namespace parallax::daemon
