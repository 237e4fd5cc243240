#pragma once
// `parallax bench link`: pushes full-size frames to many simulated modules over the socket
// transport and measures throughput and CPU per frame. The simulator runs as the real
// parallax-simhw process (the daemon's process model) when its executable is found, else on a
// thread of this process (reported as such). Prints figures; never judges them.

#include <cstdint>
#include <string>

namespace parallax::hw {

struct LinkBenchOptions {
  int modules = 72;
  int width = 1024, height = 768;
  int rounds = 20;  // every module gets one changed frame per round
  uint32_t chunkSize = 1u << 20;
  int windowFrames = 8;
  std::string simhwPath;   // empty: run the simulator in-process
  std::string socketPath;  // empty: a fresh path under the temp directory

  void validate() const;  // throws InputError naming the option
};

struct LinkPhase {
  uint64_t frames = 0;        // submitted
  uint64_t framesOnWire = 0;  // actually sent (not skipped)
  uint64_t payloadBytes = 0;  // pixel bytes sent
  double seconds = 0.0;
  double hostCpuSeconds = 0.0;        // user + system of this process during the phase
  double simulatorCpuSeconds = -1.0;  // of the parallax-simhw process; < 0 when in-process
  uint64_t failed = 0, retries = 0;
};

struct LinkBenchResult {
  std::string transport;
  bool simulatorInProcess = false;
  uint64_t frameBytes = 0;
  LinkPhase changing;                 // every frame differs from the module's last one
  LinkPhase unchanged;                // the same frames again: skipped by content hash
  double simulatorCpuSeconds = -1.0;  // the child's user + system over the whole run (startup
                                      // included); < 0 when in-process
};

LinkBenchResult runLinkBench(const LinkBenchOptions& options);

}  // namespace parallax::hw
