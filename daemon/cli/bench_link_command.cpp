// parallax bench link [--modules 72] [--resolution 1024x768] [--rounds 20] [--chunk BYTES]
//                     [--window N] [--simhw PATH | --in-process]
// Pushes frames to simulated modules over the socket transport and prints frames/s, MB/s and
// CPU per frame (hw/simulator/link_bench.h). Figures only; nothing passes or fails on time.

#include <fmt/format.h>
#include <unistd.h>

#include <filesystem>
#include <iostream>
#include <memory>

#include "common/input_error.h"
#include "common/width_height.h"
#include "daemon/cli/commands.h"
#include "hw/simulator/link_bench.h"

namespace parallax::cli {
namespace {

struct BenchLinkArgs {
  hw::LinkBenchOptions options;
  std::string resolution = "1024x768";
  std::string simhw;
  bool inProcess = false;
};

// parallax-simhw is built next to parallax (build/hw/ beside build/daemon/) or installed
// beside it.
std::string findSimhw() {
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) return "";
  for (const auto& candidate : {self.parent_path() / "parallax-simhw",
                                self.parent_path().parent_path() / "hw" / "parallax-simhw"}) {
    if (::access(candidate.c_str(), X_OK) == 0) return candidate.string();
  }
  return "";
}

void runBenchLink(BenchLinkArgs args) {
  const WidthHeight size = parseWidthHeight(args.resolution, "--resolution");
  args.options.width = size.width;
  args.options.height = size.height;
  if (!args.inProcess) {
    args.options.simhwPath = args.simhw.empty() ? findSimhw() : args.simhw;
    if (args.options.simhwPath.empty()) {
      std::cerr << "bench link: parallax-simhw not found next to parallax; running the "
                   "simulator in-process (use --simhw PATH)\n";
    }
  }
  const hw::LinkBenchResult r = hw::runLinkBench(args.options);
  const hw::LinkBenchOptions& o = args.options;
  const double mb = 1e6;
  std::cout << fmt::format(
      "link bench: {} modules x {}x{} RGB8 ({:.2f} MB/frame), {}, simulator {}, chunk {} B, "
      "window {}\n",
      o.modules, o.width, o.height, r.frameBytes / mb, r.transport,
      r.simulatorInProcess ? "in-process (thread)" : "parallax-simhw process", o.chunkSize,
      o.windowFrames);
  const hw::LinkPhase& c = r.changing;
  std::cout << fmt::format(
      "changing frames:  {} frames in {:.3f} s = {:.1f} frames/s, {:.1f} MB/s ({:.3f} GB/s) "
      "payload; {:.1f} full refreshes/s of all modules\n",
      c.framesOnWire, c.seconds, c.framesOnWire / c.seconds, c.payloadBytes / c.seconds / mb,
      c.payloadBytes / c.seconds / 1e9, c.framesOnWire / c.seconds / o.modules);
  std::cout << fmt::format("  host CPU {:.3f} ms/frame ({:.0f}% of one core)",
                           1e3 * c.hostCpuSeconds / c.frames, 100.0 * c.hostCpuSeconds / c.seconds);
  if (c.simulatorCpuSeconds >= 0) {
    std::cout << fmt::format(", parallax-simhw CPU {:.3f} ms/frame ({:.0f}% of one core)",
                             1e3 * c.simulatorCpuSeconds / c.frames,
                             100.0 * c.simulatorCpuSeconds / c.seconds);
  } else {
    std::cout << " (the simulator thread included)";
  }
  std::cout << fmt::format("; retries {}, failed {}\n", c.retries, c.failed);
  const hw::LinkPhase& u = r.unchanged;
  std::cout << fmt::format(
      "unchanged frames: {} submitted in {:.3f} s, {} sent, {} payload bytes (skipped by "
      "content hash; {:.3f} ms host CPU per frame)\n",
      u.frames, u.seconds, u.framesOnWire, u.payloadBytes, 1e3 * u.hostCpuSeconds / u.frames);
}

}  // namespace

void addBenchLinkCommand(CLI::App& app) {
  // `bench` may already exist (other benchmarks add their own sub-subcommands).
  CLI::App* bench = nullptr;
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) {
    if (sub->get_name() == "bench") bench = sub;
  }
  if (!bench) {
    bench = app.add_subcommand("bench", "benchmarks (print figures)");
    bench->require_subcommand(1);
  }
  auto args = std::make_shared<BenchLinkArgs>();
  CLI::App* link = bench->add_subcommand("link",
                                         "frames/s, MB/s and CPU per frame over the "
                                         "socket link to simulated modules");
  link->add_option("--modules", args->options.modules, "simulated modules (default 72)");
  link->add_option("--resolution", args->resolution, "module resolution (default 1024x768)");
  link->add_option("--rounds", args->options.rounds, "changed frames per module (default 20)");
  link->add_option("--chunk", args->options.chunkSize, "chunk size in bytes (default 1 MiB)");
  link->add_option("--window", args->options.windowFrames, "frames in flight (default 8)");
  link->add_option("--simhw", args->simhw, "parallax-simhw executable (default: next to parallax)");
  link->add_flag("--in-process", args->inProcess, "run the simulator on a thread instead");
  link->callback([args] { runBenchLink(*args); });
}

}  // namespace parallax::cli
