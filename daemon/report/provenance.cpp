#include "daemon/report/provenance.h"

#include <fmt/format.h>
#include <sched.h>
#include <sys/utsname.h>
#include <unistd.h>

#include <cstdlib>
#include <ctime>
#include <fstream>
#include <sstream>

#include "common/version.h"

#ifndef PARALLAX_BUILD_TYPE
#define PARALLAX_BUILD_TYPE "unknown build type"
#endif

namespace parallax::report {
namespace {

std::string cpuModel() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("model name", 0) == 0) {
      const size_t colon = line.find(':');
      if (colon != std::string::npos && colon + 2 <= line.size()) return line.substr(colon + 2);
    }
  }
  return "unknown CPU";
}

// cgroup v2's "quota period" (or "max period"): the CPUs' worth of time the group may use.
std::string readCgroupLimit() {
  std::ifstream in("/sys/fs/cgroup/cpu.max");
  std::string quota;
  double period = 0;
  if (!(in >> quota >> period) || quota == "max" || period <= 0) return "";
  const double cpus = std::atof(quota.c_str()) / period;
  return cpus > 0 ? fmt::format("{:g} CPUs (cgroup cpu.max)", cpus) : "";
}

std::string compiler() {
#if defined(__clang__)
  return fmt::format("Clang {}.{}.{}", __clang_major__, __clang_minor__, __clang_patchlevel__);
#elif defined(__GNUC__)
  return fmt::format("GCC {}.{}.{}", __GNUC__, __GNUC_MINOR__, __GNUC_PATCHLEVEL__);
#else
  return "unknown compiler";
#endif
}

}  // namespace

int affinityCoreCount() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) != 0) return 0;
  return CPU_COUNT(&set);
}

Provenance Provenance::collect(const std::string& commandLine) {
  Provenance p;
  p.cpu = cpuModel();
  p.cores = affinityCoreCount();
  p.onlineCores = static_cast<int>(sysconf(_SC_NPROCESSORS_ONLN));
  p.cgroupLimit = readCgroupLimit();
  utsname u{};
  p.system =
      uname(&u) == 0 ? fmt::format("{} {} {}", u.sysname, u.release, u.machine) : "unknown system";
  double load[3] = {0, 0, 0};
  if (getloadavg(load, 3) == 3) p.loadAverage = load[0];
  const std::string describe = parallaxGitDescribe();
  p.build =
      fmt::format("parallax {}{}, {}, {}", parallaxVersion(),
                  describe.empty() ? "" : " (" + describe + ")", PARALLAX_BUILD_TYPE, compiler());
  p.command = commandLine;
  const std::time_t t = std::time(nullptr);
  char text[64];
  std::strftime(text, sizeof text, "%Y-%m-%d %H:%M:%S UTC", std::gmtime(&t));
  p.date = text;
  return p;
}

std::string Provenance::line() const {
  std::ostringstream machine;
  machine << cpu << ", " << cores << (cores == 1 ? " core" : " cores") << " available";
  if (onlineCores > 0 && onlineCores != cores) machine << " of " << onlineCores << " online";
  if (!cgroupLimit.empty()) machine << ", limited to " << cgroupLimit;
  machine << ", " << system;
  if (loadAverage >= 0) machine << fmt::format(", load average {:.2f} at the start", loadAverage);
  return fmt::format("machine: {}; build: {}; command: `{}`; date: {}", machine.str(), build,
                     command, date);
}

}  // namespace parallax::report
