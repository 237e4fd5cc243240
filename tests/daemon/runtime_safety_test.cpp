// parallaxd and `parallax ctl` against a hostile machine (issue 18, defects 1, 2, 9, 13, 18):
// a runtime folder or socket another user made first is refused, by the daemon and by the
// client, with and without $XDG_RUNTIME_DIR; an existing folder of ours is narrowed to 0700
// and the sockets in it are 0600; a second daemon on the same folder exits naming the first
// one's pid and leaves its sockets alone; a display file that is a FIFO, a folder or a device
// is refused at once with one line (it used to hang, deaf to SIGTERM).

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

extern char** environ;

namespace parallax::daemon {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr uid_t kOtherUser = 65534;  // nobody

// A parallaxd child without XDG_RUNTIME_DIR, plus `extraEnv`.
class DaemonProcess : public testing::DaemonProcess {
 public:
  DaemonProcess(const fs::path& config, const fs::path& log, const std::string& extraEnv)
      : testing::DaemonProcess(config, log, environmentWith(extraEnv)) {}

 private:
  static std::vector<std::string> environmentWith(const std::string& extraEnv) {
    std::vector<std::string> env;
    for (std::string& e : testing::currentEnvironment())
      if (e.rfind("XDG_RUNTIME_DIR=", 0) != 0) env.push_back(std::move(e));
    env.push_back(extraEnv);
    return env;
  }
};

// `command` through the shell; exit status and output (stdout and stderr).
std::pair<int, std::string> run(const std::string& command) {
  return testing::runShellCommand(command);
}

mode_t modeOf(const fs::path& path) {
  struct stat st {};
  EXPECT_EQ(::lstat(path.c_str(), &st), 0) << path;
  return st.st_mode & 07777;
}

// A control-socket impostor: answers every line with {"ok": true, "impostor": true}.
class FakeServer {
 public:
  explicit FakeServer(const std::string& path) {
    fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::strncpy(addr.sun_path, path.c_str(), sizeof addr.sun_path - 1);
    EXPECT_EQ(::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
    EXPECT_EQ(::listen(fd_, 4), 0);
    ::chmod(path.c_str(), 0777);
    thread_ = std::thread([this] {
      while (true) {
        const int c = ::accept(fd_, nullptr, nullptr);
        if (c < 0) return;
        char buffer[4096];
        if (::recv(c, buffer, sizeof buffer, 0) > 0) {
          const std::string reply = "{\"ok\": true, \"impostor\": true}\n";
          [[maybe_unused]] const ssize_t n = ::send(c, reply.data(), reply.size(), MSG_NOSIGNAL);
        }
        ::close(c);
      }
    });
  }
  ~FakeServer() {
    ::shutdown(fd_, SHUT_RDWR);
    ::close(fd_);
    thread_.join();
  }

 private:
  int fd_ = -1;
  std::thread thread_;
};

class RuntimeSafety : public ::testing::Test {
 protected:
  void SetUp() override {
    folder_ = fs::temp_directory_path() /
              ("plxs-" + std::to_string(::getpid()) + "-" + std::to_string(counter_++));
    fs::remove_all(folder_);
    fs::create_directories(folder_ / "run");
    runtime_ = folder_ / "run" / "parallax";
  }
  void TearDown() override { fs::remove_all(folder_); }

