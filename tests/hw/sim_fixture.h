#pragma once
// An in-process parallax-simhw: SimulatedHardware served on a Unix socket by a thread, so
// tests can inspect the modules after stopping it (no race: the thread is joined first).

#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>

#include "hw/simhw_server.h"
#include "hw/simulated_hardware.h"

namespace parallax::hw {

class InProcessSimhw {
 public:
  explicit InProcessSimhw(SimulatedHardwareOptions options)
      : hardware_(std::move(options)),
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
    // listenAndServe binds synchronously at its start; wait for the socket file.
    for (int i = 0; i < 200 && !std::filesystem::exists(path_); ++i) {
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
