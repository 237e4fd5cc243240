#include "daemon/cli/command_line.h"

#include <spdlog/spdlog.h>

#include <cstdio>
#include <exception>

#include "common/input_error.h"
#include "common/progress_bar.h"
#include "common/version.h"

namespace parallax::cli {
namespace {

bool quietFlag = false;

}  // namespace

void addQuietFlag(CLI::App& app) {
  app.add_flag_callback(
      "-q,--quiet",
      [] {
        quietFlag = true;
        ProgressBar::setQuiet(true);
        spdlog::set_level(spdlog::level::warn);
      },
      "no progress, no informational lines: only the result, warnings and errors");
}

bool quiet() { return quietFlag; }

std::string versionText(const std::string& program) {
  std::string text = program + " " + parallaxVersion();
  if (const std::string describe = parallaxGitDescribe(); !describe.empty())
    text += " (" + describe + ")";
  return text;
}

void addVersionFlag(CLI::App& app) {
  const std::string text = versionText(app.get_name().empty() ? "parallax" : app.get_name());
  app.set_version_flag("--version", text, "print the version and exit");
}

int runCommandLine(CLI::App& app, int argc, char** argv, const std::string& program) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {
    return app.exit(e);  // --help, --version: printed on stdout, exit 0
  } catch (const CLI::RuntimeError& e) {
    return e.get_exit_code();  // the command said what happened and chose its code
  } catch (const CLI::ParseError& e) {
    app.exit(e);  // "unknown option", "--x: value not a number", with "Run with --help"
    return kExitUsage;
  } catch (const InputError& e) {
    std::fprintf(stderr, "%s: %s\n", program.c_str(), e.what());
    return kExitFailure;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: error: %s\n", program.c_str(), e.what());
    return kExitFailure;
  }
  return kExitSuccess;
}

}  // namespace parallax::cli
