// Animated model files: node channels evaluated between and outside their keys, skinned
// vertices following their bones (hand-made glTF whose poses are known exactly), the animated
// files of Debian's assimp-testmodels (COLLADA, FBX, X) playing deterministically inside their
// motion bounds, and hostile files refused with the file named.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <limits>

#include "common/input_error.h"
#include "tests/assimp_test_models.h"
#include "tests/tracer/gltf_fixture.h"
#include "tracer/model_loader.h"
#include "tracer/scene_source.h"

namespace parallax {
namespace {

namespace fs = std::filesystem;

fs::path scratch() {
  const fs::path dir =
      fs::temp_directory_path() / ("parallax_animation_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir;
}

const float kNaN = std::numeric_limits<float>::quiet_NaN();

// A small triangle hung under two nodes: "mover" slides (0 → (1,0,0) → (1,2,0) at t = 0, 1, 2 s)
// and turns 90° about z over 2 s; "still" is not animated.
test::GltfFixture mover() {
  test::GltfFixture g;
  const int positions = g.floats({0, 0, 0, 0.1f, 0, 0, 0, 0.1f, 0}, "VEC3", true);
  g.json["meshes"] = {{{"primitives", {{{"attributes", {{"POSITION", positions}}}}}}}};
  g.json["nodes"] = {{{"name", "mover"}, {"mesh", 0}},
                     {{"name", "still"}, {"mesh", 0}, {"translation", {0, 0, -1}}}};
  g.json["scenes"] = {{{"nodes", {0, 1}}}};
  g.json["scene"] = 0;
  const int times = g.floats({0, 1, 2}, "SCALAR", true);
  const int slide = g.floats({0, 0, 0, 1, 0, 0, 1, 2, 0}, "VEC3");
  const int turnTimes = g.floats({0, 2}, "SCALAR", true);
  const float s = std::sqrt(0.5f);
  const int turn = g.floats({0, 0, 0, 1, 0, 0, s, s}, "VEC4");
  g.json["animations"] = {
      {{"name", "slide"},
       {"samplers",
        {{{"input", times}, {"output", slide}}, {{"input", turnTimes}, {"output", turn}}}},
       {"channels",
        {{{"sampler", 0}, {"target", {{"node", 0}, {"path", "translation"}}}},
         {{"sampler", 1}, {"target", {{"node", 0}, {"path", "rotation"}}}}}}}};
  return g;
}

// A triangle skinned to one bone (weight 1, identity inverse bind matrix); the bone rises by
// 1 over 1 s.
test::GltfFixture skinned(const std::vector<float>& weight = {1, 0, 0, 0}, std::uint8_t joint = 0) {
  test::GltfFixture g;
  const int positions = g.floats({0, 0, 0, 1, 0, 0, 0, 1, 0}, "VEC3", true);
  std::vector<std::uint8_t> joints;
  std::vector<float> weights;
  for (int v = 0; v < 3; ++v) {
    joints.insert(joints.end(), {joint, 0, 0, 0});
    weights.insert(weights.end(), weight.begin(), weight.end());
  }
  const int jointsAccessor = g.bytes(joints, "VEC4");
  const int weightsAccessor = g.floats(weights, "VEC4");
  g.json["meshes"] = {{{"primitives",
                        {{{"attributes",
                           {{"POSITION", positions},
                            {"JOINTS_0", jointsAccessor},
                            {"WEIGHTS_0", weightsAccessor}}}}}}}};
  const int inverseBind = g.floats({1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}, "MAT4");
  g.json["skins"] = {{{"joints", {1}}, {"inverseBindMatrices", inverseBind}}};
  g.json["nodes"] = {{{"name", "skinned"}, {"mesh", 0}, {"skin", 0}}, {{"name", "bone"}}};
  g.json["scenes"] = {{{"nodes", {0, 1}}}};
  g.json["scene"] = 0;
  const int times = g.floats({0, 1}, "SCALAR", true);
  const int lift = g.floats({0, 0, 0, 0, 1, 0}, "VEC3");
  g.json["animations"] = {
      {{"name", "lift"},
       {"samplers", {{{"input", times}, {"output", lift}}}},
       {"channels", {{{"sampler", 0}, {"target", {{"node", 1}, {"path", "translation"}}}}}}}};
  return g;
}

struct Loaded {
  Scene scene;
  ModelAnimation animation;
  ModelLoadReport report;
};

Loaded load(const std::string& path, double height = 0.0) {
  Loaded l;
  ModelLoadOptions options;
  options.targetHeight = height;
  l.report = appendModel(path, options, &l.scene, &l.animation);
  return l;
}

std::string write(test::GltfFixture g, const std::string& name) {
  const std::string path = (scratch() / name).string();
  g.write(path);
  return path;
}

TEST(ModelAnimation, NodeKeysAreInterpolatedBetweenKeysAndHeldOutsideThem) {
  Loaded l = load(write(mover(), "mover.gltf"));
  ASSERT_EQ(l.animation.clips.size(), 1u);
  const int clip = l.animation.findClip("slide");
  ASSERT_EQ(clip, 0);
  EXPECT_DOUBLE_EQ(l.animation.clips[0].duration, 2.0);
  ASSERT_EQ(l.animation.rigidParts.size(), 2u);
  // Only the mover's instance moves.
  const int moverInstance = l.animation.rigidParts[0].instance;
  EXPECT_EQ(l.animation.clips[0].movingInstances, std::vector<int>{moverInstance});

  auto expectPose = [&](double t, const Eigen::Vector3d& translation, double angle) {
    l.animation.pose(clip, l.animation.clipTime(clip, t), &l.scene);
    const Eigen::Affine3d& m =
        l.scene.instances[static_cast<size_t>(moverInstance)].worldFromObject;
    EXPECT_LT((m.translation() - translation).norm(), 1e-6) << "t = " << t;
    const Eigen::Matrix3d expected =
        Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    EXPECT_LT((m.linear() - expected).norm(), 1e-6) << "t = " << t;
  };
  expectPose(0.0, {0, 0, 0}, 0.0);
  expectPose(0.5, {0.5, 0, 0}, M_PI / 8);
  expectPose(1.0, {1, 0, 0}, M_PI / 4);
  expectPose(1.5, {1, 1, 0}, 3 * M_PI / 8);
  expectPose(2.0, {1, 2, 0}, M_PI / 2);
  expectPose(2.5, {0.5, 0, 0}, M_PI / 8);  // the clip loops
  expectPose(-0.5, {1, 1, 0}, 3 * M_PI / 8);
  // The still node keeps its rest transform.
  const int still = l.animation.rigidParts[1].instance;
  EXPECT_LT((l.scene.instances[static_cast<size_t>(still)].worldFromObject.translation() -
             Eigen::Vector3d(0, 0, -1))
                .norm(),
            1e-12);
  // The bounds cover the slide: x from 0 to 1.1 (the triangle's width), y up to 2.1.
  ASSERT_EQ(l.scene.motionBounds.size(), 1u);
  EXPECT_NEAR(l.scene.motionBounds[0].max.y(), 2.1, 1e-6);
  EXPECT_NEAR(l.scene.geometryBounds().max.y(), 2.1, 1e-6);
}

TEST(ModelAnimation, SkinnedVerticesFollowTheirBone) {
  Loaded l = load(write(skinned(), "skinned.gltf"));
  ASSERT_EQ(l.animation.skinnedParts.size(), 1u);
  EXPECT_EQ(l.report.skinnedMeshes, 1);
  const int mesh = l.animation.skinnedParts[0].mesh;
  for (double t : {0.0, 0.25, 0.5, 1.0}) {
    l.animation.pose(0, t, &l.scene);
    const std::vector<Eigen::Vector3d>& p = l.scene.meshes[static_cast<size_t>(mesh)].positions;
    ASSERT_EQ(p.size(), 3u);
    EXPECT_LT((p[0] - Eigen::Vector3d(0, t, 0)).norm(), 1e-6) << t;
    EXPECT_LT((p[1] - Eigen::Vector3d(1, t, 0)).norm(), 1e-6) << t;
    EXPECT_LT((p[2] - Eigen::Vector3d(0, 1 + t, 0)).norm(), 1e-6) << t;
  }
  // Weights that do not sum to one are scaled to: half and half on the same bone is the bone.
  Loaded halves = load(write(skinned({0.25f, 0.25f, 0, 0}), "halves.gltf"));
  halves.animation.pose(0, 1.0, &halves.scene);
  EXPECT_LT((halves.scene.meshes[static_cast<size_t>(mesh)].positions[0] - Eigen::Vector3d(0, 1, 0))
                .norm(),
            1e-6);
}

// Every vertex of the posed model in world space.
std::vector<Eigen::Vector3d> posedVertices(const Scene& scene) {
  std::vector<Eigen::Vector3d> out;
  for (const Instance& instance : scene.instances) {
    for (const Eigen::Vector3d& p : scene.meshes[static_cast<size_t>(instance.mesh)].positions)
      out.push_back(instance.worldFromObject * p);
  }
  return out;
}

TEST(ModelAnimation, DebiansAnimatedModelsPlayDeterministicallyInsideTheirBounds) {
  const fs::path root = assimpTestModelsRoot();
  REQUIRE_ASSIMP_TEST_MODEL("FBX/animation_with_skeleton.fbx");
  struct Case {
    std::string file;
    bool skinned;
  };
  for (const Case& c :
       std::vector<Case>{{"FBX/animation_with_skeleton.fbx", true},
                         {"FBX/huesitos.fbx", true},
                         {"Collada/box_nested_animation.dae", true},
                         {"Collada/anims_with_full_rotations_between_keys.DAE", false},
                         {"X/Testwuson.X", true}}) {
    SCOPED_TRACE(c.file);
    Loaded l = load((root / c.file).string(), 1.0);
    ASSERT_FALSE(l.animation.clips.empty());
    EXPECT_EQ(!l.animation.skinnedParts.empty(), c.skinned);
    const int clip = 0;
    const double duration = l.animation.clips[0].duration;
    ASSERT_GT(duration, 0.0);
    l.animation.pose(clip, 0.3 * duration, &l.scene);
    const std::vector<Eigen::Vector3d> a = posedVertices(l.scene);
    l.animation.pose(clip, 0.7 * duration, &l.scene);
    const std::vector<Eigen::Vector3d> b = posedVertices(l.scene);
    l.animation.pose(clip, 0.3 * duration, &l.scene);
    const std::vector<Eigen::Vector3d> again = posedVertices(l.scene);
    EXPECT_NE(a, b) << "the frames do not change over time";
    EXPECT_EQ(a, again) << "the same time gives another frame";
    // Sampled poses stay inside the motion bounds (up to the bounds' own sampling, which takes
    // every key time: between keys a rotation can swing a little further).
    const Box3 bounds = l.scene.motionBounds.at(0);
    const double slack = 0.02 * bounds.size().norm();
    for (double t = 0.0; t <= duration; t += duration / 37) {
      l.animation.pose(clip, t, &l.scene);
      for (const Eigen::Vector3d& p : posedVertices(l.scene)) {
        ASSERT_TRUE((p.array() >= bounds.min.array() - slack).all() &&
                    (p.array() <= bounds.max.array() + slack).all())
            << "t = " << t << ": " << p.transpose();
      }
    }
    l.scene.validate();
  }
}

TEST(ModelAnimation, AFileWithoutAnimationsLoadsAsWithoutAsking) {
  const std::string path = write(mover(), "plain.gltf");
  test::GltfFixture still = mover();
  still.json.erase("animations");
  still.write(path);
  Loaded with = load(path);
  Scene without;
  appendModel(path, ModelLoadOptions{}, &without);
  EXPECT_TRUE(with.animation.clips.empty());
  EXPECT_TRUE(with.scene.motionBounds.empty());
  ASSERT_EQ(with.scene.instances.size(), without.instances.size());
  for (size_t i = 0; i < without.instances.size(); ++i) {
    EXPECT_EQ(with.scene.instances[i].worldFromObject.matrix(),
              without.instances[i].worldFromObject.matrix());
  }
}

TEST(ModelAnimation, HostileFilesAreRefusedNamingTheFile) {
  struct Case {
    std::string name;
    std::function<void(test::GltfFixture&)> spoil;
    std::string says;  // part of the message ("" when only the file name is checked)
  };
  const std::vector<Case> cases = {
      {"nan_key.gltf",
       [](test::GltfFixture& g) {
         const int bad = g.floats({0, 0, 0, kNaN, 0, 0, 1, 2, 0}, "VEC3");
         g.json["animations"][0]["samplers"][0]["output"] = bad;
       },
       "not finite"},
      {"backwards.gltf",
       [](test::GltfFixture& g) {
         const int bad = g.floats({0, 2, 1}, "SCALAR", true);
         g.json["animations"][0]["samplers"][0]["input"] = bad;
       },
       "goes back"},
      {"no_such_node.gltf",
       [](test::GltfFixture& g) { g.json["animations"][0]["channels"][0]["target"]["node"] = 7; },
       ""},
      {"huge_count.gltf",
       [](test::GltfFixture& g) { g.json["accessors"][1]["count"] = 1000000000; }, ""},
      {"zero_rotation.gltf",
       [](test::GltfFixture& g) {
         const int bad = g.floats({0, 0, 0, 0, 0, 0, 0, 0}, "VEC4");
         g.json["animations"][0]["samplers"][1]["output"] = bad;
       },
       "has zero length"},
  };
  for (const Case& c : cases) {
    test::GltfFixture g = mover();
    c.spoil(g);
    const std::string path = write(g, c.name);
    try {
      load(path);
      ADD_FAILURE() << c.name << " was accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(c.says), std::string::npos) << e.what();
    }
  }
  // Skins: a NaN weight, a joint the skin does not have, a NaN inverse bind matrix. Assimp
  // drops the first two's weights silently; the load says so, naming the file.
  const std::vector<std::pair<std::string, test::GltfFixture>> skins = {
      {"nan_weight.gltf", skinned({kNaN, 0, 0, 0})},
      {"bad_joint.gltf", skinned({1, 0, 0, 0}, 9)},
      {"nan_bind.gltf", [] {
         test::GltfFixture g = skinned();
         const int bad = g.floats({kNaN, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}, "MAT4");
         g.json["skins"][0]["inverseBindMatrices"] = bad;
         return g;
       }()}};
  for (const auto& [name, fixture] : skins) {
    const std::string path = write(fixture, name);
    try {
      Loaded l = load(path);
      bool said = false;
      for (const std::string& w : l.report.warnings)
        said = said || (w.find(path) != std::string::npos &&
                        w.find("no bone weights") != std::string::npos);
      EXPECT_TRUE(said) << name << " was accepted without a word";
      for (double t : {0.0, 0.5, 1.0}) {  // and what is left plays cleanly
        l.animation.pose(0, t, &l.scene);
        l.scene.validate();
      }
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace parallax
