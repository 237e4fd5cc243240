#pragma once
// Where a report's figures come from, stated once per file (issue 25): the machine (CPU model,
// the cores this process may run on, the load), the build, the command line and the date.

#include <string>

namespace parallax::report {

struct Provenance {
  std::string cpu;          // "Intel(R) Xeon(R) ..." from /proc/cpuinfo
  int cores = 0;            // CPUs in this process's affinity mask (sched_getaffinity)
  int onlineCores = 0;      // CPUs online on the machine
  std::string cgroupLimit;  // "1.5 CPUs (cgroup cpu.max)" or "" when unlimited or unknown
  std::string system;       // "Linux 6.1.0 x86_64"
  double loadAverage = -1;  // 1-minute load average at the start, -1 unknown
  std::string build;        // "parallax 0.1.0 (57e3d61), Release, GCC 12.2.0"
  std::string command;
  std::string date;  // UTC

  static Provenance collect(const std::string& commandLine);
  // "machine: ...; build: ...; command: `...`; date: ..." on one line.
  std::string line() const;
};

// CPUs in the calling thread's affinity mask; 0 when it cannot be read. This is what the
// process may use: std::thread::hardware_concurrency() counts the machine's and ignores
// `taskset` (issue 25).
int affinityCoreCount();

}  // namespace parallax::report
