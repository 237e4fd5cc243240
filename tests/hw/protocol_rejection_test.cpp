// Hostile packets are rejected with a specific error on both sides: the simulated device
// answers with an Error packet naming the problem and hangs up; the host's transport reports
// the problem as a ProtocolError and closes.

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstring>

#include "hw/link/crc32c.h"
#include "hw/link/link_protocol.h"
#include "hw/link/socket_transport.h"
#include "sim_fixture.h"

namespace parallax::hw {
namespace {

SimulatedHardwareOptions tiny() {
  SimulatedHardwareOptions o;
  o.modules = 2;
  o.width = 8;
  o.height = 4;
  o.maxChunkSize = 4096;
  return o;
}

int connectTo(const std::string& path) {
  const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::strncpy(addr.sun_path, path.c_str(), sizeof addr.sun_path - 1);
  EXPECT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  timeval tv{2, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  return fd;
}

void reseal(std::vector<uint8_t>& packet) {
  const uint32_t crc = crc32c(packet.data(), 28);
  for (int i = 0; i < 4; ++i) packet[28 + i] = static_cast<uint8_t>(crc >> (8 * i));
}

// Sends `bytes` to the simulator; returns the error its Error packet names (kOk if it sent
// none) and checks that it then closed the connection.
ProtocolError deviceVerdict(const std::vector<uint8_t>& bytes) {
  InProcessSimhw sim(tiny());
  const int fd = connectTo(sim.path());
  EXPECT_EQ(::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL),
            static_cast<ssize_t>(bytes.size()));
  PacketReader reader;
  ProtocolError verdict = ProtocolError::kOk;
  uint8_t buffer[4096];
  bool closed = false;
  while (!closed) {
    const ssize_t n = ::recv(fd, buffer, sizeof buffer, 0);
    if (n <= 0) {
      closed = n == 0;
      break;
    }
    std::span<const uint8_t> rest(buffer, static_cast<size_t>(n));
    while (!rest.empty()) {
      rest = rest.subspan(reader.feed(rest));
      if (reader.ready()) {
        if (reader.header().type == PacketType::kError) {
          ErrorBody e;
          EXPECT_EQ(decodeError(reader.payload(), &e), ProtocolError::kOk);
          verdict = e.error;
        }
        reader.next();
      }
    }
  }
  EXPECT_TRUE(closed) << "the device kept the connection open after a protocol error";
  ::close(fd);
  return verdict;
}

std::vector<uint8_t> setMode() {
  return encodePacket({PacketType::kSetMode, 0, kAllModules, 1, 0, 0},
                      encodeSetMode(DisplayMode::kPattern));
}

TEST(ProtocolRejection, DeviceNamesEachProblem) {
  std::vector<uint8_t> p = setMode();
  p[1] ^= 0xFF;
  EXPECT_EQ(deviceVerdict(p), ProtocolError::kBadMagic);

  p = setMode();
  p[4] = 7;
  reseal(p);
  EXPECT_EQ(deviceVerdict(p), ProtocolError::kBadVersion);
  p = setMode();
  p[4] = 1;  // a version 1 host (no swap lock)
  reseal(p);
  EXPECT_EQ(deviceVerdict(p), ProtocolError::kBadVersion);

  p = setMode();
  p[12] ^= 0x40;
  EXPECT_EQ(deviceVerdict(p), ProtocolError::kBadHeaderCrc);

  p = setMode();
  p[kHeaderSize] ^= 0x01;  // payload changed after sealing
  EXPECT_EQ(deviceVerdict(p), ProtocolError::kBadPayloadCrc);

  p = setMode();
  const uint32_t huge = kMaxPayloadSize + 1;
  for (int i = 0; i < 4; ++i) p[16 + i] = static_cast<uint8_t>(huge >> (8 * i));
  reseal(p);
  EXPECT_EQ(deviceVerdict(p), ProtocolError::kOversized);

  const std::vector<uint8_t> shortBody = {1, 0};
  EXPECT_EQ(deviceVerdict(encodePacket({PacketType::kSetMode, 0, kAllModules, 1, 0, 0}, shortBody)),
            ProtocolError::kTruncated);

  EXPECT_EQ(deviceVerdict(encodePacket({PacketType::kAck, 0, 0, 1, 0, 0}, encodeAck({1}))),
            ProtocolError::kUnexpected);
}

TEST(ProtocolRejection, DeviceSurvivesAndServesTheNextConnection) {
  InProcessSimhw sim(tiny());
  int fd = connectTo(sim.path());
  const std::vector<uint8_t> junk(64, 0xAB);
  ::send(fd, junk.data(), junk.size(), MSG_NOSIGNAL);
  uint8_t b[256];
  while (::recv(fd, b, sizeof b, 0) > 0) {
  }
  ::close(fd);
  SocketTransport transport(sim.path());
  std::string error;
  ASSERT_EQ(transport.open(&error), TransportStatus::kOk) << error;
  const std::vector<uint8_t> ping = encodePacket({PacketType::kKeepAlive, 0, 0, 5, 0, 0}, {});
  iovec piece{const_cast<uint8_t*>(ping.data()), ping.size()};
  ASSERT_EQ(transport.send(0, {&piece, 1}, 2000), TransportStatus::kOk);
  std::vector<ReceivedPacket> packets;
  ASSERT_EQ(transport.receive(&packets, 2000), TransportStatus::kOk);
  ASSERT_EQ(packets.size(), 1u);
  EXPECT_EQ(packets[0].header.type, PacketType::kKeepAlive);
  EXPECT_EQ(packets[0].header.sequence, 5u);
}

// The host side: a "device" on a socketpair sends bad bytes to the transport.
ProtocolError hostVerdict(const std::vector<uint8_t>& bytes) {
  int sv[2];
  EXPECT_EQ(::socketpair(AF_UNIX, SOCK_STREAM, 0, sv), 0);
  auto transport = SocketTransport::adopt(sv[0]);
  ::send(sv[1], bytes.data(), bytes.size(), MSG_NOSIGNAL);
  std::vector<ReceivedPacket> packets;
  const TransportStatus status = transport->receive(&packets, 1000);
  ::close(sv[1]);
  if (status != TransportStatus::kProtocolError) return ProtocolError::kOk;
  EXPECT_FALSE(transport->isOpen());
  return transport->lastProtocolError();
}

TEST(ProtocolRejection, HostNamesEachProblem) {
  const std::vector<uint8_t> good =
      encodePacket({PacketType::kAck, 0, 0, 3, 0, 0}, encodeAck({3, AckStatus::kOk, 0}));
  EXPECT_EQ(hostVerdict(good), ProtocolError::kOk);
  std::vector<uint8_t> p = good;
  p[2] = 'Q';
  EXPECT_EQ(hostVerdict(p), ProtocolError::kBadMagic);
  p = good;
  p[4] = 1;  // a version 1 device (no swap lock)
  reseal(p);
  EXPECT_EQ(hostVerdict(p), ProtocolError::kBadVersion);
  p = good;
  p[20] ^= 1;
  EXPECT_EQ(hostVerdict(p), ProtocolError::kBadHeaderCrc);
  p = good;
  p.back() ^= 1;
  EXPECT_EQ(hostVerdict(p), ProtocolError::kBadPayloadCrc);
  p = good;
  const uint32_t huge = 0xFFFFFFFFu;
  for (int i = 0; i < 4; ++i) p[16 + i] = static_cast<uint8_t>(huge >> (8 * i));
  reseal(p);
  EXPECT_EQ(hostVerdict(p), ProtocolError::kOversized);
}

}  // namespace
}  // namespace parallax::hw
