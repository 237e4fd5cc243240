#include "hw/simulator/simhw_server.h"

#include <fmt/format.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <thread>

#include "common/private_folder.h"
#include "hw/link/socket_transport.h"

namespace parallax::hw {
namespace {

// Reads from a socket through a buffer, with a way to read large runs directly into a
// destination. Every read waits in poll() so that `stop` is honoured.
class StreamReader {
 public:
  StreamReader(int fd, const std::atomic<bool>* stop) : fd_(fd), stop_(stop), buffer_(1 << 20) {}

  // Makes `n` bytes (n <= buffer size) available; false at end of stream or stop.
  bool need(size_t n) {
    if (end_ - begin_ >= n) return true;
    if (buffer_.size() - begin_ < n) {
      std::memmove(buffer_.data(), buffer_.data() + begin_, end_ - begin_);
      end_ -= begin_;
      begin_ = 0;
    }
    while (end_ - begin_ < n) {
      const ssize_t got = readSome(buffer_.data() + end_, buffer_.size() - end_);
      if (got <= 0) return false;
      end_ += static_cast<size_t>(got);
    }
    return true;
  }
  const uint8_t* data() const { return buffer_.data() + begin_; }
  void consume(size_t n) { begin_ += n; }

  // Reads exactly `n` bytes to dst: first what is buffered, then straight from the socket.
  bool readInto(uint8_t* dst, size_t n) {
    const size_t buffered = std::min(n, end_ - begin_);
    std::memcpy(dst, buffer_.data() + begin_, buffered);
    begin_ += buffered;
    size_t done = buffered;
    while (done < n) {
      const ssize_t got = readSome(dst + done, n - done);
      if (got <= 0) return false;
      done += static_cast<size_t>(got);
    }
    return true;
  }

 private:
  ssize_t readSome(uint8_t* dst, size_t n) {
    while (true) {
      if (stop_ && stop_->load()) return 0;
      // Try first, wait only when there is nothing: under load a frame arrives in many reads,
      // and a poll() before each would double the syscalls.
      const ssize_t got = ::recv(fd_, dst, n, MSG_DONTWAIT);
      if (got >= 0) return got;
      if (errno == EINTR) continue;
      if (errno != EAGAIN && errno != EWOULDBLOCK) return -1;
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 100) < 0 && errno != EINTR) return -1;
    }
  }

  int fd_;
  const std::atomic<bool>* stop_;
  std::vector<uint8_t> buffer_;
  size_t begin_ = 0, end_ = 0;
};

bool writeAll(int fd, const std::vector<uint8_t>& bytes) {
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::send(fd, bytes.data() + done, bytes.size() - done, MSG_NOSIGNAL);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    done += static_cast<size_t>(n);
  }
  return true;
}

}  // namespace

ConnectionEnd SimhwServer::serveConnection(int fd, const std::atomic<bool>* stop) {
  ++connections_;
  tuneLinkSocket(fd, 5000);
  hardware_.resetSession();
  StreamReader in(fd, stop);
  std::vector<uint8_t> replies;
  std::vector<uint8_t> payload;
  std::vector<uint8_t> scratch;
  auto finish = [&](ConnectionEnd end) {
    ::close(fd);
    return end;
  };

  while (true) {
    if (!in.need(kHeaderSize))
      return finish(stop && stop->load() ? ConnectionEnd::kStopped : ConnectionEnd::kPeerClosed);
    PacketHeader header;
    replies.clear();
    const ProtocolError headerError = decodeHeader({in.data(), kHeaderSize}, &header);
    if (headerError != ProtocolError::kOk) {
      // The stream cannot be trusted past a bad header: say why, then hang up.
      if (headerError == ProtocolError::kBadVersion) {
        std::fprintf(stderr,
                     "parallax-simhw: refused a host speaking link protocol version %u (this "
                     "device speaks version %u)\n",
                     static_cast<unsigned>(headerVersion({in.data(), kHeaderSize})),
                     static_cast<unsigned>(kLinkVersion));
      }
      SimulatedHardware::appendError(headerError, 0, &replies);
      writeAll(fd, replies);
      return finish(ConnectionEnd::kClosedByDevice);
    }
    in.consume(kHeaderSize);

    SimAction action;
    if (header.type == PacketType::kFrameChunk && header.payloadSize >= kChunkPrefixSize) {
      if (!in.need(kChunkPrefixSize)) return finish(ConnectionEnd::kPeerClosed);
      uint32_t frameSequence = 0, offset = 0;
      decodeChunkPrefix({in.data(), kChunkPrefixSize}, &frameSequence, &offset);
      in.consume(kChunkPrefixSize);
      const size_t dataSize = header.payloadSize - kChunkPrefixSize;
      uint8_t* dst = hardware_.chunkDestination(header, frameSequence, offset, dataSize);
      if (!dst) {
        scratch.resize(dataSize);
        dst = scratch.data();
      }
      if (!in.readInto(dst, dataSize)) return finish(ConnectionEnd::kPeerClosed);
      action = hardware_.finishChunk(header, frameSequence, offset, {dst, dataSize}, &replies);
    } else {
      payload.resize(header.payloadSize);
      if (!in.readInto(payload.data(), payload.size())) return finish(ConnectionEnd::kPeerClosed);
      action = hardware_.handlePacket(header, payload, &replies);
    }

    if (action.crash) {
      std::fprintf(stderr, "parallax-simhw: injected crash\n");
      std::fflush(stderr);
      ::close(fd);
      return ConnectionEnd::kCrashRequested;
    }
    if (action.sleepMicroseconds > 0) {
      std::this_thread::sleep_for(std::chrono::microseconds(action.sleepMicroseconds));
    }
    if (!replies.empty() && !writeAll(fd, replies)) return finish(ConnectionEnd::kPeerClosed);
    if (action.close) return finish(ConnectionEnd::kClosedByDevice);
  }
}

ConnectionEnd SimhwServer::listenAndServe(const std::string& path, const std::atomic<bool>& stop) {
  if (path.size() + 1 >= sizeof(sockaddr_un::sun_path)) {  // + 1: the temporary name's "~"
    throw std::runtime_error(fmt::format("socket path too long: {}", path));
  }
  const int listener = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (listener < 0) throw std::runtime_error(fmt::format("socket(): {}", std::strerror(errno)));
  // A stale socket of ours from a previous (crashed) run is replaced; anything else at the
  // path is refused. The socket is 0600 from the moment it exists.
  try {
    if (socketPathInUse(path)) ::unlink(path.c_str());
  } catch (...) {
    ::close(listener);
    throw;
  }
  if (listenPrivately(listener, path, 4) != 0) {
    const std::string reason = std::strerror(errno);
    ::close(listener);
    throw std::runtime_error(fmt::format("cannot listen on {}: {}", path, reason));
  }
  ConnectionEnd end = ConnectionEnd::kStopped;
  while (!stop.load()) {
    pollfd p{listener, POLLIN, 0};
    const int r = ::poll(&p, 1, 100);
    if (r <= 0) continue;
    const int fd = ::accept4(listener, nullptr, nullptr, SOCK_CLOEXEC);
    if (fd < 0) continue;
    end = serveConnection(fd, &stop);
    // A crash leaves things as a dying process would: nobody listens, the file stays behind.
    if (end == ConnectionEnd::kCrashRequested) {
      ::close(listener);
      return end;
    }
  }
  ::close(listener);
  ::unlink(path.c_str());
  return end;
}

}  // namespace parallax::hw
