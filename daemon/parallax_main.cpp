// `parallax`: the offline command-line tool and the daemon's control client (DESIGN.md, "Processes
// and interfaces").

#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <string>

#include "common/input_error.h"
#include "daemon/cli/commands.h"

int main(int argc, char** argv) {
  CLI::App app{"parallax: drive horizontal-parallax light field displays"};
  app.require_subcommand(1);
  parallax::cli::addBenchCommand(app);
  parallax::cli::addDisplayCommand(app);
  parallax::cli::addRaytexCommand(app);
  parallax::cli::addRenderCommand(app);
  parallax::cli::addViewCommand(app);
  parallax::cli::addBenchLinkCommand(app);
  parallax::cli::addSimulateCommand(app);
  parallax::cli::addCalibrateCommand(app);
  parallax::cli::addSceneApiCommand(app);
  std::string commandLine = "parallax";
  for (int i = 1; i < argc; ++i) commandLine += std::string(" ") + argv[i];
  parallax::cli::addReportCommand(app, commandLine);
  parallax::cli::addCtlCommand(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const parallax::InputError& e) {
    std::fprintf(stderr, "parallax: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "parallax: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
