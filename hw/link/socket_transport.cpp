#include "hw/link/socket_transport.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstring>

namespace parallax::hw {
void tuneLinkSocket(int fd, int sendTimeoutMs) {
  // 4 MiB each way holds a whole 1024x768 RGB8 frame; the kernel may clamp it to
  // net.core.wmem_max, which only costs throughput.
  const int bytes = 4 << 20;
  setsockopt(fd, SOL_SOCKET, SO_SNDBUF, &bytes, sizeof bytes);
  setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &bytes, sizeof bytes);
  // A peer that stops reading (a stalled device) must not block us forever.
  timeval tv{sendTimeoutMs / 1000, (sendTimeoutMs % 1000) * 1000};
  setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
}

SocketTransport::SocketTransport(std::string path)
    : path_(std::move(path)), readBuffer_(256 << 10) {}

std::unique_ptr<SocketTransport> SocketTransport::adopt(int fd) {
  auto t = std::make_unique<SocketTransport>("<socketpair>");
  t->fd_ = fd;
  t->adopted_ = true;
  tuneLinkSocket(fd, t->connectTimeoutMs_);
  t->sendTimeoutMs_ = t->connectTimeoutMs_;
  return t;
}

SocketTransport::~SocketTransport() { close(); }

TransportStatus SocketTransport::open(std::string* error) {
  close();
  if (adopted_) {
    *error = "the adopted socket was closed; it cannot be reopened";
    return TransportStatus::kUnavailable;
  }
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path_.size() >= sizeof addr.sun_path) {
    *error = fmt::format("socket path too long ({} bytes, at most {}): {}", path_.size(),
                         sizeof addr.sun_path - 1, path_);
    return TransportStatus::kUnavailable;
  }
  std::memcpy(addr.sun_path, path_.c_str(), path_.size() + 1);
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    *error = fmt::format("socket(): {}", std::strerror(errno));
    return TransportStatus::kUnavailable;
  }
  // A simulator that hangs (stopped, or stuck) stops accepting: once its listen backlog is full
  // a blocking connect() would wait forever. Linux bounds a Unix socket's connect() by the send
  // timeout, so connect with a short one (a local peer answers at once or is hung).
  timeval connectTimeout{connectTimeoutMs_ / 1000, (connectTimeoutMs_ % 1000) * 1000};
  setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &connectTimeout, sizeof connectTimeout);
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    const bool hung = errno == EAGAIN || errno == EWOULDBLOCK;
    *error = hung ? fmt::format(
                        "parallax-simhw at {} does not accept connections within {} ms "
                        "(it hangs)",
                        path_, connectTimeoutMs_)
                  : fmt::format("cannot connect to parallax-simhw at {}: {}", path_,
                                std::strerror(errno));
    ::close(fd);
    return TransportStatus::kUnavailable;
  }
  tuneLinkSocket(fd, connectTimeoutMs_);
  sendTimeoutMs_ = connectTimeoutMs_;
  fd_ = fd;
  return TransportStatus::kOk;
}

void SocketTransport::close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  reader_ = PacketReader();
}

TransportStatus SocketTransport::send(uint16_t, std::span<const iovec> pieces, int timeoutMs) {
  if (fd_ < 0) return TransportStatus::kDisconnected;
  // Each send carries the caller's time limit (LinkClient's, what is left of its stall limit):
  // set the socket's only when it changes (one syscall).
  timeoutMs = std::max(timeoutMs, 1);
  if (timeoutMs != sendTimeoutMs_) {
    const timeval tv{timeoutMs / 1000, (timeoutMs % 1000) * 1000};
    setsockopt(fd_, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
    sendTimeoutMs_ = timeoutMs;
  }
  // writev may stop early (signals, buffer limits): advance through the iovecs until done.
  std::vector<iovec> rest(pieces.begin(), pieces.end());
  size_t first = 0;
  while (first < rest.size()) {
    msghdr msg{};
    msg.msg_iov = rest.data() + first;
    msg.msg_iovlen = std::min<size_t>(rest.size() - first, IOV_MAX);
    const ssize_t n = ::sendmsg(fd_, &msg, MSG_NOSIGNAL);
    if (n < 0) {
      if (errno == EINTR) continue;
      // EAGAIN here is the send timeout: the peer took no byte for timeoutMs (it hangs). A
      // packet may be cut either way: the stream cannot go on.
      const bool hung = errno == EAGAIN || errno == EWOULDBLOCK;
      close();
      return hung ? TransportStatus::kTimeout : TransportStatus::kDisconnected;
    }
    size_t left = static_cast<size_t>(n);
    while (first < rest.size() && left >= rest[first].iov_len) {
      left -= rest[first].iov_len;
      ++first;
    }
    if (left > 0) {
      rest[first].iov_base = static_cast<uint8_t*>(rest[first].iov_base) + left;
      rest[first].iov_len -= left;
    }
  }
  return TransportStatus::kOk;
}

TransportStatus SocketTransport::receive(std::vector<ReceivedPacket>* packets, int timeoutMs) {
  if (fd_ < 0) return TransportStatus::kDisconnected;
  const size_t before = packets->size();
  int wait = timeoutMs;
  while (true) {
    pollfd p{fd_, POLLIN, 0};
    const int r = ::poll(&p, 1, wait);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) break;
    const ssize_t n = ::recv(fd_, readBuffer_.data(), readBuffer_.size(), MSG_DONTWAIT);
    if (n < 0 && (errno == EAGAIN || errno == EINTR)) continue;
    if (n <= 0) {
      close();
      return TransportStatus::kDisconnected;
    }
    std::span<const uint8_t> bytes(readBuffer_.data(), static_cast<size_t>(n));
    while (!bytes.empty()) {
      const size_t used = reader_.feed(bytes);
      bytes = bytes.subspan(used);
      if (reader_.error() != ProtocolError::kOk) {
        const ProtocolError e = reader_.error();
        lastPeerVersion_ = reader_.peerVersion();
        ::close(fd_);
        fd_ = -1;
        reader_ = PacketReader();
        lastError_ = e;  // kept readable after the reset
        return TransportStatus::kProtocolError;
      }
      if (reader_.ready()) {
        packets->push_back(
            {reader_.header(), {reader_.payload().begin(), reader_.payload().end()}});
        reader_.next();
      }
    }
    // Got something: return what is complete without waiting again.
    if (packets->size() > before) return TransportStatus::kOk;
    wait = timeoutMs;  // a partial packet: keep waiting for the rest
  }
  return packets->size() > before ? TransportStatus::kOk : TransportStatus::kTimeout;
}

}  // namespace parallax::hw
