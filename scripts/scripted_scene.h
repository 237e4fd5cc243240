#pragma once
// A scene script as the daemon plays it: the current version, hot-reloaded when the script, a
// module it required or an asset it read changes on disk. A new version that fails to load
// leaves the old one playing; the error (with its line) is kept for whoever reports it. The
// watcher polls modification times and sizes, which needs no thread and no inotify
// descriptors and is cheap at frame rate (a stat() per watched file).

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "scripts/scene_script.h"

namespace parallax {

class ScriptedScene {
 public:
  enum class Reload { kUnchanged, kReloaded, kFailed };

  // Loads the script; throws InputError when this first version fails.
  ScriptedScene(std::string path, ScriptOptions options);

  const Scene& scene() const { return script_->scene(); }
  const SceneScript& script() const { return *script_; }
  // Increases whenever scene() may have changed (a reload, an update, a parameter).
  std::uint64_t version() const { return version_; }

  // Advances an animated script to time t. On an error in update() the scene stays as it was,
  // the error goes to lastError() and the result is false.
  bool setTime(double t);
  // Changes a parameter (InputError for an unknown name or a value out of range). A static
  // script is built again with the new value; an animated one sees it in its next update.
  // Returns false (and keeps the old scene) when the rebuild fails.
  bool setParameter(const std::string& name, double value);

  // Checks the watched files; loads the new version when any changed.
  Reload reloadIfChanged();
  // Loads the script again now, changed or not (a cluster rank told by rank 0 that it changed).
  Reload reload();

  const std::string& lastError() const { return lastError_; }
  long reloads() const { return reloads_; }
  long failedReloads() const { return failedReloads_; }
  std::vector<std::string> watchedFiles() const;

 private:
  struct Stamp {
    std::string path;
    bool exists = false;
    std::filesystem::file_time_type modified;
    std::uintmax_t size = 0;
    bool operator==(const Stamp&) const = default;
  };
  static Stamp stampOf(const std::string& path);
  void watch(const std::vector<std::string>& files);
  bool loadAgain();  // from disk with the current parameter values

  std::string path_;
  ScriptOptions options_;
  std::unique_ptr<SceneScript> script_;
  std::vector<Stamp> stamps_;
  std::string lastError_;
  std::uint64_t version_ = 1;
  long reloads_ = 0;
  long failedReloads_ = 0;
};

}  // namespace parallax
