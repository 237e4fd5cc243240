// The paper's textured statue scene: Wuson (3,732 triangles) beside the spider (1,368
// triangles, five textures, Windows paths in its MTL) from Debian's assimp-testmodels, on a
// textured pedestal; about 5,100 triangles, 4 directional lights, depth 5.

#include <filesystem>

#include "common/input_error.h"
#include "tracer/mesh_shapes.h"
#include "tracer/model_loader.h"
#include "tracer/scene_fixtures.h"

namespace parallax {

Scene makeStatueScene(const std::string& assetRoot) {
  namespace fs = std::filesystem;
  const fs::path wuson = fs::path(assetRoot) / "OBJ" / "WusonOBJ.obj";
  const fs::path spider = fs::path(assetRoot) / "OBJ" / "spider.obj";
  for (const fs::path& p : {wuson, spider}) {
    if (!fs::exists(p)) {
      throw InputError({p.string(), "", 0},
                       "the statue scene needs Debian's assimp-testmodels (apt install "
                       "assimp-testmodels, or set "
                       "PARALLAX_ASSIMP_MODELS to its models folder)");
    }
  }
  Scene scene;
  scene.name = "statue";
  // Pedestal: a marble-ish procedural texture (inline, so the scene needs no extra file).
  Texture marble;
  marble.width = marble.height = 128;
  for (int y = 0; y < 128; ++y) {
    for (int x = 0; x < 128; ++x) {
      const bool check = ((x / 16) + (y / 16)) % 2 == 0;
      const float vein = 0.5f + 0.5f * std::sin(0.15f * static_cast<float>(x) +
                                                0.3f * std::sin(0.11f * static_cast<float>(y)));
      const float base = (check ? 0.75f : 0.55f) * (0.85f + 0.15f * vein);
      marble.pixels.insert(marble.pixels.end(), {base, base * 0.96f, base * 0.9f});
    }
  }
  const int marbleTexture = scene.addTexture(std::move(marble));
  const int stone = scene.addMaterial(Material::makeDiffuse(Rgb::Ones(), marbleTexture));
  scene.materials[static_cast<size_t>(stone)].name = "pedestal";
  Mesh pedestal = makeBox({3.2, 0.4, 1.6});
  pedestal.material = stone;
  scene.addMesh(pedestal, true, Eigen::Affine3d(Eigen::Translation3d(0, 0.2, 0)));
  const int floor = scene.addMaterial(Material::makeMirror({0.6f, 0.6f, 0.65f}));
  scene.materials[static_cast<size_t>(floor)].name = "polished_floor";
  Mesh base = makeGrid(4.0, 2.0, 1, 1);
  base.material = floor;
  scene.addMesh(base, true,
                Eigen::Affine3d(Eigen::AngleAxisd(-1.5707963267948966, Eigen::Vector3d::UnitX())));

  ModelLoadOptions w;
  w.targetHeight = 1.1;
  w.worldFromModel =
      Eigen::Translation3d(-0.55, 0.4, 0.0) * Eigen::AngleAxisd(-1.25, Eigen::Vector3d::UnitY());
  appendModel(wuson.string(), w, &scene);
  ModelLoadOptions s;
  s.targetHeight = 0.6;
  s.worldFromModel =
      Eigen::Translation3d(1.0, 0.4, 0.1) * Eigen::AngleAxisd(-0.6, Eigen::Vector3d::UnitY());
  appendModel(spider.string(), s, &scene);

  addPaperLights(&scene);
  scene.ambient = {0.06f, 0.06f, 0.06f};
  scene.background = {0.04f, 0.05f, 0.07f};
  scene.worldBox = Box3{{-2.0, 0.0, -1.0}, {2.0, 2.25, 1.0}};
  scene.maxDepth = 5;
  return scene;
}

}  // namespace parallax
