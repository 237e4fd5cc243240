#include "daemon/cli/bench_daemon_client.h"

#include <fmt/format.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <thread>

#include "daemon/parallaxd/control_client.h"

namespace parallax::cli {

std::string siblingBinary(const std::string& name) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  for (const fs::path& c : {self.parent_path() / name, self.parent_path() / "parallaxd" / name}) {
    if (::access(c.c_str(), X_OK) == 0) return c.string();
  }
  throw std::runtime_error(name + " not found next to parallax: build it first");
}

nlohmann::json askOrNull(const std::string& socket, const nlohmann::json& request) {
  return daemon::tryAskDaemon(socket, request).value_or(nullptr);
}

nlohmann::json waitForStats(const std::string& socket,
                            const std::function<bool(const nlohmann::json&)>& done,
                            const char* what, int timeoutSeconds, pid_t daemon) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(timeoutSeconds);
  while (std::chrono::steady_clock::now() < deadline) {
    // A daemon that died at start-up (a missing parallax-simhw, a bad config) answers nothing:
    // said at once, not after the whole timeout.
    int ended = 0;
    if (daemon > 0 && ::waitpid(daemon, &ended, WNOHANG) == daemon) {
      throw std::runtime_error(fmt::format(
          "parallaxd exited ({}) while waiting for {}; its log is on the terminal above",
          WIFEXITED(ended) ? fmt::format("exit code {}", WEXITSTATUS(ended))
                           : fmt::format("signal {}", WTERMSIG(ended)),
          what));
    }
    nlohmann::json stats = askOrNull(socket, {{"request", "stats"}});
    nlohmann::json status = askOrNull(socket, {{"request", "status"}});
    if (!stats.is_null() && !stats.is_discarded() && !status.is_discarded() && !status.is_null()) {
      if (status.value("state", "") == "error")
        throw std::runtime_error("the daemon reports an error: " + status.dump());
      if (done(stats)) return stats;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  throw std::runtime_error(fmt::format("timed out waiting for {}", what));
}

double windowMeanMs(const nlohmann::json& before, const nlohmann::json& after) {
  const double n = after["count"].get<double>() - before["count"].get<double>();
  const double total = after["mean_ms"].get<double>() * after["count"].get<double>() -
                       before["mean_ms"].get<double>() * before["count"].get<double>();
  return n > 0 ? total / n : 0.0;
}

std::string sceneForConfig(const std::string& scene) {
  return scene.ends_with(".lua") ? std::filesystem::absolute(scene).string() : scene;
}

std::string benchCacheDir(const std::string& work) {
  const char* home = std::getenv("HOME");
  return home ? std::string(home) + "/.cache/parallax" : work + "/cache";
}

std::string loadAverage() {
  std::ifstream load("/proc/loadavg");
  std::string line;
  std::getline(load, line);
  return line;
}

}  // namespace parallax::cli
