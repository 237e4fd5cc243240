#include "scripts/scripted_scene.h"

#include <set>

#include "common/input_error.h"

namespace parallax {

ScriptedScene::ScriptedScene(std::string path, ScriptOptions options)
    : path_(std::move(path)), options_(std::move(options)) {
  // Watch the script even if this first load fails half-way: the caller may retry.
  watch({path_});
  script_ = SceneScript::loadFile(path_, options_);
  watch(script_->files());
}

ScriptedScene::Stamp ScriptedScene::stampOf(const std::string& path) {
  Stamp s;
  s.path = path;
  std::error_code ec;
  s.modified = std::filesystem::last_write_time(path, ec);
  s.exists = !ec;
  if (s.exists) s.size = std::filesystem::file_size(path, ec);
  if (ec) s.size = 0;
  return s;
}

void ScriptedScene::watch(const std::vector<std::string>& files) {
  stamps_.clear();
  std::set<std::string> seen;
  for (const std::string& f : files) {
    if (seen.insert(f).second) stamps_.push_back(stampOf(f));
  }
}

std::vector<std::string> ScriptedScene::watchedFiles() const {
  std::vector<std::string> files;
  for (const Stamp& s : stamps_) files.push_back(s.path);
  return files;
}

bool ScriptedScene::loadAgain() {
  ScriptOptions options = options_;
  options.strictParameters = false;
  for (const ScriptParameter& p : script_->parameters()) options.parameters[p.name] = p.value;
  const double t = script_->time();
  try {
    std::unique_ptr<SceneScript> next = SceneScript::loadFile(path_, options);
    if (next->animated()) next->setTime(t);
    watch(next->files());
    script_ = std::move(next);
    lastError_.clear();
    ++version_;
    return true;
  } catch (const InputError& e) {
    // Keep playing the old version; watch what the failed one named too, so fixing any of
    // them triggers the next attempt.
    lastError_ = e.what();
    std::vector<std::string> files = script_->files();
    files.insert(files.begin(), path_);
    watch(files);
    return false;
  }
}

ScriptedScene::Reload ScriptedScene::reloadIfChanged() {
  bool changed = false;
  for (const Stamp& s : stamps_) changed = changed || !(stampOf(s.path) == s);
  if (!changed) return Reload::kUnchanged;
  return reload();
}

ScriptedScene::Reload ScriptedScene::reload() {
  if (loadAgain()) {
    ++reloads_;
    return Reload::kReloaded;
  }
  ++failedReloads_;
  return Reload::kFailed;
}

bool ScriptedScene::setTime(double t) {
  try {
    script_->setTime(t);
  } catch (const InputError& e) {
    lastError_ = e.what();
    return false;
  }
  if (script_->animated()) ++version_;
  return true;
}

bool ScriptedScene::setParameter(const std::string& name, double value) {
  script_->setParameter(name, value);
  options_.parameters[name] = value;
  if (script_->animated()) {
    ++version_;
    return true;
  }
  return loadAgain();
}

}  // namespace parallax
