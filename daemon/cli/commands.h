#pragma once
// The `parallax` subcommands. Each registers itself on the app and runs through the callback
// it installs; errors propagate as exceptions to main(), which prints one line and exits 1.

#include <CLI/CLI.hpp>
#include <string>

namespace parallax::cli {

void addBenchCommand(CLI::App& app);
void addBenchTextureSubcommand(CLI::App* bench);  // under `bench`
void addDisplayCommand(CLI::App& app);
void addRaytexCommand(CLI::App& app);
void addBenchLinkCommand(CLI::App& app);
void addRenderCommand(CLI::App& app);
void addViewCommand(CLI::App& app);
void addSimulateCommand(CLI::App& app);
void addCalibrateCommand(CLI::App& app);
void addCameraCommand(CLI::App& app);  // camera board, camera calibrate
void addSceneApiCommand(CLI::App& app);
// `commandLine`: how parallax was invoked, recorded in the report.
void addReportCommand(CLI::App& app, const std::string& commandLine);
void addCtlCommand(CLI::App& app);
void addBenchDaemonSubcommand(CLI::App* bench);   // under `bench`
void addBenchClusterSubcommand(CLI::App* bench);  // under `bench`

}  // namespace parallax::cli