  // A small demo display on the simulator parallaxd starts itself; `display` replaces the
  // preset with a display file.
  fs::path writeConfig(const std::string& display = "") const {
    const fs::path path = folder_ / "parallax.toml";
    std::ofstream(path) << (display.empty()
                                ? std::string("[display]\npreset = \"demo\"\nmodules = 4\n"
                                              "resolution = [64, 48]\n")
                                : "[display]\nfile = \"" + display + "\"\n")
                        << "[hardware]\nkind = \"sim\"\n[scene]\nscript = \"cornell\"\n"
                        << "[calibration]\nauto = false\nfile = \""
                        << (folder_ / "calibration.json").string() << "\"\n[daemon]\ncache_dir = \""
                        << (folder_ / "cache").string() << "\"\n";
    return path;
  }
  std::string runtimeEnv() const { return "XDG_RUNTIME_DIR=" + (folder_ / "run").string(); }
  std::string socket() const { return (runtime_ / "parallaxd.sock").string(); }
  bool waitUntilAnswering(int ms = 60000) const {
    for (int i = 0; i < ms / 20; ++i) {
      const auto s = tryAskDaemon(socket(), {{"request", "status"}}, 5.0);
      if (s && s->is_object() && s->value("ok", false)) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return false;
  }

  // The simulator child binds its socket a moment after the daemon answers.
  bool waitForSimulatorSocket() const {
    for (int i = 0; i < 1000; ++i) {
      if (fs::exists(fs::symlink_status(runtime_ / "simhw.sock"))) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return false;
  }

  fs::path folder_;
  fs::path runtime_;
  static inline int counter_ = 0;  // short folder names: a socket path has under 108 bytes
};

#define REQUIRE_ROOT() \
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to make files of another user"

TEST_F(RuntimeSafety, TheDaemonRefusesARuntimeFolderOfAnotherUser) {
  REQUIRE_ROOT();
  fs::create_directory(runtime_);
  ASSERT_EQ(::chown(runtime_.c_str(), kOtherUser, kOtherUser), 0);
  ::chmod(runtime_.c_str(), 0777);
  DaemonProcess daemon(writeConfig(), folder_ / "log", runtimeEnv());
  const int status = daemon.waitExit(20000);
  ASSERT_NE(status, -1) << "it used the folder\n" << daemon.log();
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) != 0) << daemon.log();
  EXPECT_NE(daemon.log().find("owned by"), std::string::npos) << daemon.log();
  EXPECT_TRUE(fs::is_empty(runtime_)) << "nothing may be made in it";
}

TEST_F(RuntimeSafety, TheDaemonRefusesASymlinkedRuntimeFolder) {
  fs::create_directory(folder_ / "elsewhere");
  fs::create_directory_symlink(folder_ / "elsewhere", runtime_);
  DaemonProcess daemon(writeConfig(), folder_ / "log", runtimeEnv());
  const int status = daemon.waitExit(20000);
  ASSERT_NE(status, -1) << "it used the folder\n" << daemon.log();
  EXPECT_NE(daemon.log().find("symlink"), std::string::npos) << daemon.log();
  EXPECT_TRUE(fs::is_empty(folder_ / "elsewhere"));
}

TEST_F(RuntimeSafety, AnOpenRuntimeFolderOfOursIsNarrowedAndItsSocketsArePrivate) {
  fs::create_directory(runtime_);
  ::chmod(runtime_.c_str(), 0755);
  DaemonProcess daemon(writeConfig(), folder_ / "log", runtimeEnv());
  ASSERT_TRUE(waitUntilAnswering()) << daemon.log();
  ASSERT_TRUE(waitForSimulatorSocket()) << daemon.log();
  EXPECT_EQ(modeOf(runtime_), 0700u);
  EXPECT_EQ(modeOf(runtime_ / "parallaxd.sock"), 0600u);
  EXPECT_EQ(modeOf(runtime_ / "simhw.sock"), 0600u);
}

TEST_F(RuntimeSafety, ASecondDaemonExitsNamingTheFirstAndLeavesItsSocketsAlone) {
  const fs::path config = writeConfig();
  DaemonProcess first(config, folder_ / "first.log", runtimeEnv());
  ASSERT_TRUE(waitUntilAnswering()) << first.log();
  ASSERT_TRUE(waitForSimulatorSocket()) << first.log();
  struct stat before {};
  ASSERT_EQ(::lstat((runtime_ / "simhw.sock").c_str(), &before), 0);

  DaemonProcess second(config, folder_ / "second.log", runtimeEnv());
  const int status = second.waitExit(20000);
  ASSERT_NE(status, -1) << second.log();
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 1) << second.log();
  EXPECT_NE(second.log().find("pid " + std::to_string(first.pid())), std::string::npos)
      << second.log();
  // The first one's simulator socket is the same file, and the first daemon still answers.
  struct stat after {};
  ASSERT_EQ(::lstat((runtime_ / "simhw.sock").c_str(), &after), 0);
  EXPECT_EQ(after.st_ino, before.st_ino);
  EXPECT_TRUE(waitUntilAnswering(5000));
  const auto stats = tryAskDaemon(socket(), {{"request", "status"}}, 5.0);
  ASSERT_TRUE(stats.has_value());
  EXPECT_EQ((*stats)["state"], "playing") << stats->dump();
}

TEST_F(RuntimeSafety, CtlRefusesASocketOrFolderOfAnotherUser) {
  REQUIRE_ROOT();
  fs::create_directory(runtime_);
  ::chmod(runtime_.c_str(), 0700);
  FakeServer impostor(socket());
  const std::string ctl = runtimeEnv() + " " PARALLAX_PATH " ctl status";
  {
    // Control: a socket of ours is talked to.
    const auto [code, out] = run(ctl);
    EXPECT_EQ(code, 0) << out;
  }
  ASSERT_EQ(::lchown(socket().c_str(), kOtherUser, kOtherUser), 0);
  {
    const auto [code, out] = run(ctl);
    EXPECT_NE(code, 0) << out;
    EXPECT_EQ(out.find("impostor"), std::string::npos) << out;
    EXPECT_NE(out.find("owned by"), std::string::npos) << out;
  }
  ASSERT_EQ(::lchown(socket().c_str(), 0, 0), 0);
  ASSERT_EQ(::chown(runtime_.c_str(), kOtherUser, kOtherUser), 0);
  {
    const auto [code, out] = run(ctl);
    EXPECT_NE(code, 0) << out;
    EXPECT_EQ(out.find("impostor"), std::string::npos) << out;
    EXPECT_NE(out.find("owned by"), std::string::npos) << out;
  }
}

// Without $XDG_RUNTIME_DIR the folder is the predictable /tmp/parallax-$UID: here user 65534
// runs `parallax ctl` while user 65533 made that folder first and listens in it.
TEST_F(RuntimeSafety, CtlWithoutXdgRuntimeDirRefusesAPlantedTmpFolder) {
  REQUIRE_ROOT();
  if (::access("/usr/bin/setpriv", X_OK) != 0) GTEST_SKIP() << "needs setpriv";
  const fs::path planted = "/tmp/parallax-" + std::to_string(kOtherUser);
  if (fs::exists(planted)) GTEST_SKIP() << planted << " exists already";
  fs::create_directory(planted);
  {
    FakeServer impostor((planted / "parallaxd.sock").string());
    ASSERT_EQ(::chown(planted.c_str(), kOtherUser - 1, kOtherUser - 1), 0);
    ::chmod(planted.c_str(), 0777);
    ASSERT_EQ(::lchown((planted / "parallaxd.sock").c_str(), kOtherUser - 1, kOtherUser - 1), 0);
    const auto [code, out] = run(
        "env -u XDG_RUNTIME_DIR /usr/bin/setpriv --reuid=" + std::to_string(kOtherUser) +
        " --regid=" + std::to_string(kOtherUser) + " --clear-groups " PARALLAX_PATH " ctl status");
    EXPECT_NE(code, 0) << out;
    EXPECT_EQ(out.find("impostor"), std::string::npos) << out;
    EXPECT_NE(out.find("owned by"), std::string::npos) << out;
  }
  fs::remove_all(planted);
}

TEST_F(RuntimeSafety, ADisplayFileThatIsAFifoAFolderOrADeviceIsRefusedAtOnce) {
  const fs::path fifo = folder_ / "display.fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  fs::create_directory(folder_ / "display.json");
  const std::pair<fs::path, std::string> cases[] = {
      {fifo, "a FIFO"}, {folder_ / "display.json", "a folder"}, {"/dev/zero", "a device"}};
  for (const auto& [file, kind] : cases) {
    DaemonProcess daemon(writeConfig(file.string()), folder_ / "log", runtimeEnv());
    const int status = daemon.waitExit(20000);
    if (status == -1) {
      // What it used to do: hang in the read, and ignore SIGTERM.
      ::kill(daemon.pid(), SIGTERM);
      ADD_FAILURE() << file << ": still running after 20 s; after SIGTERM it "
                    << (daemon.waitExit(3000) == -1 ? "still runs" : "stopped");
      continue;
    }
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 2) << daemon.log();
    const std::string log = daemon.log();
    EXPECT_NE(log.find(file.string()), std::string::npos) << log;
    EXPECT_NE(log.find(kind), std::string::npos) << log;
    EXPECT_EQ(log.find("not valid JSON"), std::string::npos) << log;
  }
}

}  // namespace
}  // namespace parallax::daemon
