// parallaxd as a cluster under Open MPI (issue 23): `mpirun -np N parallaxd` on the demo display,
// each rank with a simulator of its own modules. The frames every module shows are the same
// bytes with 1, 2 or 3 ranks as without mpirun; requests (status, view, load, set, shutdown)
// work across ranks; a rank killed mid-play ends the job with an error naming it and its
// modules. Run as root in CI: the launcher's run-as-root switches are set here, and
// --oversubscribe lets 3 ranks share 2 cores.

#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <thread>

#include "daemon/parallaxd/control_client.h"
#include "tests/daemon/daemon_process.h"

namespace parallax::daemon {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

json ask(const std::string& socket, const json& request) {
  return tryAskDaemon(socket, request).value_or(nullptr);
}

std::string readFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), {});
}

constexpr int kDemoModules = 16;

class ClusterTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    root_ = fs::temp_directory_path() /
            ("parallax_cluster_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    fs::remove_all(root_);
    fs::create_directories(root_);
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(root_);
  }

  // A daemon of `ranks` ranks under mpirun (0: parallaxd without a launcher) playing `scene`.
  std::unique_ptr<testing::DaemonProcess> start(int ranks, const std::string& scene,
                                                const std::string& name, int timeoutMs = 20000) {
    const fs::path folder = root_ / name;
    fs::create_directories(folder);
    socket_ = (folder / "run" / "parallax.sock").string();
    std::ofstream(folder / "parallax.toml")
        << "[display]\npreset = \"demo\"\n"
        << "[calibration]\nauto = false\n"
        << "[scene]\nscript = \"" << scene << "\"\nfps = 10\n"
        << "[daemon]\nsocket = \"" << socket_ << "\"\ncache_dir = \"" << (root_ / "cache").string()
        << "\"\n"
        << "[panel]\nenabled = false\n"
        << "[cluster]\ntimeout_ms = " << timeoutMs << "\n";
    std::vector<std::string> env = testing::currentEnvironment();
    // Open MPI refuses root unless told twice; CI runs as root.
    env.push_back("OMPI_ALLOW_RUN_AS_ROOT=1");
    env.push_back("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1");
    std::vector<std::string> launcher;
    if (ranks > 0) launcher = {"mpirun", "--oversubscribe", "-np", std::to_string(ranks)};
    return std::make_unique<testing::DaemonProcess>(folder / "parallax.toml",
                                                    folder / "parallaxd.log", env, launcher);
  }

  // Waits until the modules show `frames` display frames (rank 0 counts its own).
  json waitForFrames(int frames, const testing::DaemonProcess& daemon) {
    json s;
    for (int i = 0; i < 3000; ++i) {
      s = ask(socket_, {{"request", "stats"}});
      if (s.is_object() && s.value("display_frames", 0) >= frames) return s;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    ADD_FAILURE() << "no frame; last stats: " << s.dump() << "\nlog:\n" << daemon.log();
    return s;
  }

  // Every module's frame (the PNG bytes rank 0 writes from its owner's image).
  std::vector<std::string> moduleFrames(const std::string& tag) {
    std::vector<std::string> frames;
    for (int m = 0; m < kDemoModules; ++m) {
      const fs::path path = root_ / (tag + "_module" + std::to_string(m) + ".png");
      const json r = ask(socket_, {{"request", "frame"}, {"module", m}, {"path", path.string()}});
      EXPECT_TRUE(r.is_object() && r.value("ok", false)) << tag << " module " << m << ": " << r;
      frames.push_back(readFile(path));
    }
    return frames;
  }

  fs::path root_;
  std::string socket_;
};

// What one run shows: the static scene, the same after a parameter change, another scene
// loaded, and an observer's view made from every rank's modules.
struct Shown {
  std::vector<std::string> cornell, deeper, shapes;
  std::string view;
};

