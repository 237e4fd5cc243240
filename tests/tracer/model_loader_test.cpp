// Real-world model files from Debian's assimp-testmodels (installed by tools/setup.sh, not
// committed): Windows paths in MTL, missing textures, polygons, missing normals, glTF with
// external and embedded textures, empty and truncated files.

#include "tracer/model_loader.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include "common/input_error.h"
#include "tests/assimp_test_models.h"
#include "tests/tracer/tracer_test_util.h"
#include "tracer/physical_scene.h"
#include "tracer/scene_source.h"
#include "tracer/whitted_integrator.h"

namespace parallax {
namespace {

namespace fs = std::filesystem;

fs::path models() { return assimpTestModelsRoot(); }

#define REQUIRE_MODELS() REQUIRE_ASSIMP_TEST_MODEL("OBJ/spider.obj")

fs::path scratch(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / ("parallax_model_test_" + std::to_string(::getpid())) / name;
  fs::create_directories(dir);
  return dir;
}

TEST(ModelLoader, SpiderFindsItsFiveTexturesThroughWindowsPaths) {
  REQUIRE_MODELS();
  ModelLoadReport report;
  const Scene scene = loadModelScene((models() / "OBJ" / "spider.obj").string(), &report);
  EXPECT_EQ(report.textures, 5);
  EXPECT_EQ(report.texturesMissing, 0);
  EXPECT_GE(report.triangles, 1300);
  EXPECT_LE(report.triangles, 1368);
  for (const Texture& t : scene.textures) {
    EXPECT_TRUE(fs::exists(t.path)) << t.path;
    EXPECT_EQ(t.path.find('\\'), std::string::npos);
  }
  // Rendered: textures are loaded and sampled, and no warning is raised.
  const DisplayModel display = test::smallDisplay(1, 160, 120);
  const PhysicalScene physical(scene, display.displayableBox);
  // spider.mtl's "Skin" material is used by no mesh: its texture is never read.
  EXPECT_EQ(physical.counters().texturesLoaded, 4);
  EXPECT_EQ(physical.counters().texturesSkipped, 1);
  EXPECT_TRUE(physical.warnings().empty());
  RenderCounters counters;
  renderFrame(physical, generateRayTextures(display, 0), RenderOptions{}, &counters);
  EXPECT_GT(counters.textureLookups, 100);
}

TEST(ModelLoader, WusonLoadsWithItsNormals) {
  REQUIRE_MODELS();
  ModelLoadReport report;
  const Scene scene = loadModelScene((models() / "OBJ" / "WusonOBJ.obj").string(), &report);
  EXPECT_GE(report.triangles, 3600);
  EXPECT_LE(report.triangles, 3732);
  EXPECT_EQ(report.generatedNormals, 0);
  EXPECT_NO_THROW(scene.validate());
}

TEST(ModelLoader, QuadsAndPolygonsAreTriangulatedAndMissingNormalsMade) {
  REQUIRE_MODELS();
  ModelLoadReport box;
  const Scene boxScene = loadModelScene((models() / "OBJ" / "box.obj").string(), &box);
  EXPECT_EQ(box.triangles, 12) << "six quads";
  EXPECT_EQ(box.generatedNormals, 1);
  for (const Mesh& m : boxScene.meshes) EXPECT_EQ(m.normals.size(), m.positions.size());
  ModelLoadReport polygon;
  loadModelScene((models() / "OBJ" / "concave_polygon.obj").string(), &polygon);
  EXPECT_EQ(polygon.triangles, 64) << "one 66-gon";
}

TEST(ModelLoader, GltfWithExternalAndEmbeddedTextures) {
  REQUIRE_MODELS();
  ModelLoadReport external;
  const Scene a = loadModelScene(
      (models() / "glTF2" / "BoxTextured-glTF" / "BoxTextured.gltf").string(), &external);
  EXPECT_EQ(external.textures, 1);
  ASSERT_EQ(a.textures.size(), 1u);
  EXPECT_TRUE(fs::exists(a.textures[0].path));
  ModelLoadReport embedded;
  const Scene b = loadModelScene(
      (models() / "glTF2" / "BoxTextured-glTF-Binary" / "BoxTextured.glb").string(), &embedded);
  EXPECT_EQ(embedded.textures, 1);
  ASSERT_EQ(b.textures.size(), 1u);
  EXPECT_TRUE(b.textures[0].path.empty()) << "decoded from the .glb into inline pixels";
  EXPECT_GT(b.textures[0].width, 0);
  EXPECT_EQ(b.textures[0].pixels.size(),
            static_cast<size_t>(b.textures[0].width * b.textures[0].height * 3));
}

TEST(ModelLoader, MissingTexturesWarnAndFallBackToTheMaterialColour) {
  REQUIRE_MODELS();
  const fs::path dir = scratch("missing");
  fs::copy_file(models() / "OBJ" / "spider.obj", dir / "spider.obj",
                fs::copy_options::overwrite_existing);
  fs::copy_file(models() / "OBJ" / "spider.mtl", dir / "spider.mtl",
                fs::copy_options::overwrite_existing);
  ModelLoadReport report;
  const Scene scene = loadModelScene((dir / "spider.obj").string(), &report);
  EXPECT_EQ(report.texturesMissing, 5);
  ASSERT_EQ(report.warnings.size(), 5u);
  EXPECT_NE(report.warnings[0].find(".jpg"), std::string::npos) << report.warnings[0];
  // The materials keep their own colours (MTL Kd), and the scene renders.
  bool skin = false;
  for (const Material& m : scene.materials)
    skin = skin || (m.name == "Skin" && std::abs(m.diffuse.x() - 0.827451f) < 1e-5f);
  EXPECT_TRUE(skin);
  const DisplayModel display = test::smallDisplay(1, 64, 48);
  const PhysicalScene physical(scene, display.displayableBox);
  EXPECT_NO_THROW(renderFrame(physical, generateRayTextures(display, 0), RenderOptions{}));
  fs::remove_all(dir.parent_path());
}

TEST(ModelLoader, EmptyAndTruncatedFilesAreClearErrorsNotCrashes) {
  REQUIRE_MODELS();
  const fs::path dir = scratch("bad");
  { std::ofstream(dir / "empty.obj"); }
  try {
    loadModelScene((dir / "empty.obj").string());
    FAIL() << "a 0-byte file must be rejected";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("empty.obj"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("empty"), std::string::npos) << e.what();
  }
  EXPECT_THROW(loadModelScene((dir / "absent.obj").string()), InputError);
  // Truncated binaries at several lengths: an InputError (or, where the prefix is itself a
  // valid model, a scene that validates), never a crash.
  for (const fs::path& source : {models() / "glTF2" / "BoxTextured-glTF-Binary" / "BoxTextured.glb",
                                 models() / "OBJ" / "WusonOBJ.obj"}) {
    std::ifstream in(source, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    for (double fraction : {0.01, 0.3, 0.77}) {
      const fs::path cut = dir / ("cut" + std::to_string(static_cast<int>(fraction * 100)) +
                                  source.extension().string());
      std::ofstream(cut, std::ios::binary)
          .write(bytes.data(), static_cast<std::streamsize>(bytes.size() * fraction));
      try {
        const Scene scene = loadModelScene(cut.string());
        EXPECT_NO_THROW(scene.validate()) << cut;
      } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find(cut.filename().string()), std::string::npos)
            << e.what();
      }
    }
  }
  fs::remove_all(dir.parent_path());
}

// A model names other files (an OBJ its mtllib): assimp opens only regular ones, so a FIFO
// there is passed over with assimp's warning instead of blocking the loader for ever (a helper
// opens the FIFO's other end after 5 s to let a blocked load go, and the test then fails).
TEST(ModelLoader, AFileTheModelNamesThatIsNotRegularIsNotOpened) {
  const fs::path dir = scratch("fifo");
  const fs::path fifo = dir / "blocking.mtl";
  fs::remove(fifo);
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  { std::ofstream(dir / "tri.obj") << "mtllib blocking.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"; }
  std::atomic<bool> done{false}, blocked{false};
  std::thread unblock([&] {
    for (int i = 0; i < 100 && !done; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    if (done) return;
    blocked = true;
    const int fd = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK);
    if (fd >= 0) ::close(fd);
  });
  ModelLoadReport report;
  const Scene scene = loadModelScene((dir / "tri.obj").string(), &report);
  done = true;
  unblock.join();
  EXPECT_FALSE(blocked) << "the loader waited on the FIFO its model named";
  EXPECT_EQ(scene.triangleCount(), 1);
  fs::remove_all(dir.parent_path());
}

// A PLY header's element counts are believed by assimp, which reserved and looped for them: 300
// million vertices promised in a few hundred bytes took more than 120 s and 3.6 GB. Counts the
// file cannot hold are refused at once, naming the element; real PLY files still load.
TEST(ModelLoader, APlyHeaderPromisingMoreThanTheFileHoldsIsRefused) {
  const fs::path dir = scratch("ply");
  const std::string header =
      "ply\nformat ascii 1.0\nelement vertex 300000000\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  { std::ofstream(dir / "liar.ply") << header << "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"; }
  try {
    loadModelScene((dir / "liar.ply").string());
    FAIL() << "the promised counts were believed";
  } catch (const InputError& e) {
    EXPECT_EQ(e.location().field, "element vertex") << e.what();
    EXPECT_NE(std::string(e.what()).find("liar.ply"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("promises 300000000"), std::string::npos) << e.what();
  }
  // Exactly what the header says, the last line without its newline: read.
  {
    std::ofstream(dir / "exact.ply")
        << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
           "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
           "0 0 0\n1 0 0\n0 1 0\n3 0 1 2";
  }
  EXPECT_EQ(loadModelScene((dir / "exact.ply").string()).triangleCount(), 1);
  if (fs::exists(models() / "PLY" / "cube_binary.ply")) {
    EXPECT_EQ(loadModelScene((models() / "PLY" / "cube_binary.ply").string()).triangleCount(), 12);
    EXPECT_EQ(loadModelScene((models() / "PLY" / "cube.ply").string()).triangleCount(), 12);
  }
  fs::remove_all(dir.parent_path());
}

TEST(ModelLoader, WindowsPathsResolveCaseInsensitively) {
  const fs::path dir = scratch("paths");
  fs::create_directories(dir / "Textures");
  std::ofstream(dir / "Textures" / "Wood.JPG") << "x";  // only its name matters
  bool found = false;
  EXPECT_EQ(resolveTexturePath(".\\Textures\\Wood.JPG", dir.string(), &found),
            (dir / "Textures" / "Wood.JPG").string());
  EXPECT_TRUE(found);
  EXPECT_EQ(resolveTexturePath("Textures\\wood.jpg", dir.string(), &found),
            (dir / "Textures" / "Wood.JPG").string());
  EXPECT_TRUE(found);
  resolveTexturePath(".\\nothing.png", dir.string(), &found);
  EXPECT_FALSE(found);
  fs::remove_all(dir.parent_path());
}

}  // namespace
}  // namespace parallax
