#include <fmt/format.h>

#include <cmath>
#include <lua.hpp>

#include "common/input_error.h"
#include "scripts/lua_values.h"
#include "scripts/scene_api_functions.h"
#include "scripts/script_paths.h"
#include "scripts/script_sandbox.h"
#include "tracer/mesh_shapes.h"
#include "tracer/model_loader.h"

namespace parallax::scene_api_detail {
namespace {

using lua::HandleKind;
using lua::Options;
using lua::ScriptArgumentError;

constexpr long kMaxTessellation = 4096;  // slices, stacks, grid cells along one side

// A file the script names: below its own folder, or below a trusted asset root when the
// path starts with that root's prefix ("assimp:OBJ/spider.obj").
std::string resolveAsset(lua_State* L, const SceneBuild& b, const std::string& path) {
  const size_t colon = path.find(':');
  if (colon != std::string::npos && colon > 1) {
    const auto root = b.assetRoots.find(path.substr(0, colon));
    if (root == b.assetRoots.end()) {
      std::string known;
      for (const auto& [name, folder] : b.assetRoots)
        known += (known.empty() ? "" : ", ") + name + ":";
      throw ScriptArgumentError(fmt::format("\"{}\": unknown asset root (known: {})", path,
                                            known.empty() ? "none" : known));
    }
    return resolvePathBelow(root->second, path.substr(colon + 1));
  }
  return resolvePathBelow(ScriptSandbox::of(L).folder(), path);
}

}  // namespace

SceneBuild& buildOf(lua_State* L) {
  return *static_cast<SceneBuild*>(ScriptSandbox::of(L).context);
}

// ---- textures ----

int apiTexture(lua_State* L, SceneBuild& b) {
  const Options o(L, 1, "options", {"path", "fallback", "srgb"});
  const std::string relative = o.string("path", "");
  const std::string path = resolveAsset(L, b, relative);
  Texture t;
  t.path = path;
  t.fallback = o.color("fallback", t.fallback);
  t.srgb = o.boolean("srgb", true);
  b.assets.push_back(path);
  pushHandle(L, HandleKind::kTexture, b.scene.addTexture(std::move(t)));
  return 1;
}

int apiImage(lua_State* L, SceneBuild& b) {
  const Options o(L, 1, "options", {"width", "height", "pixels", "fallback"});
  const long limit = ScriptSandbox::of(L).limits().maxTexturePixels;
  if (!o.has("width") || !o.has("height")) throw ScriptArgumentError("width and height: required");
  const long width = o.integer("width", 0, 1, 1 << 16);
  const long height = o.integer("height", 0, 1, 1 << 16);
  long used = 0;
  for (const Texture& t : b.scene.textures) used += static_cast<long>(t.width) * t.height;
  if (used + width * height > limit) {
    throw ScriptArgumentError(
        fmt::format("{}×{} pixels would pass the scene's limit of {} inline texture pixels", width,
                    height, limit));
  }
  const int list = o.push("pixels");
  const size_t count = static_cast<size_t>(width * height * 3);
  if (lua_type(L, list) != LUA_TTABLE || lua_rawlen(L, list) != count) {
    throw ScriptArgumentError(
        fmt::format("pixels: expected a table of width × height × 3 = {} numbers", count));
  }
  Texture t;
  t.width = static_cast<int>(width);
  t.height = static_cast<int>(height);
  t.pixels.resize(count);
  for (size_t i = 0; i < count; ++i) {
    lua_rawgeti(L, list, static_cast<lua_Integer>(i + 1));
    const double v = lua::toNumber(L, -1, fmt::format("pixels[{}]", i + 1));
    if (v < 0.0)
      throw ScriptArgumentError(fmt::format("pixels[{}]: must be >= 0, got {}", i + 1, v));
    t.pixels[i] = static_cast<float>(v);
    lua_pop(L, 1);
  }
  lua_pop(L, 1);
  t.fallback = o.color("fallback", t.fallback);
  pushHandle(L, HandleKind::kTexture, b.scene.addTexture(std::move(t)));
  return 1;
}

// ---- geometry ----

// The options every object shares: {material =, name =, transform =}.
struct Placement {
  int material = 0;
  std::string name;
  Eigen::Affine3d worldFromObject = Eigen::Affine3d::Identity();
};

Placement placement(lua_State* L, SceneBuild& b, const Options& o, const char* defaultName) {
  Placement p;
  const int m = o.push("material");
  if (lua_isnil(L, m))
    throw ScriptArgumentError("material: required (from px.diffuse, px.mirror, ...)");
  p.material = lua::toHandle(L, m, HandleKind::kMaterial, "material");
  lua_pop(L, 1);
  p.name = o.string("name", defaultName);
  const int t = o.push("transform");
  if (!lua_isnil(L, t)) p.worldFromObject = lua::toTransform(L, t, "transform");
  lua_pop(L, 1);
  (void)b;
  return p;
}

void checkTriangleBudget(lua_State* L, const SceneBuild& b, long adding) {
  const long limit = ScriptSandbox::of(L).limits().maxTriangles;
  long meshTriangles = 0;
  for (const Mesh& mesh : b.scene.meshes) meshTriangles += static_cast<long>(mesh.triangles.size());
  if (adding < 0 || meshTriangles + adding > limit) {
    throw ScriptArgumentError(
        fmt::format("{} more triangles would pass the scene's limit of {}", adding, limit));
  }
}

void checkInstanceBudget(lua_State* L, const SceneBuild& b, size_t adding) {
  const long limit = ScriptSandbox::of(L).limits().maxInstances;
  const size_t total = b.scene.instances.size() + adding;
  if (total > static_cast<size_t>(limit)) {
    throw ScriptArgumentError(
        fmt::format("{} objects would pass the scene's limit of {} (px.instance, px.model's "
                    "parts and every shape count)",
                    total, limit));
  }
}

int addObject(lua_State* L, SceneBuild& b, Mesh mesh, const Placement& p) {
  checkInstanceBudget(L, b, 1);
  mesh.material = p.material;
  mesh.name = p.name;
  const int meshIndex = b.scene.addMesh(std::move(mesh), false);
  pushHandle(L, HandleKind::kObject, b.scene.addInstance(meshIndex, p.worldFromObject));
  return 1;
}

double positive(const Options& o, const char* key, double fallback) {
  const double v = o.number(key, fallback);
  if (!(v > 0.0)) throw ScriptArgumentError(fmt::format("{}: must be positive, got {}", key, v));
  return v;
}

int apiGrid(lua_State* L, SceneBuild& b) {
  const Options o(L, 1, "options",
                  {"width", "height", "nx", "ny", "material", "name", "transform"});
  const long nx = o.integer("nx", 1, 1, kMaxTessellation),
             ny = o.integer("ny", 1, 1, kMaxTessellation);
  checkTriangleBudget(L, b, 2 * nx * ny);
  const Placement p = placement(L, b, o, "grid");
  return addObject(
      L, b, makeGrid(positive(o, "width", 1.0), positive(o, "height", 1.0), int(nx), int(ny)), p);
}

int apiPlane(lua_State* L, SceneBuild& b) {
  const Options o(L, 1, "options", {"width", "height", "material", "name", "transform"});
  const Placement p = placement(L, b, o, "plane");
  checkTriangleBudget(L, b, 2);
  return addObject(L, b, makeGrid(positive(o, "width", 1.0), positive(o, "height", 1.0), 1, 1), p);
}

int apiBox(lua_State* L, SceneBuild& b) {
  const Options o(L, 1, "options", {"size", "material", "name", "transform"});
  const Eigen::Vector3d size = o.vector3("size", Eigen::Vector3d::Ones());
  if ((size.array() <= 0.0).any()) throw ScriptArgumentError("size: every side must be positive");
  const Placement p = placement(L, b, o, "box");
  checkTriangleBudget(L, b, 12);
  return addObject(L, b, makeBox(size), p);
}

int apiSphere(lua_State* L, SceneBuild& b) {
  const Options o(L, 1, "options", {"radius", "slices", "stacks", "material", "name", "transform"});
  const long slices = o.integer("slices", 24, 3, kMaxTessellation),
             stacks = o.integer("stacks", 12, 2, kMaxTessellation);
  checkTriangleBudget(L, b, 2 * slices * (stacks - 1));
  const Placement p = placement(L, b, o, "sphere");
  return addObject(L, b, makeSphere(positive(o, "radius", 1.0), int(slices), int(stacks)), p);
}

int apiTorus(lua_State* L, SceneBuild& b) {
  const Options o(L, 1, "options",
                  {"major", "minor", "segments", "sides", "material", "name", "transform"});
  const long segments = o.integer("segments", 24, 3, kMaxTessellation),
             sides = o.integer("sides", 12, 3, kMaxTessellation);
  checkTriangleBudget(L, b, 2 * segments * sides);
  const Placement p = placement(L, b, o, "torus");
  return addObject(
      L, b,
      makeTorus(positive(o, "major", 1.0), positive(o, "minor", 0.25), int(segments), int(sides)),
      p);
}

int apiCylinder(lua_State* L, SceneBuild& b) {
  const Options o(L, 1, "options", {"radius", "height", "slices", "material", "name", "transform"});
  const long slices = o.integer("slices", 24, 3, kMaxTessellation);
  checkTriangleBudget(L, b, 4 * slices);
  const Placement p = placement(L, b, o, "cylinder");
  return addObject(
      L, b, makeCylinder(positive(o, "radius", 0.5), positive(o, "height", 1.0), int(slices)), p);
}

int apiCone(lua_State* L, SceneBuild& b) {
  const Options o(L, 1, "options", {"radius", "height", "slices", "material", "name", "transform"});
  const long slices = o.integer("slices", 24, 3, kMaxTessellation);
  checkTriangleBudget(L, b, 2 * slices);
  const Placement p = placement(L, b, o, "cone");
  return addObject(
      L, b, makeCone(positive(o, "radius", 0.5), positive(o, "height", 1.0), int(slices)), p);
}

// Reads a list of n-tuples of numbers ({{x, y, z}, ...}) into `out` through `store`.
template <typename Store>
size_t readTuples(lua_State* L, const Options& o, const char* key, int arity, size_t maxCount,
                  Store store) {
  const int list = o.push(key);
  if (lua_isnil(L, list)) {
    lua_pop(L, 1);
    return 0;
  }
  if (lua_type(L, list) != LUA_TTABLE)
    throw ScriptArgumentError(fmt::format("{}: expected a list of tables", key));
  const size_t count = lua_rawlen(L, list);
  if (count > maxCount)
    throw ScriptArgumentError(
        fmt::format("{}: {} entries, more than the {} allowed", key, count, maxCount));
  double v[4];
  for (size_t i = 0; i < count; ++i) {
    lua_rawgeti(L, list, static_cast<lua_Integer>(i + 1));
    if (lua_type(L, -1) != LUA_TTABLE || lua_rawlen(L, -1) != static_cast<size_t>(arity)) {
      throw ScriptArgumentError(fmt::format("{}[{}]: expected {} numbers", key, i + 1, arity));
    }
    for (int k = 0; k < arity; ++k) {
      lua_rawgeti(L, -1, k + 1);
      v[k] = lua::toNumber(L, -1, fmt::format("{}[{}][{}]", key, i + 1, k + 1));
      lua_pop(L, 1);
    }
    lua_pop(L, 1);
    store(i, v);
  }
  lua_pop(L, 1);
  return count;
}

int apiMesh(lua_State* L, SceneBuild& b) {
  const Options o(
      L, 1, "options",
      {"positions", "triangles", "normals", "uvs", "colors", "material", "name", "transform"});
  const size_t maxCount = static_cast<size_t>(ScriptSandbox::of(L).limits().maxTriangles) * 3;
  Mesh mesh;
  readTuples(L, o, "positions", 3, maxCount,
             [&](size_t, const double* v) { mesh.positions.emplace_back(v[0], v[1], v[2]); });
  if (mesh.positions.empty()) throw ScriptArgumentError("positions: required, a list of {x, y, z}");
  const double n = static_cast<double>(mesh.positions.size());
  readTuples(L, o, "triangles", 3, maxCount, [&](size_t i, const double* v) {
    std::array<std::uint32_t, 3> t{};
    for (int k = 0; k < 3; ++k) {
      // 1-based, as everything else in Lua.
      if (v[k] != std::floor(v[k]) || v[k] < 1 || v[k] > n) {
        throw ScriptArgumentError(fmt::format(
            "triangles[{}][{}]: vertex index must be 1..{}, got {}", i + 1, k + 1, n, v[k]));
      }
      t[static_cast<size_t>(k)] = static_cast<std::uint32_t>(v[k] - 1);
    }
    mesh.triangles.push_back(t);
  });
  if (mesh.triangles.empty())
    throw ScriptArgumentError("triangles: required, a list of {a, b, c} (1-based)");
  checkTriangleBudget(L, b, static_cast<long>(mesh.triangles.size()));
  auto perVertex = [&](const char* key, size_t count) {
    if (count != 0 && count != mesh.positions.size()) {
      throw ScriptArgumentError(fmt::format("{}: {} entries for {} positions (one per position)",
                                            key, count, mesh.positions.size()));
    }
  };
  perVertex("normals", readTuples(L, o, "normals", 3, maxCount, [&](size_t, const double* v) {
              mesh.normals.push_back(Eigen::Vector3d(v[0], v[1], v[2]).cast<float>());
            }));
  perVertex("uvs", readTuples(L, o, "uvs", 2, maxCount, [&](size_t, const double* v) {
              mesh.uvs.push_back(Eigen::Vector2d(v[0], v[1]).cast<float>());
            }));
  perVertex("colors", readTuples(L, o, "colors", 3, maxCount, [&](size_t, const double* v) {
              mesh.colors.push_back(Eigen::Vector3d(v[0], v[1], v[2]).cast<float>());
            }));
  const Placement p = placement(L, b, o, "mesh");
  return addObject(L, b, std::move(mesh), p);
}

int apiModel(lua_State* L, SceneBuild& b) {
  const Options o(L, 1, "options", {"path", "height", "transform"});
  const std::string path = resolveAsset(L, b, o.string("path", ""));
  ModelLoadOptions load;
  load.targetHeight = o.number("height", 0.0);
  if (load.targetHeight < 0.0)
    throw ScriptArgumentError("height: must be positive (or 0 for the model's own units)");
  const int t = o.push("transform");
  if (!lua_isnil(L, t)) load.worldFromModel = lua::toTransform(L, t, "transform");
  lua_pop(L, 1);
  b.assets.push_back(path);
  // Loaded into a scratch scene first, so a model over the triangle limit never lands.
  Scene scratch = b.scene;
  ModelAnimation animation;
  animation.file = path;
  try {
    appendModel(path, load, &scratch, &animation);
  } catch (const InputError& e) {
    throw ScriptArgumentError(e.what());
  }
  long added = 0;
  for (size_t i = b.scene.meshes.size(); i < scratch.meshes.size(); ++i)
    added += static_cast<long>(scratch.meshes[i].triangles.size());
  checkTriangleBudget(L, b, added);
  checkInstanceBudget(L, b, scratch.instances.size() - b.scene.instances.size());
  const size_t firstInstance = b.scene.instances.size();
  b.scene = std::move(scratch);
  b.models.push_back(std::move(animation));
  lua_createtable(L, static_cast<int>(b.scene.instances.size() - firstInstance), 0);
  for (size_t i = firstInstance; i < b.scene.instances.size(); ++i) {
    pushHandle(L, HandleKind::kObject, static_cast<int>(i));
    lua_rawseti(L, -2, static_cast<lua_Integer>(i - firstInstance + 1));
  }
  pushHandle(L, HandleKind::kModel, static_cast<int>(b.models.size() - 1));
  return 2;
}

int apiInstance(lua_State* L, SceneBuild& b) {
  const int object = lua::toHandle(L, 1, HandleKind::kObject, "object");
  const Eigen::Affine3d t = lua::toTransform(L, 2, "transform");
  const int mesh = b.scene.instances.at(static_cast<size_t>(object)).mesh;
  checkInstanceBudget(L, b, 1);
  pushHandle(L, HandleKind::kObject, b.scene.addInstance(mesh, t));
  return 1;
}

int apiSetTransform(lua_State* L, SceneBuild& b) {
  const int object = lua::toHandle(L, 1, HandleKind::kObject, "object");
  b.scene.instances.at(static_cast<size_t>(object)).worldFromObject =
      lua::toTransform(L, 2, "transform");
  if (!b.loading) b.scene.movedInstances.insert(object);  // placed at load: not moving
  return 0;
}

int apiTriangleCount(lua_State* L, SceneBuild& b) {
  lua_pushinteger(L, b.scene.triangleCount());
  return 1;
}

}  // namespace parallax::scene_api_detail
