#include "scripts/scene_script.h"

#include <fmt/format.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "common/input_error.h"
#include "scripts/script_paths.h"
#include "tracer/scene_source.h"

#ifndef PARALLAX_SCENE_LIBRARY
#define PARALLAX_SCENE_LIBRARY ""
#endif
#ifndef PARALLAX_SCENE_LIBRARY_FROM_BINDIR
#define PARALLAX_SCENE_LIBRARY_FROM_BINDIR "../share/parallax/scenes"
#endif

namespace parallax {
namespace fs = std::filesystem;

namespace {

// What update() may change, kept to put back when it fails half-way.
struct AnimatedState {
  std::vector<Instance> instances;
  std::vector<Material> materials;
  std::vector<Light> lights;
  Rgb background, ambient;
  std::vector<Box3> motionBounds;
  struct Deformed {
    int mesh;
    std::vector<Eigen::Vector3d> positions;
    std::vector<Eigen::Vector3f> normals;
  };
  std::vector<Deformed> skinned;            // meshes px.set_animation deforms
  std::vector<Eigen::Affine3d> placements;  // each model's, which px.set_animation may change

  AnimatedState(const Scene& s, const std::vector<ModelAnimation>& models)
      : instances(s.instances),
        materials(s.materials),
        lights(s.lights),
        background(s.background),
        ambient(s.ambient),
        motionBounds(s.motionBounds) {
    for (const ModelAnimation& model : models) {
      placements.push_back(model.placement);
      for (const SkinnedPart& part : model.skinnedParts) {
        const Mesh& mesh = s.meshes[static_cast<size_t>(part.mesh)];
        skinned.push_back({part.mesh, mesh.positions, mesh.normals});
      }
    }
  }
  void restore(Scene* s, std::vector<ModelAnimation>* models) const {
    s->instances = instances;
    s->materials = materials;
    s->lights = lights;
    s->background = background;
    s->ambient = ambient;
    s->motionBounds = motionBounds;
    for (const Deformed& d : skinned) {
      s->meshes[static_cast<size_t>(d.mesh)].positions = d.positions;
      s->meshes[static_cast<size_t>(d.mesh)].normals = d.normals;
    }
    for (size_t i = 0; i < models->size(); ++i) (*models)[i].placement = placements[i];
  }
};

}  // namespace

std::string ScriptOptions::defaultSceneLibrary() {
  if (const char* env = std::getenv("PARALLAX_SCENE_LIBRARY")) return env;
  // An installed program finds the library relative to itself, so any prefix (or a package
  // unpacked anywhere) works; a program in the build tree has none there and uses the sources'.
  static const std::string installed = [] {
    std::error_code ec;
    const fs::path self = fs::read_symlink("/proc/self/exe", ec);
    if (ec) return std::string();
    const fs::path library =
        (self.parent_path() / PARALLAX_SCENE_LIBRARY_FROM_BINDIR).lexically_normal();
    return fs::is_directory(library, ec) ? library.string() : std::string();
  }();
  return installed.empty() ? PARALLAX_SCENE_LIBRARY : installed;
}

std::map<std::string, std::string> ScriptOptions::defaultAssetRoots() {
  return {{"assimp", assimpTestModelsRoot()}};
}

void ScriptOptions::validate() const {
  limits.validate();
  for (const auto& [name, value] : parameters) {
    if (!std::isfinite(value)) throw InputError({"", "--set " + name, 0}, "value must be finite");
  }
}

SceneScript::~SceneScript() = default;

std::unique_ptr<SceneScript> SceneScript::loadFile(const std::string& path,
                                                   const ScriptOptions& options) {
  std::error_code ec;
  const fs::path canonical = fs::canonical(path, ec);
  if (ec) throw InputError({path, "", 0}, "cannot open the scene script: " + ec.message());
  std::string source;
  try {
    source = readSmallFile(canonical.string(), options.limits.maxSourceBytes);
  } catch (const std::exception& e) {
    throw InputError({path, "", 0}, e.what());
  }
  std::unique_ptr<SceneScript> script(new SceneScript());
  script->name_ = canonical.filename().string();
  script->path_ = canonical.string();
  script->sandboxFolder_ = canonical.parent_path().string();
  script->load(source, options);
  return script;
}

std::unique_ptr<SceneScript> SceneScript::loadSource(const std::string& source,
                                                     const std::string& name,
                                                     const std::string& folder,
                                                     const ScriptOptions& options) {
  std::unique_ptr<SceneScript> script(new SceneScript());
  script->name_ = name;
  script->sandboxFolder_ = folder;
  script->load(source, options);
  return script;
}

void SceneScript::load(const std::string& source, const ScriptOptions& options) {
  options.validate();
  sandbox_ = std::make_unique<ScriptSandbox>(options.limits, sandboxFolder_, options.libraryRoot);
  sandbox_->quiet = options.quiet;
  build_.overrides = options.parameters;
  build_.assetRoots = options.assetRoots;
  build_.scene.name = fs::path(name_).stem().string();
  installSceneApi(*sandbox_, &build_);
  sandbox_->run(source, name_, options.limits.loadInstructions, options.limits.loadAllocationBytes);
  build_.loading = false;
  build_.inCall = false;

  for (const auto& [key, value] : options.parameters) {
    bool declared = false;
    std::string names;
    for (const ScriptParameter& p : build_.parameters) {
      declared = declared || p.name == key;
      names += (names.empty() ? "" : ", ") + p.name;
    }
    if (!declared && options.strictParameters) {
      throw InputError({name_, "--set " + key, 0},
                       fmt::format("the script declares no such parameter (it declares: {})",
                                   names.empty() ? "none" : names));
    }
  }
  animated_ = sandbox_->hasGlobalFunction("update");
  build_.scene.animated = animated_;
  try {
    build_.scene.validate();
  } catch (const InputError& e) {
    throw e.inFile(name_);
  }
  // An animated scene starts as its update(0, 0) shows it.
  if (animated_) setTime(0.0);
}

void SceneScript::setTime(double t) {
  if (!std::isfinite(t)) throw InputError({name_, "time", 0}, "must be finite");
  if (!animated_) {
    time_ = t;
    return;
  }
  const AnimatedState before(build_.scene, build_.models);
  try {
    build_.inCall = false;
    sandbox_->startBudget(sandbox_->limits().updateInstructions,
                          sandbox_->limits().updateAllocationBytes);
    publishParameters(*sandbox_, build_);
    sandbox_->call("update", {t, t - time_}, sandbox_->limits().updateInstructions,
                   sandbox_->limits().updateAllocationBytes);
    build_.scene.validate();
  } catch (const InputError& e) {
    before.restore(&build_.scene, &build_.models);
    if (e.location().file.empty()) throw e.inFile(name_);
    throw;
  }
  time_ = t;
}

void SceneScript::setParameter(const std::string& name, double value) {
  for (ScriptParameter& p : build_.parameters) {
    if (p.name != name) continue;
    if (!std::isfinite(value) || value < p.min || value > p.max) {
      throw InputError(
          {name_, "parameter " + name, 0},
          fmt::format("{} is outside its range [{}, {}] ({})", value, p.min, p.max, p.description));
    }
    p.value = value;
    return;
  }
  throw InputError({name_, "parameter " + name, 0}, "the script declares no such parameter");
}

std::vector<std::string> SceneScript::files() const {
  std::vector<std::string> files;
  if (!path_.empty()) files.push_back(path_);
  for (const std::string& f : sandbox_->requiredFiles()) files.push_back(f);
  for (const std::string& f : build_.assets) files.push_back(f);
  return files;
}

}  // namespace parallax
