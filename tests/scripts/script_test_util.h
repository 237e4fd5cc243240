#pragma once
// Helpers for the scripts tests: temporary folders with files, and loading scripts given as
// text with small limits (so the endless-loop and memory-bomb tests take milliseconds).

#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <string>

#include "common/input_error.h"
#include "scripts/scene_script.h"

namespace parallax::testing {

inline std::string sceneLibrary() { return std::string(PARALLAX_SOURCE_DIR) + "/scripts/scenes"; }

class TempFolder {
 public:
  TempFolder() {
    std::random_device random;
    path_ =
        std::filesystem::temp_directory_path() / ("parallax_scripts_" + std::to_string(random()));
    std::filesystem::create_directories(path_);
  }
  ~TempFolder() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  std::string path() const { return path_.string(); }
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  // Writes the file and moves its modification time forward, so a watcher sees the change
  // even within the file system's timestamp granularity.
  std::string write(const std::string& name, const std::string& text) const {
    const std::filesystem::path p = path_ / name;
    std::filesystem::create_directories(p.parent_path());
    const bool existed = std::filesystem::exists(p);
    const auto before =
        existed ? std::filesystem::last_write_time(p) : std::filesystem::file_time_type{};
    std::ofstream(p, std::ios::binary) << text;
    if (existed) std::filesystem::last_write_time(p, before + std::chrono::seconds(2));
    return p.string();
  }

 private:
  std::filesystem::path path_;
};

// The library's scenes with the default limits, quietly (scripts played frame after frame).
inline ScriptOptions libraryOptions() {
  ScriptOptions options;
  options.libraryRoot = sceneLibrary();
  options.quiet = true;
  return options;
}

inline ScriptOptions smallLimits() {
  ScriptOptions options;
  options.libraryRoot = sceneLibrary();
  options.limits.loadInstructions = 2'000'000;
  options.limits.updateInstructions = 1'000'000;
  options.limits.memoryBytes = std::size_t{16} << 20;
  options.limits.loadAllocationBytes = std::size_t{256} << 20;
  options.limits.updateAllocationBytes = std::size_t{64} << 20;
  options.quiet = true;
  return options;
}

// The error a script's loading raises ("" when it loads).
inline std::string loadError(const std::string& source, const std::string& folder,
                             const ScriptOptions& options = smallLimits()) {
  try {
    SceneScript::loadSource(source, "attempt.lua", folder, options);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace parallax::testing
