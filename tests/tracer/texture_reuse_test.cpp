// An animated scene's frames hand their textures to the next frame's scene (PhysicalScene's
// `previous`): read and filtered once, not every frame — until the file changes.

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>

#include "tracer/frame.h"
#include "tracer/mesh_shapes.h"
#include "tracer/physical_scene.h"
#include "tracer_test_util.h"

namespace parallax {
namespace {

void writeFlatImage(const std::string& path, const Rgb& colour) {
  Frame image(4, 4);
  for (Rgb& p : image.pixels) p = colour;
  const bool existed = std::filesystem::exists(path);
  const auto before =
      existed ? std::filesystem::last_write_time(path) : std::filesystem::file_time_type{};
  writePng(image, path);
  // A new modification time even within the file system's timestamp granularity.
  if (existed) std::filesystem::last_write_time(path, before + std::chrono::seconds(2));
}

bool sameFrames(const Frame& a, const Frame& b) { return a.pixels == b.pixels; }

TEST(PhysicalScene, TexturesAreTakenOverFromThePreviousFrameUntilTheirFileChanges) {
  const std::string path = ::testing::TempDir() + "parallax_reused_texture.png";
  writeFlatImage(path, Rgb(0.8f, 0.2f, 0.1f));
  Scene scene;
  const int texture = scene.addTextureFile(path);
  const int material = scene.addMaterial(Material::makeDiffuse(Rgb::Ones(), texture));
  Mesh wall = makeGrid(2.0, 1.5, 2, 2);
  wall.material = material;
  scene.addMesh(wall);
  scene.addLight(Light::makeDirectional({0.2, -0.3, -1.0}, Rgb::Ones()));
  scene.worldBox = Box3{Eigen::Vector3d(-1.2, -1.0, -1.0), Eigen::Vector3d(1.2, 1.0, 1.0)};
  scene.animated = true;
  const DisplayModel display = test::smallDisplay(1, 64, 48);
  const RayTextures rays = generateRayTextures(display, 0);
  const RenderOptions options;

  auto first = std::make_unique<PhysicalScene>(scene, display.displayableBox);
  EXPECT_EQ(first->counters().texturesReused, 0);
  const Frame red = renderFrame(*first, rays, options);
  auto second =
      std::make_unique<PhysicalScene>(scene, display.displayableBox, nullptr, first.get());
  EXPECT_EQ(second->counters().texturesReused, 1);
  EXPECT_EQ(second->counters().texturesLoaded, 1);
  EXPECT_TRUE(sameFrames(renderFrame(*second, rays, options), red));

  // The file changes: read again, and the frame shows the new picture.
  writeFlatImage(path, Rgb(0.1f, 0.3f, 0.9f));
  const PhysicalScene third(scene, display.displayableBox, nullptr, second.get());
  EXPECT_EQ(third.counters().texturesReused, 0);
  const Frame blue = renderFrame(third, rays, options);
  EXPECT_FALSE(sameFrames(blue, red));
  EXPECT_TRUE(
      sameFrames(blue, renderFrame(PhysicalScene(scene, display.displayableBox), rays, options)));
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace parallax
