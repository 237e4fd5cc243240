// parallaxd as a process, the way systemd and installers run it: it tells systemd it is ready,
// `parallax ctl` finds it with no socket argument, SIGHUP reloads the config, SIGTERM stops it
// cleanly (socket removed, the simulator it started stopped after writing what its modules
// showed), and a run with injected faults (a module that disconnects, a corrupt chunk, a bad
// scene over the control socket) ends with every module showing the daemon's frame.

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "daemon/parallaxd/control_client.h"
#include "tests/daemon/daemon_process.h"
#include "tests/daemon/shell_command.h"
#include "tracer/frame.h"

extern char** environ;

namespace parallax::daemon {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// A parallaxd child running `config` (written into `folder`), its log beside it.
class Daemon : public testing::DaemonProcess {
 public:
  Daemon(const fs::path& folder, const std::string& config, std::vector<std::string> extraEnv = {})
      : testing::DaemonProcess(writeConfig(folder, config), folder / "parallaxd.log",
                               environmentWith(std::move(extraEnv))) {}

 private:
  static fs::path writeConfig(const fs::path& folder, const std::string& config) {
    std::ofstream(folder / "parallax.toml") << config;
    return folder / "parallax.toml";
  }
  static std::vector<std::string> environmentWith(std::vector<std::string> extraEnv) {
    std::vector<std::string> env = testing::currentEnvironment();
    for (std::string& e : extraEnv) env.push_back(std::move(e));
    return env;
  }
};

json ask(const std::string& socket, const json& request) {
  return daemon::tryAskDaemon(socket, request).value_or(nullptr);
}

json waitForStats(const std::string& socket, const std::function<bool(const json&)>& done,
                  int ms = 30000) {
  json s;
  for (int i = 0; i < ms / 20; ++i) {
    s = ask(socket, {{"request", "stats"}});
    if (s.is_object() && done(s)) return s;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ADD_FAILURE() << "timed out; last stats: " << s.dump();
  return s;
}

// Runs `parallax ctl ARGS` with the environment `env` added; returns exit status and output.
std::pair<int, std::string> ctl(const std::vector<std::string>& args, const std::string& env) {
  std::string command = env + " " + PARALLAX_PATH + " ctl";
  for (const std::string& a : args) command += " '" + a + "'";
  return testing::runShellCommand(command);
}

// The systemd side of sd_notify: a datagram socket the daemon is pointed at with $NOTIFY_SOCKET.
class NotifySocket {
 public:
  explicit NotifySocket(const fs::path& path) : path_(path.string()) {
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::strncpy(addr.sun_path, path_.c_str(), sizeof addr.sun_path - 1);
    EXPECT_EQ(::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
    timeval timeout{30, 0};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  }
  ~NotifySocket() { ::close(fd_); }
  NotifySocket(const NotifySocket&) = delete;
  NotifySocket& operator=(const NotifySocket&) = delete;

  std::string env() const { return "NOTIFY_SOCKET=" + path_; }
  // The next message; "" after 30 s without one.
  std::string receive() {
    char message[1024] = {};
    const ssize_t n = ::recv(fd_, message, sizeof message - 1, 0);
    return n > 0 ? std::string(message, static_cast<size_t>(n)) : std::string();
  }
  // Receives until a message starting with `wanted`; false on a timeout. All are kept in
  // `received`.
  bool receiveUntil(const std::string& wanted) {
    while (true) {
      std::string m = receive();
      if (m.empty()) return false;
      received.push_back(std::move(m));
      if (received.back().rfind(wanted, 0) == 0) return true;
    }
  }
  std::vector<std::string> received;

 private:
  std::string path_;
  int fd_ = -1;
};

class ParallaxdProcess : public ::testing::Test {
 protected:
  void SetUp() override {
    folder_ = fs::temp_directory_path() /
              ("plxd-" + std::to_string(::getpid()) + "-" +
               ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(folder_);
    fs::create_directories(folder_ / "run");
    socket_ = (folder_ / "run" / "parallax" / "parallaxd.sock").string();
  }
  void TearDown() override { fs::remove_all(folder_); }
  // A small demo display (4 modules of 64×48) on the simulator parallaxd starts itself.
  std::string config(const std::string& hardwareExtra = "",
                     const std::string& scene = "cornell") const {
    return "[display]\npreset = \"demo\"\nmodules = 4\nresolution = [64, 48]\n"
           "[hardware]\nkind = \"sim\"\ndump = \"" +
           (folder_ / "shown").string() + "\"\n" + hardwareExtra + "[scene]\nscript = \"" + scene +
           "\"\n"
           "[calibration]\nauto = false\nfile = \"" +
           (folder_ / "calibration.json").string() +
           "\"\n"
           "[daemon]\ncache_dir = \"" +
           (folder_ / "cache").string() + "\"\n";
  }
  std::string runtimeEnv() const { return "XDG_RUNTIME_DIR=" + (folder_ / "run").string(); }

  fs::path folder_;
  std::string socket_;
};

TEST_F(ParallaxdProcess, TellsSystemdItIsReadyAndStopsCleanlyOnSigterm) {
  NotifySocket notify(folder_ / "notify.sock");
  Daemon daemon(folder_, config(), {runtimeEnv(), notify.env(), "WATCHDOG_USEC=2000000"});
  // READY=1 (a long start-up stage may feed the watchdog and say its status before it).
  ASSERT_TRUE(notify.receiveUntil("READY=1")) << daemon.log();
  for (const std::string& m : notify.received) {
    EXPECT_TRUE(m == "READY=1" || m == "WATCHDOG=1" || m.rfind("STATUS=", 0) == 0) << m;
  }
  // `parallax ctl` with no socket argument finds it (same $XDG_RUNTIME_DIR).
  auto [code, out] = ctl({"status"}, runtimeEnv());
  EXPECT_EQ(code, 0) << out;
  EXPECT_NE(out.find("\"state\": \"playing\""), std::string::npos) << out;
  waitForStats(socket_, [](const json& s) { return s["module_frames_sent"] == 4; });
  // The watchdog keeps being fed while it idles (half of WATCHDOG_USEC).
  notify.received.clear();
  EXPECT_TRUE(notify.receiveUntil("WATCHDOG=1"));
  EXPECT_LE(notify.received.size(), 5u);

  ASSERT_EQ(::kill(daemon.pid(), SIGTERM), 0);
  const int status = daemon.waitExit(20000);
  ASSERT_NE(status, -1) << "did not stop on SIGTERM\n" << daemon.log();
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status << "\n" << daemon.log();
  EXPECT_FALSE(fs::exists(socket_));
  EXPECT_TRUE(notify.receiveUntil("STOPPING=1"));
  // The simulator was stopped, not killed: it wrote what its 4 modules showed.
  for (int m = 0; m < 4; ++m)
    EXPECT_TRUE(fs::exists(moduleFrameStem((folder_ / "shown").string(), m) + ".png")) << m;
}

TEST_F(ParallaxdProcess, RefusesABadConfigNamingTheKeyAndLine) {
  Daemon daemon(folder_, "[scene]\nfps = -3\n");
  const int status = daemon.waitExit(10000);
  ASSERT_TRUE(WIFEXITED(status)) << status;
  EXPECT_EQ(WEXITSTATUS(status), 2);
  EXPECT_NE(daemon.log().find("parallax.toml:2: scene.fps"), std::string::npos) << daemon.log();
}

TEST_F(ParallaxdProcess, SurvivesFaultsAndEveryModuleEndsWithItsFrame) {
  // Module 1 drops the link at its first frame, module 2 gets a corrupted chunk.
  Daemon daemon(folder_, config("faults = [\"1:disconnect\", \"2:flip:1\"]\n"), {runtimeEnv()});
  waitForStats(socket_, [](const json& s) {
    return s["module_frames_sent"].get<int>() >= 4 && s["module_frames_failed"] == 0;
  });
  // A bad scene over the control socket: refused, the old one stays up.
  const json r = ask(socket_, {{"request", "load"}, {"scene", "no_such_scene.lua"}});
  EXPECT_EQ(r["ok"], false);
  // A malformed request: an error reply, and the daemon goes on.
  const auto [code, out] = ctl({"--json", "{\"request\": 7}"}, runtimeEnv());
  EXPECT_EQ(code, 1) << out;
  const json status = ask(socket_, {{"request", "status"}});
  EXPECT_EQ(status["state"], "playing") << status.dump();
  EXPECT_EQ(status["scene"]["name"], "cornell");
  std::vector<std::vector<uint8_t>> frames;
  for (int m = 0; m < 4; ++m) {
    const std::string path = (folder_ / ("daemon_" + std::to_string(m) + ".png")).string();
    const json f = ask(socket_, {{"request", "frame"}, {"module", m}, {"path", path}});
    ASSERT_EQ(f["ok"], true) << f.dump();
    frames.push_back(readFrame(path).toSrgb8());
  }
  EXPECT_EQ(ask(socket_, {{"request", "shutdown"}})["ok"], true);
  const int exit = daemon.waitExit(20000);
  ASSERT_TRUE(WIFEXITED(exit) && WEXITSTATUS(exit) == 0) << daemon.log();
  for (int m = 0; m < 4; ++m) {
    const Frame shown = readFrame(moduleFrameStem((folder_ / "shown").string(), m) + ".png");
    EXPECT_EQ(shown.toSrgb8(), frames[static_cast<size_t>(m)]) << "module " << m;
  }
  EXPECT_NE(daemon.log().find("reconnecting"), std::string::npos) << daemon.log();
}

TEST_F(ParallaxdProcess, SighupReloadsTheConfig) {
  Daemon daemon(folder_, config(), {runtimeEnv()});
  waitForStats(socket_, [](const json& s) { return s["module_frames_sent"] == 4; });
  std::ofstream(folder_ / "parallax.toml") << config("", "shapes");
  ASSERT_EQ(::kill(daemon.pid(), SIGHUP), 0);
  json status;
  for (int i = 0; i < 1000; ++i) {
    status = ask(socket_, {{"request", "status"}});
    if (status.is_object() && status.contains("scene") && status["scene"]["name"] == "shapes")
      break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_EQ(status["scene"]["name"], "shapes") << status.dump();
  waitForStats(socket_, [](const json& s) { return s["display_frames"] == 2; });
  ::kill(daemon.pid(), SIGINT);
  const int exit = daemon.waitExit(20000);
  EXPECT_TRUE(WIFEXITED(exit) && WEXITSTATUS(exit) == 0) << daemon.log();
}

TEST_F(ParallaxdProcess, SighupRebuildsForANewDisplayRefusesABadOne) {
  Daemon daemon(folder_, config(), {runtimeEnv()});
  waitForStats(socket_, [](const json& s) { return s["module_frames_sent"] == 4; });
  auto withDisplay = [&](const std::string& display) {
    std::string text = config();
    const std::string old = "preset = \"demo\"\nmodules = 4\nresolution = [64, 48]\n";
    text.replace(text.find(old), old.size(), display);
    return text;
  };
  auto waitForModules = [&](int modules) {
    json status;
    for (int i = 0; i < 1500; ++i) {
      status = ask(socket_, {{"request", "status"}});
      if (status.is_object() && status["display"]["modules"] == modules &&
          status["state"] == "playing")
        break;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return status;
  };
  // The simulator's truth files, in a folder of this display's (and seed's) own.
  const json first = ask(socket_, {{"request", "status"}});
  const fs::path firstTruth = first.value("simulated_display", "");
  ASSERT_TRUE(fs::exists(firstTruth / "ground_truth.json")) << first.dump();
  EXPECT_EQ(firstTruth.filename(), "seed-7");
  EXPECT_EQ(firstTruth.parent_path().parent_path(), folder_ / "cache" / "simulated-display");
  // Three modules: the display changed, so simulator, link and loop are built again.
  std::ofstream(folder_ / "parallax.toml")
      << withDisplay("preset = \"demo\"\nmodules = 3\nresolution = [64, 48]\n");
  ASSERT_EQ(::kill(daemon.pid(), SIGHUP), 0);
  json status = waitForModules(3);
  EXPECT_EQ(status["display"]["modules"], 3) << status.dump() << daemon.log();
  // Another display with the same seed and cache: its own truth, the first's left as it was
  // (they shared seed-7/ and the second overwrote the first's ground truth).
  const fs::path secondTruth = status.value("simulated_display", "");
  EXPECT_NE(secondTruth, firstTruth);
  auto modulesIn = [](const fs::path& truth) {
    std::ifstream in(truth / "ground_truth.json");
    return json::parse(in, nullptr, false).value("modules", json::array()).size();
  };
  EXPECT_EQ(modulesIn(firstTruth), 4u);
  EXPECT_EQ(modulesIn(secondTruth), 3u);
  waitForStats(socket_, [](const json& s) { return s["module_frames_sent"] == 3; });
  // A display file that does not exist: refused before anything stops; three modules play on.
  std::ofstream(folder_ / "parallax.toml")
      << withDisplay("file = \"" + (folder_ / "no_such_display.json").string() + "\"\n");
  ASSERT_EQ(::kill(daemon.pid(), SIGHUP), 0);
  for (int i = 0; i < 500; ++i) {
    status = ask(socket_, {{"request", "status"}});
    if (status.is_object() && status.contains("last_error") && !status["last_error"].is_null() &&
        status["last_error"].dump().find("no_such_display") != std::string::npos) {
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_NE(status.dump().find("no_such_display"), std::string::npos)
      << status.dump() << daemon.log();
  EXPECT_EQ(status["display"]["modules"], 3) << status.dump();
  EXPECT_EQ(status["state"], "playing") << status.dump();
  ::kill(daemon.pid(), SIGTERM);
  const int exit = daemon.waitExit(20000);
  EXPECT_TRUE(WIFEXITED(exit) && WEXITSTATUS(exit) == 0) << daemon.log();
}

// Waits until the daemon says it is calibrating and has taken a picture or two.
json waitForPictures(const std::string& socket, int ms = 60000) {
  json status;
  for (int i = 0; i < ms / 20; ++i) {
    status = ask(socket, {{"request", "status"}});
    if (status.is_object() && status["state"] == "calibrating" &&
        status["stage"].get<std::string>().rfind("pictures: 2", 0) == 0)
      return status;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ADD_FAILURE() << "never saw the calibration take pictures; last status: " << status.dump();
  return status;
}

// Issue 18, item 6: a reload keeps the camera of the simulator parallaxd started, so
// `calibrate` still works after it.
TEST_F(ParallaxdProcess, CalibrateWorksAfterAReload) {
  Daemon daemon(folder_, config(), {runtimeEnv()});
  waitForStats(socket_, [](const json& s) { return s["module_frames_sent"] == 4; });
  ASSERT_EQ(::kill(daemon.pid(), SIGHUP), 0);
  const json reloaded = ask(socket_, {{"request", "reload"}});
  ASSERT_EQ(reloaded["ok"], true) << reloaded.dump();
  json reply;
  std::thread calibrating([&] {
    reply = daemon::tryAskDaemon(socket_, {{"request", "calibrate"}}, 600.0).value_or(nullptr);
  });
  for (int i = 0; i < 500 && !reply.is_object(); ++i) {
    const json status = ask(socket_, {{"request", "status"}});
    if (status.is_object() && status["stage"].get<std::string>().rfind("pictures: 2", 0) == 0)
      break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  if (!reply.is_object()) {
    EXPECT_EQ(ask(socket_, {{"request", "cancel"}})["ok"], true);
  }
  calibrating.join();
  EXPECT_EQ(reply["ok"], false) << reply.dump();
  EXPECT_NE(reply.value("error", "").find("cancelled"), std::string::npos)
      << "the calibration did not run: " << reply.dump() << daemon.log();
  ::kill(daemon.pid(), SIGTERM);
  EXPECT_NE(daemon.waitExit(20000), -1);
}

// Issue 18, item 7: SIGTERM during a calibration stops it at its next step: nothing is
// installed and the daemon exits, well before the calibration would have finished.
TEST_F(ParallaxdProcess, SigtermStopsARunningCalibration) {
  std::string text = config();
  text.replace(text.find("auto = false"), 12, "auto = true");
  Daemon daemon(folder_, text, {runtimeEnv()});
  waitForPictures(socket_);
  ASSERT_EQ(::kill(daemon.pid(), SIGTERM), 0);
  const int exit = daemon.waitExit(15000);
  ASSERT_NE(exit, -1) << "still running 15 s after SIGTERM\n" << daemon.log();
  EXPECT_TRUE(WIFEXITED(exit) && WEXITSTATUS(exit) == 0) << daemon.log();
  EXPECT_FALSE(fs::exists(folder_ / "calibration.json")) << daemon.log();
  EXPECT_EQ(daemon.log().find("calibration installed"), std::string::npos) << daemon.log();
  EXPECT_FALSE(fs::exists(socket_));
}

}  // namespace
}  // namespace parallax::daemon

namespace parallax::daemon {
namespace {

// Under systemd: STATUS= follows the state (what `systemctl status` shows), a SIGHUP reload is
// bracketed by RELOADING=1 (with MONOTONIC_USEC) and READY=1, also when the new config is
// refused, and SIGTERM sends STOPPING=1.
TEST_F(ParallaxdProcess, TellsSystemdItsStatusReloadsAndStop) {
  NotifySocket notify(folder_ / "notify.sock");
  Daemon daemon(folder_, config(), {runtimeEnv(), notify.env()});
  ASSERT_TRUE(notify.receiveUntil("READY=1")) << daemon.log();
  ASSERT_TRUE(notify.receiveUntil("STATUS=playing")) << daemon.log();
  // The status follows the state (polled: a state that lasts is always shown).
  EXPECT_EQ(ask(socket_, {{"request", "pause"}})["ok"], true);
  ASSERT_TRUE(notify.receiveUntil("STATUS=paused")) << daemon.log();
  EXPECT_EQ(ask(socket_, {{"request", "play"}})["ok"], true);
  ASSERT_TRUE(notify.receiveUntil("STATUS=playing")) << daemon.log();

  notify.received.clear();
  ASSERT_EQ(::kill(daemon.pid(), SIGHUP), 0);
  ASSERT_TRUE(notify.receiveUntil("READY=1")) << daemon.log();
  ASSERT_FALSE(notify.received.empty());
  const std::string& reloading = notify.received.front();
  EXPECT_EQ(reloading.rfind("RELOADING=1\nMONOTONIC_USEC=", 0), 0u) << reloading;
  EXPECT_GT(std::stoll(reloading.substr(reloading.find('=', 12) + 1)), 0) << reloading;

  // A config that does not load: still RELOADING=1 ... READY=1, the old config plays on.
  std::ofstream(folder_ / "parallax.toml") << "[scene]\nfps = -3\n";
  notify.received.clear();
  ASSERT_EQ(::kill(daemon.pid(), SIGHUP), 0);
  ASSERT_TRUE(notify.receiveUntil("READY=1")) << daemon.log();
  EXPECT_EQ(notify.received.front().rfind("RELOADING=1", 0), 0u) << notify.received.front();
  EXPECT_EQ(ask(socket_, {{"request", "status"}})["state"], "playing");

  ASSERT_EQ(::kill(daemon.pid(), SIGTERM), 0);
  const int status = daemon.waitExit(20000);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << daemon.log();
  EXPECT_TRUE(notify.receiveUntil("STOPPING=1")) << daemon.log();
}

// With stderr a journal stream ($JOURNAL_STREAM names its device and inode, as systemd sets
// it), every line parallaxd logs carries its syslog priority and no timestamp of ours (the
// journal stamps each record once), so `journalctl -p err` finds the errors.
TEST_F(ParallaxdProcess, LogsWithJournalPrioritiesWhenStderrIsTheJournal) {
  // The log file the daemon's stderr is opened on (O_TRUNC keeps its inode).
  std::ofstream(folder_ / "parallaxd.log").close();
  struct stat logStat {};
  ASSERT_EQ(::stat((folder_ / "parallaxd.log").c_str(), &logStat), 0);
  const std::string journalStream =
      "JOURNAL_STREAM=" + std::to_string(logStat.st_dev) + ":" + std::to_string(logStat.st_ino);
  Daemon daemon(folder_, config(), {runtimeEnv(), journalStream});
  waitForStats(socket_, [](const json& s) { return s["module_frames_sent"] == 4; });
  // An error: a reload of a config that does not load.
  std::ofstream(folder_ / "parallax.toml") << "[scene]\nfps = -3\n";
  EXPECT_EQ(ask(socket_, {{"request", "reload"}})["ok"], false);
  ASSERT_EQ(::kill(daemon.pid(), SIGTERM), 0);
  const int status = daemon.waitExit(20000);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << daemon.log();

  const std::string log = daemon.log();
  EXPECT_NE(log.find("<6>parallaxd ready\n"), std::string::npos) << log;
  EXPECT_NE(log.find("<3>reloading the config failed (the old one stays): "), std::string::npos)
      << log;
  EXPECT_NE(log.find("scene.fps"), std::string::npos) << log;
  std::istringstream lines(log);
  int parallaxdLines = 0;
  for (std::string line; std::getline(lines, line);) {
    // The simulator child writes its own lines to the same stream; parallaxd's are the "<N>"
    // ones.
    if (line.size() < 3 || line[0] != '<') continue;
    ++parallaxdLines;
    EXPECT_TRUE(line[1] >= '2' && line[1] <= '7' && line[2] == '>') << line;
    EXPECT_EQ(line.find("[20"), std::string::npos) << "a timestamp of ours: " << line;
  }
  EXPECT_GT(parallaxdLines, 5) << log;
}

}  // namespace
}  // namespace parallax::daemon
