// `parallax`: the command users type (DESIGN.md, "Processes and interfaces"). A light front:
// `parallax ctl ...` is answered here by a program that links only the control client, so a
// `status` takes milliseconds (the full tool loads ~280 shared libraries — OpenCV, Ceres,
// Embree, OpenImageIO — before main: 0.3–0.9 s). Every other command, and --help, runs
// `parallax-tools` (parallax_tools_main.cpp, installed beside this program) with the same
// arguments.

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <string_view>
#include <system_error>

#include "daemon/cli/command_line.h"
#include "daemon/cli/commands.h"

namespace {

// parallax-tools beside this program (argv[0] is not trusted: /proc/self/exe).
std::string toolsPath() {
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  return (self.parent_path() / "parallax-tools").string();
}

}  // namespace

int main(int argc, char** argv) {
  int command = 1;  // the first word that is not --quiet: `parallax -q ctl status`
  while (command < argc &&
         (std::string_view(argv[command]) == "-q" || std::string_view(argv[command]) == "--quiet"))
    ++command;
  const std::string_view first = command < argc ? argv[command] : "";
  if (first == "ctl" || first == "--version") {
    CLI::App app{"parallax: drive horizontal-parallax light field displays", "parallax"};
    parallax::cli::addVersionFlag(app);
    parallax::cli::addQuietFlag(app);
    parallax::cli::addCtlCommand(app);
    return parallax::cli::runCommandLine(app, argc, argv, "parallax");
  }
  const std::string tools = toolsPath();
  argv[0] = const_cast<char*>(tools.c_str());
  ::execv(tools.c_str(), argv);
  std::fprintf(stderr, "parallax: error: cannot run %s: %s\n", tools.c_str(), std::strerror(errno));
  return 1;
}
