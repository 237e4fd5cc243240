// `parallax-tools`: the whole command-line tool (DESIGN.md, "Processes and interfaces"), which
// the light `parallax` front (parallax_main.cpp) runs for every command but `ctl`. It links
// everything (calibration, tracer, simulator, report), so it can be run directly too.

#include <CLI/CLI.hpp>
#include <string>

#include "daemon/cli/command_line.h"
#include "daemon/cli/commands.h"

int main(int argc, char** argv) {
  CLI::App app{"parallax: drive horizontal-parallax light field displays", "parallax"};
  app.require_subcommand(1);
  app.footer(
      "Exit codes: 0 success, 1 runtime failure (bad input, I/O, a daemon's refusal), 2 usage "
      "error.");
  app.fallthrough();  // --quiet after the command too: `parallax render ... --quiet`
  parallax::cli::addVersionFlag(app);
  parallax::cli::addQuietFlag(app);
  parallax::cli::addBenchCommand(app);
  parallax::cli::addDisplayCommand(app);
  parallax::cli::addRaytexCommand(app);
  parallax::cli::addRenderCommand(app);
  parallax::cli::addViewCommand(app);
  parallax::cli::addBenchLinkCommand(app);
  parallax::cli::addSimulateCommand(app);
  parallax::cli::addCalibrateCommand(app);
  parallax::cli::addCameraCommand(app);
  parallax::cli::addSceneApiCommand(app);
  std::string commandLine = "parallax";
  for (int i = 1; i < argc; ++i) commandLine += std::string(" ") + argv[i];
  parallax::cli::addReportCommand(app, commandLine);
  parallax::cli::addCtlCommand(app);
  return parallax::cli::runCommandLine(app, argc, argv, "parallax");
}
