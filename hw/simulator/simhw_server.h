#pragma once
// Serves SimulatedHardware over a stream socket: the body of `parallax-simhw`, and of the
// in-process simulator the tests run on a socketpair. Frame chunks are read straight into the
// module's receive buffer (no intermediate copy), so the receiving side costs one kernel copy
// and one CRC pass per byte.

#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include "hw/simulator/simulated_hardware.h"

namespace parallax::hw {

enum class ConnectionEnd { kPeerClosed, kClosedByDevice, kCrashRequested, kStopped };

class SimhwServer {
 public:
  explicit SimhwServer(SimulatedHardware& hardware) : hardware_(hardware) {}

  // Serves one connected socket until it ends; closes fd. Polls `stop` every 100 ms.
  ConnectionEnd serveConnection(int fd, const std::atomic<bool>* stop = nullptr);

  // Listens on `path` (replacing a stale socket file) and serves connections one after the
  // other until `stop` or a crash fault. Throws std::runtime_error if it cannot listen.
  ConnectionEnd listenAndServe(const std::string& path, const std::atomic<bool>& stop);

  uint64_t connectionsServed() const { return connections_; }

 private:
  SimulatedHardware& hardware_;
  uint64_t connections_ = 0;
};

}  // namespace parallax::hw
