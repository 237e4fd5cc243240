#include "hw/simulator/link_bench.h"

#include <fmt/format.h>
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <vector>

#include "common/input_error.h"
#include "hw/link/link_client.h"
#include "hw/link/socket_transport.h"
#include "hw/simulator/simhw_server.h"
#include "hw/simulator/simulated_hardware.h"

extern char** environ;

namespace parallax::hw {
namespace {

double cpuSeconds(int who) {
  rusage u{};
  getrusage(who, &u);
  return u.ru_utime.tv_sec + u.ru_utime.tv_usec * 1e-6 + u.ru_stime.tv_sec +
         u.ru_stime.tv_usec * 1e-6;
}

// The simulator: a child process, or a thread when no executable was given.
class BenchSimulator {
 public:
  BenchSimulator(const LinkBenchOptions& o, const std::string& path) {
    if (!o.simhwPath.empty()) {
      const std::vector<std::string> args = {o.simhwPath,
                                             "--socket",
                                             path,
                                             "--modules",
                                             std::to_string(o.modules),
                                             "--resolution",
                                             fmt::format("{}x{}", o.width, o.height)};
      std::vector<char*> argv;
      for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
      argv.push_back(nullptr);
      if (posix_spawn(&child_, o.simhwPath.c_str(), nullptr, nullptr, argv.data(), environ) != 0) {
        throw std::runtime_error(
            fmt::format("cannot start {}: {}", o.simhwPath, std::strerror(errno)));
      }
      return;
    }
    SimulatedHardwareOptions so;
    so.modules = o.modules;
    so.width = o.width;
    so.height = o.height;
    hardware_ = std::make_unique<SimulatedHardware>(so);
    server_ = std::make_unique<SimhwServer>(*hardware_);
    thread_ = std::thread([this, path] { server_->listenAndServe(path, stop_); });
  }
  ~BenchSimulator() { stop(); }

  // Stops the simulator; returns its CPU seconds when it was a child process, else -1.
  double stop() {
    if (child_ > 0) {
      kill(child_, SIGTERM);
      int status = 0;
      const double before = cpuSeconds(RUSAGE_CHILDREN);
      waitpid(child_, &status, 0);
      child_ = 0;
      return cpuSeconds(RUSAGE_CHILDREN) - before;
    }
    stop_ = true;
    if (thread_.joinable()) thread_.join();
    return -1.0;
  }
  bool inProcess() const { return hardware_ != nullptr; }
  // The child's user + system CPU so far (from /proc), or -1 when in-process or unknown.
  double childCpuSeconds() const {
    if (child_ <= 0) return -1.0;
    std::ifstream stat(fmt::format("/proc/{}/stat", child_));
    std::string text((std::istreambuf_iterator<char>(stat)), std::istreambuf_iterator<char>());
    // Fields after the parenthesised command name: state is field 3, utime 14, stime 15.
    const size_t close = text.rfind(')');
    if (close == std::string::npos) return -1.0;
    std::istringstream rest(text.substr(close + 2));
    std::string field;
    double utime = 0, stime = 0;
    for (int i = 3; i <= 15 && rest >> field; ++i) {
      if (i == 14) utime = std::stod(field);
      if (i == 15) stime = std::stod(field);
    }
    return (utime + stime) / static_cast<double>(sysconf(_SC_CLK_TCK));
  }

 private:
  pid_t child_ = 0;
  std::unique_ptr<SimulatedHardware> hardware_;
  std::unique_ptr<SimhwServer> server_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
};

// Distinct, cheap-to-make frame content per module (a xorshift stream).
void fill(Image& image, uint64_t seed) {
  uint64_t x = seed * 0x9E3779B97F4A7C15ull + 1;
  uint8_t* p = image.pixels.data();
  const size_t n = image.pixels.size();
  size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    std::memcpy(p + i, &x, 8);
  }
  for (; i < n; ++i) p[i] = static_cast<uint8_t>(i);
}

}  // namespace

void LinkBenchOptions::validate() const {
  if (modules < 1 || modules > 1024) throw InputError({"", "--modules", 0}, "must be in 1..1024");
  if (width < 1 || height < 1 || width > 8192 || height > 8192) {
    throw InputError({"", "--resolution", 0}, "must be in 1..8192 per side");
  }
  if (rounds < 1) throw InputError({"", "--rounds", 0}, "must be positive");
}

