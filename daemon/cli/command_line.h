#pragma once
// How every Parallax program starts and ends, the same for all (README, "Exit codes"):
//   0  success, and --help, --version;
//   1  a runtime failure: bad input (a file, a config, a daemon's refusal), an I/O error —
//      one line on stderr naming the file, line or field;
//   2  a usage error: an unknown option, a missing or malformed value (CLI11's parse errors).

#include <CLI/CLI.hpp>
#include <string>

namespace parallax::cli {

enum ExitCode : int { kExitSuccess = 0, kExitFailure = 1, kExitUsage = 2 };

// "parallax 0.1.0 (v0.1.0-12-gabcdef)": the project version and, when built from a git
// checkout, `git describe` at configure time.
std::string versionText(const std::string& program);
// --version on `app`, printing versionText(app's name).
void addVersionFlag(CLI::App& app);
// --quiet (-q) on `app` or a subcommand: no progress bars, no log lines below warnings, no
// "wrote ..." chatter; what a command prints on stdout as its result stays, and errors too.
void addQuietFlag(CLI::App& app);
bool quiet();
// Parses and runs `app`; returns the exit code above. `program` prefixes the error line.
// A subcommand that wants its own code throws CLI::RuntimeError(code) (printed by no one).
int runCommandLine(CLI::App& app, int argc, char** argv, const std::string& program);

}  // namespace parallax::cli
