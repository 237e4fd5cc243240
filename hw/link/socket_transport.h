#pragma once
// The "simhw" transport: one Unix stream socket to parallax-simhw carrying the packets of all
// its modules. Built for throughput (>= 1 GB/s of frames on two cores): a frame goes out as
// one writev of its header, chunk headers and the caller's pixel memory (no copy in user
// space), with multi-megabyte socket buffers so the kernel moves it in few large steps.

#include <string>

#include "hw/link/link_transport.h"

namespace parallax::hw {

class SocketTransport : public LinkTransport {
 public:
  // Connect to a path...
  explicit SocketTransport(std::string path);
  // ...or adopt a connected socket (socketpair in tests); open() then fails once it closes.
  static std::unique_ptr<SocketTransport> adopt(int fd);
  ~SocketTransport() override;

  std::string name() const override { return "simhw:" + path_; }
  TransportStatus open(std::string* error) override;
  void close() override;
  bool isOpen() const override { return fd_ >= 0; }
  TransportStatus send(uint16_t module, std::span<const iovec> pieces, int timeoutMs) override;
  TransportStatus receive(std::vector<ReceivedPacket>* packets, int timeoutMs) override;
  ProtocolError lastProtocolError() const override { return lastError_; }
  uint16_t lastPeerVersion() const override { return lastPeerVersion_; }
  void setConnectTimeoutMs(int ms) override { connectTimeoutMs_ = ms; }

 private:
  std::string path_;
  int connectTimeoutMs_ = 1000;
  int fd_ = -1;
  int sendTimeoutMs_ = 0;  // what SO_SNDTIMEO is set to (0: not yet)
  bool adopted_ = false;
  PacketReader reader_;
  ProtocolError lastError_ = ProtocolError::kOk;
  uint16_t lastPeerVersion_ = 0;
  std::vector<uint8_t> readBuffer_;
};

// Sets the socket buffers large (best effort) and the send timeout (SO_SNDTIMEO: a send that
// moves no byte for this long fails with EAGAIN).
void tuneLinkSocket(int fd, int sendTimeoutMs);

}  // namespace parallax::hw
