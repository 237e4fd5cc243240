// Protocol v2's swap lock against the simulated hardware: a module acknowledges a complete frame
// of display frame N and shows it only on Present(N); a module late for N keeps its frame for one
// display frame and then goes dark, so no two modules ever show moments more than a display frame
// apart; an unchanged frame is acknowledged for N without its bytes; a version 1 device is refused
// with a message naming both versions.

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <map>
#include <set>
#include <thread>

#include "hw/link/crc32c.h"
#include "hw/link/link_client.h"
#include "random_frame.h"
#include "sim_fixture.h"

namespace parallax::hw {
namespace {

constexpr int kWidth = 64, kHeight = 48;

SimulatedHardwareOptions threeModules() {
  SimulatedHardwareOptions o;
  o.modules = 3;
  o.width = kWidth;
  o.height = kHeight;
  o.maxChunkSize = 4096;
  return o;
}

// A stalled frame is given up (superseded) after the ack timeout, 400 ms.
LinkOptions fastOptions() { return fastLinkOptions(); }

// One display frame: every module's frame submitted for `n`, the late ones awaited until the
// deadline, then presented.
std::vector<int> playDisplayFrame(LinkClient& link, uint32_t n,
                                  const std::vector<std::shared_ptr<const Image>>& frames) {
  for (size_t m = 0; m < frames.size(); ++m) link.submit(static_cast<int>(m), frames[m], n);
  // Far below the ack timeout (a stalled frame is late, not yet given up), far above a small
  // frame's round trip even on a loaded machine.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(300);
  std::vector<int> late = link.awaitDisplayFrame(n, deadline);
  EXPECT_TRUE(link.present(n));
  return late;
}

// What each module shows after each Present, from the simulator's record.
std::map<uint32_t, std::map<int, PresentRecord>> recordByFrame(const SimulatedHardware& hw) {
  std::map<uint32_t, std::map<int, PresentRecord>> byFrame;
  for (const PresentRecord& r : hw.presents()) byFrame[r.displayFrame][r.module] = r;
  return byFrame;
}

TEST(SwapLock, ModulesShowAFrameOnlyOnItsPresentAndALateOneLagsOneFrameThenGoesDark) {
  InProcessSimhw sim(threeModules());
  LinkClient link(createLinkTransport(sim.spec()), fastOptions());
  std::vector<std::vector<std::shared_ptr<const Image>>> frames(8);
  for (uint32_t n = 1; n <= 7; ++n) {
    for (uint32_t m = 0; m < 3; ++m) frames[n].push_back(randomFrame(kWidth, kHeight, n * 10 + m));
  }
  frames[5] = frames[4];  // display frame 5 shows what 4 showed: no pixels travel

  std::map<uint32_t, std::vector<int>> late;
  late[1] = playDisplayFrame(link, 1, frames[1]);
  ASSERT_TRUE(link.injectFault(2, {FaultKind::kStall, 2, 0}));  // module 2 hangs on 2 frames
  for (uint32_t n = 2; n <= 6; ++n) late[n] = playDisplayFrame(link, n, frames[n]);
  // Display frame 7 is complete and acknowledged everywhere, but never presented.
  for (int m = 0; m < 3; ++m) link.submit(m, frames[7][static_cast<size_t>(m)], 7);
  EXPECT_TRUE(link.awaitDisplayFrame(7, std::chrono::steady_clock::now() + std::chrono::seconds(5))
                  .empty());
  link.flush();
  int reused = 0;
  for (const FrameOutcome& o : link.takeOutcomes()) {
    reused += o.status == FrameStatus::kSkippedUnchanged;
    EXPECT_NE(o.status, FrameStatus::kFailed) << o.reason;
  }
  EXPECT_EQ(reused, 3) << "display frame 5: every module told to keep its frame";

  EXPECT_TRUE(late[1].empty());
  EXPECT_EQ(late[2], std::vector<int>{2});
  EXPECT_EQ(late[3], std::vector<int>{2});
  EXPECT_TRUE(late[4].empty());
  EXPECT_TRUE(late[6].empty());

  sim.stop();
  const SimulatedHardware& hw = sim.hardware();
  auto byFrame = recordByFrame(hw);
  ASSERT_EQ(byFrame.size(), 6u);
  for (uint32_t n = 1; n <= 6; ++n) {
    ASSERT_EQ(byFrame[n].size(), 3u) << "display frame " << n;
    // The rule: after every Present, each module shows N, N-1, or is dark.
    for (const auto& [m, r] : byFrame[n])
      EXPECT_TRUE(r.shows == n || r.shows + 1 == n || r.shows == 0) << n << " " << m;
    EXPECT_EQ(byFrame[n][0].shows, n);
    EXPECT_EQ(byFrame[n][1].shows, n);
  }
  EXPECT_EQ(byFrame[2][2].shows, 1u) << "late once: keeps the previous frame";
  EXPECT_FALSE(byFrame[2][2].switched);
  EXPECT_EQ(byFrame[3][2].shows, 0u) << "late twice: dark rather than two frames behind";
  EXPECT_TRUE(byFrame[3][2].switched);
  EXPECT_EQ(byFrame[4][2].shows, 4u) << "back in step with its next frame";
  EXPECT_EQ(byFrame[5][2].shows, 5u);
  EXPECT_EQ(hw.counters(2).blanked, 1u);
  // The modules switch together: one clock reading per Present on one simulator.
  for (uint32_t n : {1u, 4u, 5u, 6u}) {
    EXPECT_EQ(byFrame[n][0].atNs, byFrame[n][2].atNs);
  }
  for (int m = 0; m < 3; ++m) {
    EXPECT_EQ(hw.shownDisplayFrame(m), 6u) << "frame 7 was never presented";
    EXPECT_EQ(hw.shownFrame(m).pixels, frames[6][static_cast<size_t>(m)]->pixels);
  }
}

// A device that speaks version 1: answers anything with a version 1 Error and hangs up.
class VersionOneDevice {
 public:
  VersionOneDevice()
      : path_((std::filesystem::temp_directory_path() /
               ("plx-v1-" + std::to_string(::getpid()) + ".sock"))
                  .string()) {
    std::filesystem::remove(path_);
    listener_ = ::socket(AF_UNIX, SOCK_STREAM, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::strncpy(addr.sun_path, path_.c_str(), sizeof addr.sun_path - 1);
    EXPECT_EQ(::bind(listener_, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
    EXPECT_EQ(::listen(listener_, 1), 0);
    thread_ = std::thread([this] {
      const int fd = ::accept(listener_, nullptr, nullptr);
      if (fd < 0) return;
      uint8_t header[kHeaderSize];
      (void)::recv(fd, header, sizeof header, MSG_WAITALL);
      std::vector<uint8_t> reply = encodePacket({PacketType::kError, 0, kAllModules, 0, 0, 0},
                                                encodeError({ProtocolError::kBadVersion, 0}));
      reply[4] = 1;  // version 1, resealed
      const uint32_t crc = crc32c(reply.data(), 28);
      for (int i = 0; i < 4; ++i) reply[28 + i] = static_cast<uint8_t>(crc >> (8 * i));
      (void)::send(fd, reply.data(), reply.size(), MSG_NOSIGNAL);
      ::close(fd);
    });
  }
  ~VersionOneDevice() {
    ::shutdown(listener_, SHUT_RDWR);
    thread_.join();
    ::close(listener_);
    std::filesystem::remove(path_);
  }
  std::string spec() const { return "simhw:" + path_; }

 private:
  std::string path_;
  int listener_ = -1;
  std::thread thread_;
};

TEST(SwapLock, AVersionOneDeviceIsRefusedWithBothVersionsNamed) {
  VersionOneDevice device;
  LinkOptions options = fastOptions();
  options.reconnectAttempts = 0;
  try {
    LinkClient link(createLinkTransport(device.spec()), options);
    FAIL() << "a version 1 device was accepted";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("link protocol version 1"), std::string::npos) << what;
    EXPECT_NE(what.find("version " + std::to_string(kLinkVersion)), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace parallax::hw
