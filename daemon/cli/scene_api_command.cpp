// parallax scene-api
// Prints the scene script API reference (markdown), generated from the binding's registry:
// every Lua-visible function with its signature, a one-line description and an example.

#include <iostream>

#include "daemon/cli/commands.h"
#include "scripts/scene_api.h"

namespace parallax::cli {

void addSceneApiCommand(CLI::App& app) {
  CLI::App* command =
      app.add_subcommand("scene-api", "print the scene script (Lua) API reference as markdown");
  command->callback([] { std::cout << sceneApiMarkdown(); });
}

}  // namespace parallax::cli
