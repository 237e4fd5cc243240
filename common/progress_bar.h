#pragma once
// A progress bar on stderr for anything that runs longer than a second. Thread-safe: workers
// call advance() from any thread. On a terminal it redraws one line; elsewhere (CI logs, the
// journal) it prints a line at every 10%, so logs stay short. Once a second has passed it says
// how long is left at the rate so far ("~12s left"). `--quiet` turns every bar off
// (setQuiet).

#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>

namespace parallax {

class ProgressBar {
 public:
  ProgressBar(std::string label, std::int64_t total, bool enabled = true);
  ~ProgressBar();
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  void advance(std::int64_t steps = 1);
  void finish();

  // Process-wide: no bar draws anything while quiet (the command-line tools' --quiet).
  static void setQuiet(bool quiet);
  // "~12s left", "~3m05s left", or "" before a second has passed or at 0% and 100%.
  static std::string timeLeft(double fraction, double seconds);

 private:
  void end(std::int64_t done);  // the final line, once: finish() or the destructor
  void draw(std::int64_t done, bool final);

  std::string label_;
  std::int64_t total_;
  bool enabled_;
  bool interactive_;
  std::atomic<std::int64_t> done_{0};
  std::mutex drawMutex_;
  int lastDecile_ = -1;
  int lastPermille_ = -1;
  bool finished_ = false;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace parallax
