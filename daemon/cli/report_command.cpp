// parallax report [--out DIR] [--display demo|default|FILE] [--scale F] [--quick]
// The error-against-run-time report of issue 7: report.md with CSV tables and SVG plots
// (daemon/report/). Without flags: the `default` display at full resolution, one module, in a
// few minutes; --quick: `demo` at a quarter of its resolution, in seconds (CI).

#include <fmt/format.h>

#include <iostream>
#include <memory>

#include "daemon/cli/commands.h"
#include "daemon/report/report.h"

namespace parallax::cli {

void addReportCommand(CLI::App& app, const std::string& commandLine) {
  auto options = std::make_shared<report::ReportOptions>();
  options->commandLine = commandLine;
  CLI::App* command = app.add_subcommand(
      "report",
      "error-against-run-time report: markdown and HTML, CSV tables, SVG plots with PNG twins");
  command->add_option("--out", options->out, "output folder (created)");
  command->add_option("--display", options->display,
                      "display JSON file or built-in name (default: default; demo with --quick)");
  command->add_option("--scale", options->scale,
                      "module resolution factor in [0.05, 1] (default 1; 0.25 with --quick)");
  command->add_flag("--quick", options->quick,
                    "small and fast: demo display, reduced resolution and levels (CI)");
  command->callback([options] {
    const std::string path = report::writeReport(*options);
    std::cout << fmt::format("report written to {}\n", path);
  });
}

}  // namespace parallax::cli