LinkBenchResult runLinkBench(const LinkBenchOptions& o) {
  o.validate();
  const std::string path =
      !o.socketPath.empty()
          ? o.socketPath
          : (std::filesystem::temp_directory_path() / fmt::format("plx-bench-{}.sock", getpid()))
                .string();
  BenchSimulator simulator(o, path);

  LinkOptions lo;
  lo.chunkSize = o.chunkSize;
  lo.windowFrames = o.windowFrames;
  std::unique_ptr<LinkClient> link;
  std::string lastError;
  // The simulator needs a moment to listen.
  for (int attempt = 0; attempt < 100 && !link; ++attempt) {
    try {
      link = std::make_unique<LinkClient>(std::make_unique<SocketTransport>(path), lo);
    } catch (const std::runtime_error& e) {
      lastError = e.what();
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  }
  if (!link) throw std::runtime_error("the simulator did not come up: " + lastError);

  LinkBenchResult result;
  result.transport = link->transportName();
  result.simulatorInProcess = simulator.inProcess();

  // Two frames per module, alternated by round, so a frame is never rewritten while the link
  // may still be sending it (the window is far smaller than a round).
  std::vector<std::shared_ptr<Image>> frames(2 * o.modules);
  for (size_t i = 0; i < frames.size(); ++i) {
    frames[i] = std::make_shared<Image>();
    frames[i]->width = o.width;
    frames[i]->height = o.height;
    frames[i]->pixels.resize(frames[i]->byteSize());
    fill(*frames[i], i);
  }
  result.frameBytes = frames[0]->byteSize();

  int round = 0;  // across phases: every round's stamp is new
  auto runPhase = [&](int rounds) {
    LinkPhase phase;
    const LinkStats before = link->stats();
    const double cpu0 = cpuSeconds(RUSAGE_SELF);
    const double simCpu0 = simulator.childCpuSeconds();
    const auto t0 = std::chrono::steady_clock::now();
    for (int end = round + rounds; round < end; ++round) {
      const int r = round;
      for (int m = 0; m < o.modules; ++m) {
        std::shared_ptr<Image>& f = frames[2 * m + (r & 1)];
        {
          // The link borrows the pixels until the frame is final; never write under it.
          if (f.use_count() > 1) link->flush();
          const uint64_t stamp = (static_cast<uint64_t>(r) << 32) | static_cast<uint32_t>(m);
          std::memcpy(f->pixels.data(), &stamp, sizeof stamp);
        }
        link->submit(m, f);
        ++phase.frames;
      }
    }
    link->flush();
    phase.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    phase.hostCpuSeconds = cpuSeconds(RUSAGE_SELF) - cpu0;
    phase.simulatorCpuSeconds = simCpu0 < 0 ? -1.0 : simulator.childCpuSeconds() - simCpu0;
    const LinkStats& after = link->stats();
    phase.framesOnWire = after.attempts - before.attempts;
    phase.payloadBytes = after.payloadBytesSent - before.payloadBytesSent;
    phase.failed = after.failed - before.failed;
    phase.retries = after.retries - before.retries;
    link->takeOutcomes();
    return phase;
  };

  runPhase(1);  // warm-up: first contact, page faults in the simulator's buffers
  result.changing = runPhase(o.rounds);
  // Resubmit what every module already shows: frames of the last round, unchanged.
  {
    LinkPhase phase;
    const LinkStats before = link->stats();
    const double cpu0 = cpuSeconds(RUSAGE_SELF);
    const auto t0 = std::chrono::steady_clock::now();
    const int last = (round - 1) & 1;
    for (int r = 0; r < o.rounds; ++r) {
      for (int m = 0; m < o.modules; ++m) {
        link->submit(m, frames[2 * m + last]);
        ++phase.frames;
      }
    }
    link->flush();
    phase.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    phase.hostCpuSeconds = cpuSeconds(RUSAGE_SELF) - cpu0;
    phase.framesOnWire = link->stats().attempts - before.attempts;
    phase.payloadBytes = link->stats().payloadBytesSent - before.payloadBytesSent;
    phase.failed = link->stats().failed - before.failed;
    link->takeOutcomes();
    result.unchanged = phase;
  }
  link.reset();
  result.simulatorCpuSeconds = simulator.stop();
  return result;
}

}  // namespace parallax::hw