TEST_F(ClusterTest, FramesAreTheSameBytesWithOneTwoOrThreeRanks) {
  std::map<int, Shown> runs;
  for (int ranks : {0, 1, 2, 3}) {
    SCOPED_TRACE("ranks " + std::to_string(ranks));
    const std::string name = "np" + std::to_string(ranks);
    auto daemon = start(ranks, "cornell", name);
    waitForFrames(1, *daemon);
    Shown& shown = runs[ranks];
    shown.cornell = moduleFrames(name + "_cornell");

    const json status = ask(socket_, {{"request", "status"}});
    if (ranks > 1) {
      // Every rank reports, with its own modules and its own link up; together all modules.
      ASSERT_TRUE(status.contains("cluster")) << status;
      EXPECT_EQ(status["cluster"]["ranks"], ranks);
      std::set<int> modules;
      for (const json& r : status["cluster"]["rank"]) {
        EXPECT_EQ(r["link"]["health"], "up") << r;
        for (int m : r["modules"]) EXPECT_TRUE(modules.insert(m).second) << "module " << m;
      }
      EXPECT_EQ(modules.size(), static_cast<size_t>(kDemoModules));
    } else {
      EXPECT_FALSE(status.contains("cluster")) << status;
    }

    const int before = ask(socket_, {{"request", "stats"}}).value("display_frames", 0);
    json r = ask(socket_, {{"request", "set"}, {"name", "depth"}, {"value", 0.8}});
    ASSERT_TRUE(r.value("ok", false)) << r;
    waitForFrames(before + 1, *daemon);
    shown.deeper = moduleFrames(name + "_deeper");

    const int loaded = ask(socket_, {{"request", "stats"}}).value("display_frames", 0);
    r = ask(socket_, {{"request", "load"}, {"scene", "shapes"}});
    ASSERT_TRUE(r.value("ok", false)) << r;
    waitForFrames(loaded + 1, *daemon);
    shown.shapes = moduleFrames(name + "_shapes");

    const fs::path view = root_ / (name + "_view.png");
    r = ask(socket_, {{"request", "view"}, {"x", 0.1}, {"path", view.string()}});
    ASSERT_TRUE(r.value("ok", false)) << r;
    shown.view = readFile(view);

    r = ask(socket_, {{"request", "shutdown"}});
    EXPECT_TRUE(r.value("ok", false)) << r;
    const int exit = daemon->waitExit(30000);
    EXPECT_TRUE(WIFEXITED(exit) && WEXITSTATUS(exit) == 0) << exit << "\n" << daemon->log();
  }
  const Shown& reference = runs[0];  // parallaxd as it runs without mpirun
  for (const auto& [ranks, shown] : runs) {
    for (int m = 0; m < kDemoModules; ++m) {
      const auto i = static_cast<size_t>(m);
      EXPECT_FALSE(shown.cornell[i].empty());
      EXPECT_TRUE(shown.cornell[i] == reference.cornell[i]) << ranks << " ranks, module " << m;
      EXPECT_TRUE(shown.deeper[i] == reference.deeper[i]) << ranks << " ranks, module " << m;
      EXPECT_TRUE(shown.shapes[i] == reference.shapes[i]) << ranks << " ranks, module " << m;
    }
    EXPECT_TRUE(shown.view == reference.view) << ranks << " ranks: the observer view differs";
  }
  // The changes did change what the modules show (else the comparisons prove little).
  EXPECT_NE(reference.cornell[5], reference.deeper[5]);
  EXPECT_NE(reference.cornell[5], reference.shapes[5]);
}

// Rank 1 of 3 as status names it: its pid and "rank 1 (modules A-B)".
std::pair<pid_t, std::string> rankOne(const std::string& socket) {
  const json status = ask(socket, {{"request", "status"}});
  EXPECT_TRUE(status.contains("cluster")) << status;
  const json& rank1 = status["cluster"]["rank"][1];
  const std::vector<int> modules = rank1["modules"];
  EXPECT_FALSE(modules.empty());
  return {rank1["pid"].get<pid_t>(), "rank 1 (modules " + std::to_string(modules.front()) + "-" +
                                         std::to_string(modules.back()) + ")"};
}

TEST_F(ClusterTest, AKilledRankEndsTheJob) {
  auto daemon = start(3, "orbit", "kill");
  waitForFrames(2, *daemon);
  const auto [pid, named] = rankOne(socket_);
  ASSERT_EQ(::kill(pid, SIGKILL), 0);
  const int exit = daemon->waitExit(30000);
  ASSERT_NE(exit, -1) << "the job did not end:\n" << daemon->log();
  EXPECT_FALSE(WIFEXITED(exit) && WEXITSTATUS(exit) == 0) << daemon->log();
  // mpirun names the rank (and stops the others at once: SIGKILL a second after SIGTERM);
  // the ranks' map, logged by rank 0 at the start, names its modules.
  const std::string log = daemon->log();
  EXPECT_NE(log.find("process rank 1 "), std::string::npos) << log;
  EXPECT_NE(log.find("cluster: " + named + " on "), std::string::npos) << log;
}

TEST_F(ClusterTest, AHungRankEndsTheJobNamedWithItsModules) {
  auto daemon = start(3, "orbit", "hang", 3000);
  waitForFrames(2, *daemon);
  const auto [pid, named] = rankOne(socket_);
  ASSERT_EQ(::kill(pid, SIGSTOP), 0);
  const int exit = daemon->waitExit(30000);
  ::kill(pid, SIGCONT);  // if the job did not end, let the launcher stop it
  ASSERT_NE(exit, -1) << "the job did not end:\n" << daemon->log();
  EXPECT_FALSE(WIFEXITED(exit) && WEXITSTATUS(exit) == 0) << daemon->log();
  const std::string log = daemon->log();
  EXPECT_NE(log.find("cluster: " + named + " did not answer (no answer within 3000 ms)"),
            std::string::npos)
      << log;
}

}  // namespace
}  // namespace parallax::daemon
