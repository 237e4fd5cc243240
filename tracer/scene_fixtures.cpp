#include "tracer/scene_fixtures.h"

#include <fmt/format.h>

#include "common/input_error.h"
#include "tracer/mesh_shapes.h"

namespace parallax {
namespace {

Eigen::Affine3d translation(const Eigen::Vector3d& t) {
  return Eigen::Affine3d(Eigen::Translation3d(t));
}

Eigen::Affine3d rotationY(double radians) {
  return Eigen::Affine3d(Eigen::AngleAxisd(radians, Eigen::Vector3d::UnitY()));
}

Eigen::Affine3d rotationX(double radians) {
  return Eigen::Affine3d(Eigen::AngleAxisd(radians, Eigen::Vector3d::UnitX()));
}

Mesh withMaterial(Mesh mesh, int material, const std::string& name) {
  mesh.material = material;
  mesh.name = name;
  return mesh;
}

}  // namespace

void addPaperLights(Scene* scene) {
  // From the viewers' side and above, spread left/right so the shadows read in every module.
  const Rgb white(0.32f, 0.32f, 0.30f);
  scene->addLight(Light::makeDirectional({0.3, -0.3, -1.0}, white));
  scene->addLight(Light::makeDirectional({-0.3, -0.3, -1.0}, white));
  scene->addLight(Light::makeDirectional({0.8, -0.15, -0.6}, 0.6f * white));
  scene->addLight(Light::makeDirectional({-0.8, -0.15, -0.6}, 0.6f * white));
}

Scene makeXyzTriangleScene() {
  Scene scene;
  scene.name = "xyz";
  scene.addMaterial(Material::makeEmissive(Rgb::Ones()));
  Mesh mesh;
  mesh.name = "xyz_triangle";
  mesh.positions = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  mesh.colors = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  mesh.triangles = {{0, 1, 2}};
  scene.addMesh(mesh);
  scene.worldBox = Box3{Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones()};
  scene.maxDepth = 1;
  return scene;
}

Scene makeCornellScene(double scale, const Eigen::Vector3d& offset) {
  Scene scene;
  scene.name = "cornell";
  const int white = scene.addMaterial(Material::makeDiffuse({0.73f, 0.73f, 0.73f}));
  const int red = scene.addMaterial(Material::makeDiffuse({0.65f, 0.06f, 0.05f}));
  const int green = scene.addMaterial(Material::makeDiffuse({0.12f, 0.45f, 0.15f}));
  const int mirror = scene.addMaterial(Material::makeMirror({0.85f, 0.85f, 0.85f}));
  const int lamp = scene.addMaterial(Material::makeEmissive({4.0f, 3.6f, 3.0f}));
  const int blue =
      scene.addMaterial(Material::makePhong({0.15f, 0.2f, 0.6f}, {0.5f, 0.5f, 0.5f}, 40.0f));
  scene.materials[static_cast<size_t>(white)].name = "white";
  scene.materials[static_cast<size_t>(red)].name = "red";
  scene.materials[static_cast<size_t>(green)].name = "green";
  scene.materials[static_cast<size_t>(mirror)].name = "mirror_floor";
  scene.materials[static_cast<size_t>(lamp)].name = "lamp";
  scene.materials[static_cast<size_t>(blue)].name = "blue_phong";

  // The box is 1 wide, 1 tall and kDepth deep, so it fills the displayable box (1.6 × 0.9 ×
  // 0.5 m) from top to bottom instead of being limited by B_P's shallow depth; everything is
  // placed in it, then scaled and offset as a whole.
  constexpr double kDepth = 0.55;
  const Eigen::Affine3d worldFromBox = translation(offset) * Eigen::Scaling(scale);
  const Eigen::Affine3d shallow(Eigen::Scaling(1.0, 1.0, kDepth));
  auto add = [&](Mesh mesh, int material, const std::string& name,
                 const Eigen::Affine3d& boxFromObject) {
    scene.addMesh(withMaterial(std::move(mesh), material, name), true,
                  worldFromBox * boxFromObject);
  };
  constexpr double kHalfPi = 1.5707963267948966;
  // Walls: 10×10 grids (200 triangles each), facing into the box.
  add(makeGrid(1, 1, 10, 10), mirror, "floor",
      shallow * translation({0.5, 0, 0.5}) * rotationX(-kHalfPi));
  add(makeGrid(1, 1, 10, 10), white, "ceiling",
      shallow * translation({0.5, 1, 0.5}) * rotationX(kHalfPi));
  add(makeGrid(1, 1, 10, 10), white, "back", translation({0.5, 0.5, 0}));
  add(makeGrid(1, 1, 10, 10), red, "left",
      shallow * translation({0, 0.5, 0.5}) * rotationY(kHalfPi));
  add(makeGrid(1, 1, 10, 10), green, "right",
      shallow * translation({1, 0.5, 0.5}) * rotationY(-kHalfPi));
  // Ceiling lamp just below the ceiling (2 triangles).
  add(makeGrid(0.3, 0.3, 1, 1), lamp, "lamp", translation({0.5, 0.998, 0.26}) * rotationX(kHalfPi));
  // A tall and a short box (12 each) and a sphere (84).
  add(makeBox({0.28, 0.58, 0.28}), white, "tall_box",
      translation({0.32, 0.29, 0.2}) * rotationY(0.3));
  add(makeBox({0.27, 0.27, 0.27}), white, "short_box",
      translation({0.68, 0.135, 0.35}) * rotationY(-0.3));
  add(makeSphere(0.12, 6, 8), blue, "sphere", translation({0.68, 0.39, 0.35}));
  addPaperLights(&scene);
  scene.ambient = {0.04f, 0.04f, 0.04f};
  scene.background = {0.02f, 0.02f, 0.03f};
  scene.worldBox = Box3{offset, offset + scale * Eigen::Vector3d(1.0, 1.0, kDepth)};
  scene.maxDepth = 5;
  return scene;
}

Scene makeShapesScene() {
  Scene scene;
  scene.name = "shapes";
  const int floor = scene.addMaterial(Material::makeDiffuse({0.7f, 0.7f, 0.65f}));
  const int wall = scene.addMaterial(Material::makeDiffuse({0.5f, 0.55f, 0.7f}));
  const int glass = scene.addMaterial(Material::makeDielectric(1.5f));
  const int tinted = scene.addMaterial(Material::makeDielectric(1.45f, {0.2f, 0.9f, 1.8f}));
  const int gold =
      scene.addMaterial(Material::makePhong({0.8f, 0.6f, 0.2f}, {0.6f, 0.6f, 0.5f}, 60.0f));
  const int red = scene.addMaterial(Material::makeDiffuse({0.8f, 0.15f, 0.1f}));
  const int green =
      scene.addMaterial(Material::makePhong({0.2f, 0.7f, 0.3f}, {0.4f, 0.4f, 0.4f}, 20.0f));
  for (auto [i, n] : {std::pair{floor, "floor"},
                      {wall, "wall"},
                      {glass, "glass"},
                      {tinted, "tinted_glass"},
                      {gold, "gold"},
                      {red, "red"},
                      {green, "green"}}) {
    scene.materials[static_cast<size_t>(i)].name = n;
  }
  constexpr double kHalfPi = 1.5707963267948966;
  // World: x in [-2, 2], y in [0, 2.25], z in [-1.25, 1.25] (B_P's 1.6 : 0.9 : 0.5 shape).
  scene.addMesh(withMaterial(makeGrid(4, 2.5, 12, 12), floor, "floor"), true,
                translation({0, 0, 0}) * rotationX(-kHalfPi));
  scene.addMesh(withMaterial(makeGrid(4, 2.25, 2, 2), wall, "back_wall"), true,
                translation({0, 1.125, -1.25}));
  scene.addMesh(withMaterial(makeSphere(0.55, 24, 12), glass, "glass_sphere"), true,
                translation({-0.5, 0.55, 0.35}));
  scene.addMesh(withMaterial(makeBox({0.6, 0.9, 0.35}), tinted, "glass_block"), true,
                translation({0.75, 0.45, 0.55}) * rotationY(0.5));
  scene.addMesh(withMaterial(makeTorus(0.42, 0.14, 24, 12), gold, "torus"), true,
                translation({-1.35, 0.5, -0.45}) * rotationX(1.2));
  scene.addMesh(withMaterial(makeCylinder(0.28, 1.0, 24), red, "cylinder"), true,
                translation({0.3, 0.5, -0.6}));
  scene.addMesh(withMaterial(makeCone(0.35, 0.9, 24), green, "cone"), true,
                translation({1.5, 0.45, -0.35}));
  addPaperLights(&scene);
  scene.ambient = {0.05f, 0.05f, 0.05f};
  scene.background = {0.05f, 0.06f, 0.08f};
  scene.worldBox = Box3{{-2.0, 0.0, -1.25}, {2.0, 2.25, 1.25}};
  scene.maxDepth = 5;
  return scene;
}

std::vector<std::string> builtInSceneNames() { return {"cornell", "shapes", "statue", "xyz"}; }

bool isBuiltInScene(const std::string& name) {
  for (const std::string& n : builtInSceneNames()) {
    if (n == name) return true;
  }
  return false;
}

Scene makeStatueScene(const std::string& assetRoot);  // statue_scene.cpp

Scene makeBuiltInScene(const std::string& name, const std::string& assetRoot) {
  if (name == "cornell") return makeCornellScene();
  if (name == "shapes") return makeShapesScene();
  if (name == "xyz") return makeXyzTriangleScene();
  if (name == "statue") return makeStatueScene(assetRoot);
  throw InputError({"", "--scene", 0},
                   fmt::format("unknown scene \"{}\" (built in: cornell, shapes, statue, xyz; "
                               "or a model file)",
                               name));
}

}  // namespace parallax
