#include "scripts/scene_api.h"

#include <fmt/format.h>

#include <cmath>
#include <lua.hpp>

#include "common/input_error.h"
#include "scripts/lua_values.h"
#include "scripts/scene_api_functions.h"
#include "scripts/script_paths.h"
#include "scripts/script_sandbox.h"

namespace parallax {
namespace {

using lua::HandleKind;
using lua::Options;
using lua::ScriptArgumentError;
using namespace scene_api_detail;  // NOLINT: the geometry half of the binding

// ---- scene settings ----

int apiName(lua_State* L, SceneBuild& b) {
  b.scene.name = lua::toString(L, 1, "name");
  return 0;
}

int apiBackground(lua_State* L, SceneBuild& b) {
  b.scene.background = lua::toColor(L, 1, "colour");
  return 0;
}

int apiAmbient(lua_State* L, SceneBuild& b) {
  b.scene.ambient = lua::toColor(L, 1, "colour");
  return 0;
}

int apiMaxDepth(lua_State* L, SceneBuild& b) {
  b.scene.maxDepth = static_cast<int>(lua::toInteger(L, 1, "depth", 1, 16));
  return 0;
}

int apiWorldBox(lua_State* L, SceneBuild& b) {
  if (lua_isnone(L, 1)) {
    if (b.scene.instances.empty())
      throw ScriptArgumentError("no geometry yet to take the bounds of");
    b.scene.worldBox = b.scene.geometryBounds();
    return 0;
  }
  const Options o(L, 1, "options", {"min", "max"});
  const Box3 box{o.vector3("min"), o.vector3("max")};
  if ((box.max.array() <= box.min.array()).any())
    throw ScriptArgumentError("max must exceed min on every axis");
  b.scene.worldBox = box;
  return 0;
}

// ---- materials ----

float shininessField(const Options& o, float fallback) {
  const double v = o.number("shininess", fallback);
  if (v < 0.0 || v > 1e6)
    throw ScriptArgumentError(fmt::format("shininess: must be in [0, 1e6], got {}", v));
  return static_cast<float>(v);
}

float iorField(const Options& o, float fallback) {
  const double v = o.number("ior", fallback);
  if (!(v > 0.0) || v > 100.0)
    throw ScriptArgumentError(fmt::format("ior: must be in (0, 100], got {}", v));
  return static_cast<float>(v);
}

int addMaterial(lua_State* L, SceneBuild& b, Material m, const std::string& name) {
  m.name = name;
  pushHandle(L, HandleKind::kMaterial, b.scene.addMaterial(std::move(m)));
  return 1;
}

int textureField(lua_State* L, const Options& o) {
  const int i = o.push("texture");
  const int texture = lua_isnil(L, i) ? -1 : lua::toHandle(L, i, HandleKind::kTexture, "texture");
  lua_pop(L, 1);
  return texture;
}

int apiDiffuse(lua_State* L, SceneBuild& b) {
  const Options o(L, 1, "options", {"color", "texture", "name"});
  return addMaterial(
      L, b, Material::makeDiffuse(o.color("color", Rgb(0.8f, 0.8f, 0.8f)), textureField(L, o)),
      o.string("name", "diffuse"));
}

int apiPhong(lua_State* L, SceneBuild& b) {
  const Options o(L, 1, "options", {"color", "specular", "shininess", "texture", "name"});
  Material m =
      Material::makePhong(o.color("color", Rgb(0.8f, 0.8f, 0.8f)),
                          o.color("specular", Rgb(0.5f, 0.5f, 0.5f)), shininessField(o, 32.0f));
  m.diffuseTexture = textureField(L, o);
  return addMaterial(L, b, m, o.string("name", "phong"));
}

int apiMirror(lua_State* L, SceneBuild& b) {
  const Options o(L, 1, "options", {"reflectance", "name"});
  return addMaterial(L, b, Material::makeMirror(o.color("reflectance", Rgb(0.9f, 0.9f, 0.9f))),
                     o.string("name", "mirror"));
}

int apiGlass(lua_State* L, SceneBuild& b) {
  const Options o(L, 1, "options", {"ior", "absorption", "name"});
  return addMaterial(
      L, b, Material::makeDielectric(iorField(o, 1.5f), o.color("absorption", Rgb::Zero())),
      o.string("name", "glass"));
}

int apiEmissive(lua_State* L, SceneBuild& b) {
  const Options o(L, 1, "options", {"color", "texture", "name"});
  return addMaterial(L, b,
                     Material::makeEmissive(o.color("color", Rgb::Ones()), textureField(L, o)),
                     o.string("name", "emissive"));
}

int apiSetMaterial(lua_State* L, SceneBuild& b) {
  const int index = lua::toHandle(L, 1, HandleKind::kMaterial, "material");
  const Options o(
      L, 2, "options",
      {"color", "specular", "shininess", "reflectance", "ior", "absorption", "emission"});
  Material& m = b.scene.materials.at(static_cast<size_t>(index));
  m.diffuse = o.color("color", m.diffuse);
  m.specular = o.color("specular", m.specular);
  m.shininess = shininessField(o, m.shininess);
  m.reflectance = o.color("reflectance", m.reflectance);
  m.ior = iorField(o, m.ior);
  m.absorption = o.color("absorption", m.absorption);
  m.emission = o.color("emission", m.emission);
  return 0;
}

// ---- transforms ----

int apiIdentity(lua_State* L, SceneBuild&) {
  lua::pushTransform(L, Eigen::Affine3d::Identity());
  return 1;
}

int apiTranslate(lua_State* L, SceneBuild&) {
  const Eigen::Vector3d t(lua::toNumber(L, 1, "x"), lua::toNumber(L, 2, "y"),
                          lua::toNumber(L, 3, "z"));
  lua::pushTransform(L, Eigen::Affine3d(Eigen::Translation3d(t)));
  return 1;
}

int rotateAbout(lua_State* L, const Eigen::Vector3d& axis) {
  lua::pushTransform(
      L, Eigen::Affine3d(Eigen::AngleAxisd(lua::toNumber(L, 1, "angle (radians)"), axis)));
  return 1;
}
int apiRotateX(lua_State* L, SceneBuild&) { return rotateAbout(L, Eigen::Vector3d::UnitX()); }
int apiRotateY(lua_State* L, SceneBuild&) { return rotateAbout(L, Eigen::Vector3d::UnitY()); }
int apiRotateZ(lua_State* L, SceneBuild&) { return rotateAbout(L, Eigen::Vector3d::UnitZ()); }

int apiRotate(lua_State* L, SceneBuild&) {
  const Eigen::Vector3d axis = lua::toVector3(L, 1, "axis");
  if (!(axis.norm() > 1e-12)) throw ScriptArgumentError("axis: must not be zero");
  lua::pushTransform(L, Eigen::Affine3d(Eigen::AngleAxisd(lua::toNumber(L, 2, "angle (radians)"),
                                                          axis.normalized())));
  return 1;
}

int apiScale(lua_State* L, SceneBuild&) {
  const double sx = lua::toNumber(L, 1, "scale");
  const double sy = lua_isnone(L, 2) ? sx : lua::toNumber(L, 2, "y scale");
  const double sz = lua_isnone(L, 3) ? sx : lua::toNumber(L, 3, "z scale");
  if (sx == 0.0 || sy == 0.0 || sz == 0.0) throw ScriptArgumentError("scale must not be zero");
  lua::pushTransform(L, Eigen::Affine3d(Eigen::Scaling(sx, sy, sz)));
  return 1;
}

// ---- lights ----

int apiDirectional(lua_State* L, SceneBuild& b) {
  const Options o(L, 1, "options", {"direction", "color"});
  const Eigen::Vector3d d = o.vector3("direction");
  if (!(d.norm() > 0.0)) throw ScriptArgumentError("direction: must not be zero");
  b.scene.addLight(Light::makeDirectional(d, o.color("color", Rgb::Ones())));
  pushHandle(L, HandleKind::kLight, static_cast<int>(b.scene.lights.size() - 1));
  return 1;
}

int apiPoint(lua_State* L, SceneBuild& b) {
  const Options o(L, 1, "options", {"position", "color"});
  b.scene.addLight(Light::makePoint(o.vector3("position"), o.color("color", Rgb::Ones())));
  pushHandle(L, HandleKind::kLight, static_cast<int>(b.scene.lights.size() - 1));
  return 1;
}

int apiSetLight(lua_State* L, SceneBuild& b) {
  Light& light =
      b.scene.lights.at(static_cast<size_t>(lua::toHandle(L, 1, HandleKind::kLight, "light")));
  const Options o(L, 2, "options", {"direction", "position", "color"});
  const Eigen::Vector3d d = o.vector3("direction", light.direction);
  if (!(d.norm() > 0.0)) throw ScriptArgumentError("direction: must not be zero");
  light.direction = d;
  light.position = o.vector3("position", light.position);
  light.intensity = o.color("color", light.intensity);
  return 0;
}

// ---- parameters ----

int apiParam(lua_State* L, SceneBuild& b) {
  const Options o(L, 1, "options", {"name", "default", "min", "max", "description"});
  ScriptParameter p;
  p.name = o.string("name", "");
  if (p.name.empty()) throw ScriptArgumentError("name: required");
  for (const ScriptParameter& q : b.parameters) {
    if (q.name == p.name)
      throw ScriptArgumentError(fmt::format("parameter \"{}\" is declared twice", p.name));
  }
  p.defaultValue = o.number("default");
  p.min = o.number("min");
  p.max = o.number("max");
  p.description = o.string("description", "");
  if (!(p.min <= p.defaultValue && p.defaultValue <= p.max)) {
    throw ScriptArgumentError(fmt::format("\"{}\": default {} is outside [{}, {}]", p.name,
                                          p.defaultValue, p.min, p.max));
  }
  p.value = p.defaultValue;
  if (auto it = b.overrides.find(p.name); it != b.overrides.end()) {
    if (!(p.min <= it->second && it->second <= p.max)) {
      throw ScriptArgumentError(fmt::format("\"{}\" was set to {}, outside its range [{}, {}]",
                                            p.name, it->second, p.min, p.max));
    }
    p.value = it->second;
  }
  b.parameters.push_back(p);
  // Raw access: no metamethod of the script's may run (and raise) while C++ objects are live.
  lua_rawgeti(L, LUA_REGISTRYINDEX, LUA_RIDX_GLOBALS);
  lua_pushstring(L, "params");
  if (lua_rawget(L, -2) == LUA_TTABLE) {
    lua_pushstring(L, p.name.c_str());
    lua_pushnumber(L, p.value);
    lua_rawset(L, -3);
  }
  lua_pop(L, 2);
  lua_pushnumber(L, p.value);
  return 1;
}

// ---- the registry ----

struct ApiFunction {
  SceneApiEntry doc;
  int (*impl)(lua_State*, SceneBuild&);
  bool loadOnly;  // adds to the scene: only while the script builds it, never in update()
};

const std::vector<ApiFunction>& apiFunctions() {
  static const std::vector<ApiFunction> functions = {
      {{"name", "px.name(text)", "Names the scene (shown by render and the daemon).",
        R"(px.name("cornell"))"},
       apiName,
       true},
      {{"background", "px.background({r, g, b})", "Colour of rays that hit nothing (linear RGB).",
        "px.background({0.02, 0.02, 0.03})"},
       apiBackground,
       false},
      {{"ambient", "px.ambient({r, g, b})",
        "Constant light added to diffuse surfaces (times albedo).",
        "px.ambient({0.04, 0.04, 0.04})"},
       apiAmbient,
       false},
      {{"max_depth", "px.max_depth(n)",
        "Whitted recursion limit, 1..16 (1: primary rays only); default 5.", "px.max_depth(5)"},
       apiMaxDepth,
       true},
      {{"world_box", "px.world_box{min = {x, y, z}, max = {x, y, z}} | px.world_box()",
        "Sets B_W, the part of world space shown in the display's box B_P (the presets': "
        "1.6 x 0.9 x 0.5 m around the screen centre); with no argument, the bounds of the "
        "geometry so far. World units are scaled uniformly, by the largest factor that fits "
        "B_W inside B_P on every axis (min over x, y, z of B_P's size / B_W's; a flat axis "
        "does not count), and B_W's centre goes to B_P's: the tightest axis sets the size, "
        "so a box deeper than the display's shallow B_P comes out small. Keep B_W close "
        "around what matters, in B_P's proportions.",
        "px.world_box{min = {-2, 0, -1.25}, max = {2, 2.25, 1.25}}"},
       apiWorldBox,
       true},
      {{"diffuse", "px.diffuse{color =, texture =, name =} -> material",
        "A Lambert material, optionally textured.",
        R"(local white = px.diffuse{color = {0.73, 0.73, 0.73}, name = "white"})"},
       apiDiffuse,
       true},
      {{"phong", "px.phong{color =, specular =, shininess =, texture =, name =} -> material",
        "A Lambert material with a Phong highlight.",
        "local gold = px.phong{color = {0.8, 0.6, 0.2}, specular = {0.6, 0.6, 0.5}, shininess = "
        "60}"},
       apiPhong,
       true},
      {{"mirror", "px.mirror{reflectance =, name =} -> material",
        "A perfect mirror scaled by reflectance.",
        "local m = px.mirror{reflectance = {0.85, 0.85, 0.85}}"},
       apiMirror,
       true},
      {{"glass", "px.glass{ior =, absorption =, name =} -> material",
        "A dielectric: Fresnel reflection and refraction, absorption per world unit inside.",
        "local g = px.glass{ior = 1.45, absorption = {0.2, 0.9, 1.8}}"},
       apiGlass,
       true},
      {{"emissive", "px.emissive{color =, texture =, name =} -> material",
        "An unlit surface that emits its colour.", "local lamp = px.emissive{color = {4, 3.6, 3}}"},
       apiEmissive,
       true},
      {{"set_material",
        "px.set_material(material, {color =, specular =, shininess =, reflectance =, ior =, "
        "absorption =, emission =})",
        "Changes a material's parameters (in update, to animate them).",
        "px.set_material(lamp, {emission = {4 * k, 3.6 * k, 3 * k}})"},
       apiSetMaterial,
       false},
      {{"texture", "px.texture{path =, fallback =, srgb =} -> texture",
        "An image file (watched for hot reload); the fallback colour if it cannot be read.",
        R"(local wood = px.texture{path = "textures/wood.png", fallback = {0.5, 0.35, 0.2}})"},
       apiTexture,
       true},
      {{"image", "px.image{width =, height =, pixels = {r, g, b, ...}, fallback =} -> texture",
        "An inline texture: width × height × 3 linear values, row 0 at the top.",
        "local t = px.image{width = 2, height = 1, pixels = {1, 0, 0, 0, 0, 1}}"},
       apiImage,
       true},
      {{"grid", "px.grid{width =, height =, nx =, ny =, material =, name =, transform =} -> object",
        "A rectangle in the x-y plane facing +z, split into nx × ny quads.",
        "px.grid{width = 1, height = 1, nx = 10, ny = 10, material = white}"},
       apiGrid,
       true},
      {{"plane", "px.plane{width =, height =, material =, name =, transform =} -> object",
        "A rectangle in the x-y plane facing +z (2 triangles).",
        "px.plane{width = 4, height = 2, material = wall}"},
       apiPlane,
       true},
      {{"box", "px.box{size = {x, y, z}, material =, name =, transform =} -> object",
        "An axis-aligned box centred at the origin (12 triangles).",
        "px.box{size = {0.28, 0.58, 0.28}, material = white, transform = px.rotate_y(0.3)}"},
       apiBox,
       true},
      {{"sphere",
        "px.sphere{radius =, slices = 24, stacks = 12, material =, name =, transform =} -> object",
        "A UV sphere: 2 · slices · (stacks − 1) triangles.",
        "px.sphere{radius = 0.5, material = glass}"},
       apiSphere,
       true},
      {{"torus",
        "px.torus{major =, minor =, segments = 24, sides = 12, material =, name =, transform =} -> "
        "object",
        "A torus around the y axis: 2 · segments · sides triangles.",
        "px.torus{major = 0.42, minor = 0.14, material = gold}"},
       apiTorus,
       true},
      {{"cylinder",
        "px.cylinder{radius =, height =, slices = 24, material =, name =, transform =} -> object",
        "A closed cylinder along y, centred: 4 · slices triangles.",
        "px.cylinder{radius = 0.28, height = 1, material = red}"},
       apiCylinder,
       true},
      {{"cone",
        "px.cone{radius =, height =, slices = 24, material =, name =, transform =} -> object",
        "A closed cone along y, base at −height/2: 2 · slices triangles.",
        "px.cone{radius = 0.35, height = 0.9, material = green}"},
       apiCone,
       true},
      {{"mesh",
        "px.mesh{positions =, triangles =, normals =, uvs =, colors =, material =, name =, "
        "transform =} -> object",
        "A triangle mesh given inline; triangle indices are 1-based.",
        "px.mesh{positions = {{0,0,0}, {1,0,0}, {0,1,0}}, triangles = {{1, 2, 3}}, material = "
        "white}"},
       apiMesh,
       true},
      {{"model", "px.model{path =, height =, transform =} -> {object, ...}, model",
        "Meshes, materials and textures of a model file (OBJ, glTF, FBX, COLLADA, ... through "
        "assimp), scaled to `height` with its base at the origin (0: its own units), then placed "
        "by transform; watched for hot reload. The second result is the model, for "
        "px.animations and px.set_animation; an animated file shows its rest pose until posed, "
        "and the scene's bounds (px.world_box(), an unset world box) cover all its animations.",
        R"(local wuson = px.model{path = "assimp:OBJ/WusonOBJ.obj", height = 1.1, transform = px.translate(-0.55, 0.4, 0)})"},
       apiModel,
       true},
      {{"animations", "px.animations(model) -> {{name =, duration =}, ...}",
        "The model file's animations (node and skeletal; morph targets are not played) with "
        "their lengths in seconds; an unnamed one is called \"animation N\". Empty for a still "
        "file.",
        R"(local _, walker = px.model{path = "assimp:X/Testwuson.X", height = 1}; for i, a in ipairs(px.animations(walker)) do print(i, a.name, a.duration) end)"},
       apiAnimations,
       false},
      {{"set_animation", "px.set_animation(model, animation, t [, transform])",
        "Poses the model at time t (seconds) of an animation, named or numbered as "
        "px.animations lists it; t outside [0, duration] wraps (the animation loops). Keys are "
        "interpolated linearly (rotations spherically), skinned meshes deformed by their bones; "
        "transform, if given, places the whole model anew (it replaces px.model's). Call it in "
        "update(t, dt) to play the animation.",
        R"(function update(t) px.set_animation(walker, "Wuson_Walk", t, px.rotate_y(0.4 * t)) end)"},
       apiSetAnimation,
       false},
      {{"instance", "px.instance(object, transform) -> object",
        "Draws an object's mesh once more, elsewhere.",
        "local copy = px.instance(tree, px.translate(2, 0, 0))"},
       apiInstance,
       true},
      {{"set_transform", "px.set_transform(object, transform)",
        "Moves an object (in update, to animate it).",
        "px.set_transform(ball, px.translate(math.cos(t), 0.5, math.sin(t)))"},
       apiSetTransform,
       false},
      {{"triangle_count", "px.triangle_count() -> n",
        "Triangles drawn so far (over all instances).", "print(px.triangle_count())"},
       apiTriangleCount,
       false},
      {{"identity", "px.identity() -> transform", "The identity transform.",
        "local t = px.identity()"},
       apiIdentity,
       false},
      {{"translate", "px.translate(x, y, z) -> transform", "A translation.",
        "px.translate(0.5, 0, 0.5)"},
       apiTranslate,
       false},
      {{"rotate_x", "px.rotate_x(radians) -> transform",
        "A rotation about the x axis (right-handed).", "px.rotate_x(-math.pi / 2)"},
       apiRotateX,
       false},
      {{"rotate_y", "px.rotate_y(radians) -> transform",
        "A rotation about the y axis (right-handed).", "px.rotate_y(0.3)"},
       apiRotateY,
       false},
      {{"rotate_z", "px.rotate_z(radians) -> transform",
        "A rotation about the z axis (right-handed).", "px.rotate_z(0.1)"},
       apiRotateZ,
       false},
      {{"rotate", "px.rotate({x, y, z}, radians) -> transform",
        "A rotation about any axis (normalised for you).", "px.rotate({1, 1, 0}, 0.5)"},
       apiRotate,
       false},
      {{"scale", "px.scale(s) | px.scale(sx, sy, sz) -> transform",
        "A uniform or per-axis scaling.", "px.scale(2)"},
       apiScale,
       false},
      {{"directional", "px.directional{direction = {x, y, z}, color =} -> light",
        "A directional light; direction is the way the light travels; colour is its irradiance.",
        "local sun = px.directional{direction = {0.3, -0.3, -1}, color = {0.32, 0.32, 0.3}}"},
       apiDirectional,
       true},
      {{"point", "px.point{position = {x, y, z}, color =} -> light",
        "A point light; colour is the irradiance at 1 world unit.",
        "px.point{position = {0, 2, 1}, color = {1, 1, 1}}"},
       apiPoint,
       true},
      {{"set_light", "px.set_light(light, {direction =, position =, color =})",
        "Changes a light (in update, to animate it).",
        "px.set_light(sun, {direction = {math.sin(t), -0.3, -1}})"},
       apiSetLight,
       false},
      {{"param", "px.param{name =, default =, min =, max =, description =} -> value",
        "Declares a number the user can change (render --set name=value, the daemon); its current "
        "value is also params.name.",
        R"(local speed = px.param{name = "speed", default = 0.25, min = 0, max = 2, description = "turns a second"})"},
       apiParam,
       true},
  };
  return functions;
}

int dispatch(lua_State* L) {
  const ApiFunction& f = apiFunctions()[static_cast<size_t>(lua_tointeger(L, lua_upvalueindex(1)))];
  try {
    SceneBuild& b = buildOf(L);
    if (f.loadOnly && !b.loading) {
      throw ScriptArgumentError(
          "adds to the scene, so it can be called only while the script builds it, not in "
          "update()");
    }
    if (b.inCall) throw ScriptArgumentError("cannot be called from a finalizer (__gc)");
    b.inCall = true;
    int results = 0;
    try {
      results = f.impl(L, b);
    } catch (...) {
      b.inCall = false;
      throw;
    }
    b.inCall = false;
    return results;
  } catch (const std::exception& e) {
    lua_pushfstring(L, "px.%s: %s", f.doc.name, e.what());
  }
  // Raised only here, with every C++ object of the call destroyed.
  luaL_where(L, 1);
  lua_insert(L, -2);
  lua_concat(L, 2);
  return lua_error(L);
}

int installProtected(lua_State* L) {
  lua::registerTransformType(L);
  lua::registerHandleType(L);
  const auto& functions = apiFunctions();
  lua_createtable(L, 0, static_cast<int>(functions.size()));
  for (size_t i = 0; i < functions.size(); ++i) {
    lua_pushinteger(L, static_cast<lua_Integer>(i));
    lua_pushcclosure(L, &dispatch, 1);
    lua_setfield(L, -2, functions[i].doc.name);
  }
  lua_setglobal(L, "px");
  lua_newtable(L);
  lua_setglobal(L, "params");
  return 0;
}

int publishProtected(lua_State* L) {
  const SceneBuild& b = buildOf(L);
  lua_rawgeti(L, LUA_REGISTRYINDEX, LUA_RIDX_GLOBALS);
  lua_pushstring(L, "params");
  lua_newtable(L);
  for (const ScriptParameter& p : b.parameters) {
    lua_pushnumber(L, p.value);
    lua_setfield(L, -2, p.name.c_str());
  }
  lua_rawset(L, -3);  // raw: a metamethod of the script's on _G does not get a say
  return 0;
}

void runProtected(ScriptSandbox& sandbox, lua_CFunction f) {
  lua_State* L = sandbox.state();
  lua_pushcfunction(L, f);
  if (lua_pcall(L, 0, 0, 0) != LUA_OK) {
    const std::string message = lua_tostring(L, -1) ? lua_tostring(L, -1) : "?";
    lua_pop(L, 1);
    throw InputError({"", "params", 0}, "cannot publish the parameters: " + message);
  }
}

}  // namespace

void installSceneApi(ScriptSandbox& sandbox, SceneBuild* build) {
  sandbox.context = build;
  runProtected(sandbox, &installProtected);
}

void publishParameters(ScriptSandbox& sandbox, const SceneBuild&) {
  runProtected(sandbox, &publishProtected);
}

const std::vector<SceneApiEntry>& sceneApiReference() {
  static const std::vector<SceneApiEntry> entries = [] {
    std::vector<SceneApiEntry> e;
    for (const ApiFunction& f : apiFunctions()) e.push_back(f.doc);
    return e;
  }();
  return entries;
}

std::string sceneApiMarkdown() {
  std::string text =
      "# Scene script API\n\n"
      "Generated from the binding's registry (`parallax scene-api`); do not edit by hand.\n\n"
      "A scene script is Lua 5.4 in a sandbox (no io, os, debug, package, binary chunks, `__gc`\n"
      "finalizers; `require` only "
      "finds modules of the scene library and the script's folder). It builds the scene through "
      "the\n"
      "global table `px` and may define `update(t, dt)`, called with the animation time in "
      "seconds, to\n"
      "move objects and change lights and materials. Values declared with `px.param` are in the\n"
      "global table `params`. Colours are linear RGB tables `{r, g, b}`, points and directions\n"
      "`{x, y, z}`; transforms compose with `*` (the right one applies first). Functions marked\n"
      "*build* add to the scene and can be called only while the script loads, not in `update`.\n"
      "Files are named relative to the script's folder (no `..`, no absolute paths, no symlinks\n"
      "leading out) or below a trusted root by prefix: `assimp:` is Debian's assimp-testmodels.\n\n"
      "| function | what it does | example |\n|---|---|---|\n";
  for (const ApiFunction& f : apiFunctions()) {
    std::string example = f.doc.example;
    std::string signature = f.doc.signature;
    for (std::string* s : {&example, &signature}) {
      for (size_t at = s->find('|'); at != std::string::npos; at = s->find('|', at + 2))
        s->replace(at, 1, "\\|");
    }
    text += fmt::format("| `{}` | {}{} | `{}` |\n", signature, f.doc.description,
                        f.loadOnly ? " *build*" : "", example);
  }
  return text;
}

}  // namespace parallax
