#pragma once
// An in-process parallax-simhw: SimulatedHardware served on a Unix socket by a thread, so
// tests can inspect the modules after stopping it (no race: the thread is joined first).

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>

#include "hw/link/link_client.h"
#include "hw/simulator/simhw_server.h"
#include "hw/simulator/simulated_hardware.h"

namespace parallax::hw {

// Link options for tests: 4 KiB chunks, a short ack timeout (a stall costs one; still far above
// a small frame's round trip on a loaded machine), quick reconnects.
inline LinkOptions fastLinkOptions() {
  LinkOptions o;
  o.chunkSize = 4096;
  o.ackTimeoutMs = 400;
  o.maxRetries = 3;
  o.reconnectAttempts = 3;
  o.reconnectDelayMs = 10;
  o.linkDownRetryMs = 0;  // tests restart the simulator right away
  return o;
}

class InProcessSimhw {
 public:
  explicit InProcessSimhw(SimulatedHardwareOptions options,
                          std::unique_ptr<CameraPhysics> physics = nullptr)
      : hardware_(std::move(options), std::move(physics)),
        path_(
            (std::filesystem::temp_directory_path() / ("plx-simhw-" + std::to_string(::getpid()) +
                                                       "-" + std::to_string(counter_++) + ".sock"))
                .string()) {
    start();
  }
  ~InProcessSimhw() { stop(); }

  void start() {
    stop_ = false;
    ended_ = false;
    server_ = std::make_unique<SimhwServer>(hardware_);
    std::filesystem::remove(path_);  // a crash leaves the file: wait for the new one below
    thread_ = std::thread([this] {
      end_ = server_->listenAndServe(path_, stop_);
      ended_ = true;
    });
    // The socket file appears at bind(), a moment before listen(): wait until a connection
    // is actually accepted (the probe is served as a connection that ends at once).
    for (int i = 0; i < 2000; ++i) {
      const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
      sockaddr_un addr{};
      addr.sun_family = AF_UNIX;
      std::strncpy(addr.sun_path, path_.c_str(), sizeof addr.sun_path - 1);
      const bool up = ::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0;
      ::close(fd);
      if (up) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  }
  void stop() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }
  // Waits for the server thread to end by itself (a crash fault), for at most `ms`.
  bool waitForEnd(int ms) {
    for (int i = 0; i < ms && !ended_; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    if (ended_ && thread_.joinable()) thread_.join();
    return !thread_.joinable();
  }

  const std::string& path() const { return path_; }
  std::string spec() const { return "simhw:" + path_; }
  SimulatedHardware& hardware() { return hardware_; }  // only while stopped
  ConnectionEnd end() const { return end_; }

 private:
  static inline std::atomic<int> counter_{0};
  SimulatedHardware hardware_;
  std::string path_;
  std::unique_ptr<SimhwServer> server_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> ended_{false};
  ConnectionEnd end_ = ConnectionEnd::kStopped;
};

}  // namespace parallax::hw
