// What a user of the tracer notices: shadows where geometry puts them, textures showing their
// texels, the left-out passes really left out (counters), bad scenes rejected or warned about,
// and the same image whatever the world's scale or offset.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>

#include "common/input_error.h"
#include "tests/png_header_bomb.h"
#include "tests/tracer/tracer_test_util.h"
#include "tracer/frame.h"
#include "tracer/mesh_shapes.h"
#include "tracer/scene_fixtures.h"
#include "tracer/texture_image.h"
#include "tracer/whitted_integrator.h"

namespace parallax {
namespace {

using test::forEachRenderedPixel;
using test::hitPlane;
using test::positionColouredRect;
using test::RenderedPixel;
using test::smallDisplay;
using test::WorldRay;

Eigen::Affine3d at(const Eigen::Vector3d& t) { return Eigen::Affine3d(Eigen::Translation3d(t)); }

// Floor y = −1 (albedo 0.5) under a box of `boxMaterial` hovering at y ∈ [−0.5, −0.2], |x|, |z|
// < 0.3, lit by one directional light shining along `lightDirection`.
Scene floorUnderHoveringBox(const Material& boxMaterial, const Eigen::Vector3d& lightDirection) {
  Scene scene;
  const int white = scene.addMaterial(Material::makeDiffuse({0.5f, 0.5f, 0.5f}));
  Mesh floor = positionColouredRect(0, 2, 1, -1.0, 1.0, 0.0, white);
  floor.colors.clear();
  scene.addMesh(floor);
  Mesh box = makeBox({0.6, 0.3, 0.6});
  box.material = scene.addMaterial(boxMaterial);
  scene.addMesh(box, true, at({0, -0.35, 0}));
  scene.addLight(Light::makeDirectional(lightDirection, Rgb::Ones()));
  scene.worldBox = Box3{Eigen::Vector3d::Constant(-1), Eigen::Vector3d::Constant(1)};
  return scene;
}

// Where the ray meets that floor, max(|x|, |z|) of the point: below 0.3 it lies under the box.
// nullopt for rays that see the floor through the box (they cross its slab above the floor),
// meet it within 0.02 of its rim or of the box's shadow edge, or miss it.
std::optional<double> floorPointEdge(const WorldRay& ray) {
  const auto t = hitPlane(ray, Eigen::Vector3d::UnitY(), -1.0);
  if (!t) return std::nullopt;
  const Eigen::Vector3d p = ray.origin + *t * ray.direction;
  if (std::abs(p.x()) > 0.98 || std::abs(p.z()) > 0.98) return std::nullopt;
  for (double y : {-0.2, -0.5}) {
    const auto ty = hitPlane(ray, Eigen::Vector3d::UnitY(), y);
    if (!ty) continue;
    const Eigen::Vector3d q = ray.origin + *ty * ray.direction;
    if (std::abs(q.x()) < 0.32 && std::abs(q.z()) < 0.32) return std::nullopt;
  }
  const double edge = std::max(std::abs(p.x()), std::abs(p.z()));
  if (std::abs(edge - 0.3) < 0.02) return std::nullopt;
  return edge;
}

// The floor under an opaque box, light straight down: dark exactly under the box and 0.5
// elsewhere; light from below reaches no floor point seen from above.
TEST(Shadows, PresentWhereGeometryBlocksTheLightAbsentElsewhere) {
  const DisplayModel display =
      smallDisplay(3, 320, 240);  // the middle module looks straight at the shadow
  for (bool fromBelow : {false, true}) {
    const Scene scene = floorUnderHoveringBox(Material::makeDiffuse({0.5f, 0.5f, 0.5f}),
                                              {0, fromBelow ? 1.0 : -1.0, 0});
    const PhysicalScene physical(scene, display.displayableBox);
    long lit = 0, shadowed = 0;
    forEachRenderedPixel(display, 2, physical, RenderOptions{}, [&](const RenderedPixel& pixel) {
      const auto edge = floorPointEdge(pixel.ray);
      if (!edge) return;
      if (fromBelow || *edge < 0.3) {
        ++shadowed;
        EXPECT_EQ(pixel.colour, Rgb::Zero()) << pixel.column << "," << pixel.row;
      } else {
        ++lit;
        EXPECT_NEAR(pixel.colour.x(), 0.5f, 1e-5f) << pixel.column << "," << pixel.row;
      }
    });
    if (fromBelow) {
      EXPECT_GT(shadowed, 1000) << "light from below reaches no upward-seen floor point";
    } else {
      EXPECT_GT(lit, 1000);
      EXPECT_GT(shadowed, 100);
    }
  }
}

// The same floor and hovering box, light straight down, the box now glass. Shadow rays pass
// through glass (glass_shadows.h): at normal incidence the floor under the box gets the
// analytic single-pass transmittance of a slab, (1 − R)² · exp(−a · h) per channel, with
// R = ((n − 1)/(n + 1))² and h = 0.3 the box's height, a its absorption per world unit — the
// shadow ray's straight path is the exact one here (no refraction at normal incidence), so the
// only tolerance is float rounding (1e-5 on values ≤ 0.5; the light that bounces twice inside
// the slab, R² e^{−2ah} ≈ 0.1 %, is left out by Whitted's model for every ray, not only here).
// An opaque box still blocks; IOR 1 without absorption casts no shadow at all.
TEST(Shadows, GlassLetsThroughItsFresnelAndBeerLambertTransmittance) {
  const DisplayModel display = smallDisplay(3, 320, 240);
  const Rgb absorption(0.5f, 1.0f, 2.0f);
  struct Case {
    const char* name;
    Material material;
    Rgb expected;  // floor under the box
  };
  const double r = std::pow((1.5 - 1.0) / (1.5 + 1.0), 2.0);
  Rgb glassExpected;
  for (int c = 0; c < 3; ++c)
    glassExpected[c] = static_cast<float>(0.5 * (1 - r) * (1 - r) * std::exp(-absorption[c] * 0.3));
  const Case cases[] = {
      {"absorbing glass", Material::makeDielectric(1.5f, absorption), glassExpected},
      {"opaque", Material::makeDiffuse({0.5f, 0.5f, 0.5f}), Rgb::Zero()},
      {"index 1, clear", Material::makeDielectric(1.0f), Rgb::Constant(0.5f)},
  };
  for (const Case& test : cases) {
    SCOPED_TRACE(test.name);
    const PhysicalScene physical(floorUnderHoveringBox(test.material, {0, -1.0, 0}),
                                 display.displayableBox);
    const bool glass = test.material.kind == MaterialKind::kDielectric;
    EXPECT_EQ(physical.glassShadows(), glass);
    long under = 0, lit = 0;
    RenderCounters total;
    forEachRenderedPixel(
        display, 2, physical, RenderOptions{},
        [&](const RenderedPixel& pixel) {
          const auto edge = floorPointEdge(pixel.ray);
          if (!edge) return;
          const Rgb expected = *edge < 0.3 ? test.expected : Rgb::Constant(0.5f);
          (*edge < 0.3 ? under : lit) += 1;
          for (int k = 0; k < 3; ++k) {
            EXPECT_NEAR(pixel.colour[k], expected[k], 1e-5f)
                << pixel.column << "," << pixel.row << " channel " << k;
          }
        },
        &total);
    EXPECT_GT(under, 100);
    EXPECT_GT(lit, 1000);
    // Glass costs no extra shadow rays: each shadow ray under the box met the two faces it
    // crossed (the filter's calls); opaque boxes never call it.
    if (glass) {
      EXPECT_GE(total.glassShadowHits, 2 * under);
    } else {
      EXPECT_EQ(total.glassShadowHits, 0);
    }
  }
}

// A point light at the origin in front of a white wall z = -1: Lambert with inverse-square
// falloff in world units gives L = cos / d² = 1 / d³ at distance d; the same scene 1000×
// larger with a light 1000² stronger renders the same.
TEST(PointLights, InverseSquareFalloffInWorldUnitsAtAnyScale) {
  const DisplayModel display = smallDisplay(1, 160, 120);
  for (double scale : {1.0, 1000.0}) {
    Scene scene;
    const int white = scene.addMaterial(Material::makeDiffuse(Rgb::Ones()));
    Mesh wall = positionColouredRect(0, 1, 2, -1.0, 1.0, 0.0, white);
    wall.colors.clear();
    scene.addMesh(wall, true, Eigen::Affine3d(Eigen::Scaling(scale)));
    // Intensity is irradiance at 1 world unit: a scene 1000× larger needs 1000² to look the same.
    scene.addLight(Light::makePoint({0, 0, 0}, Rgb::Constant(static_cast<float>(scale * scale))));
    scene.worldBox = Box3{Eigen::Vector3d::Constant(-scale), Eigen::Vector3d::Constant(scale)};
    const PhysicalScene physical(scene, display.displayableBox);
    long checked = 0;
    forEachRenderedPixel(display, 1, physical, RenderOptions{}, [&](const RenderedPixel& pixel) {
      const auto t = hitPlane(pixel.ray, Eigen::Vector3d::UnitZ(), -scale);
      if (!t) return;
      const Eigen::Vector3d p = (pixel.ray.origin + *t * pixel.ray.direction) / scale;
      if (std::abs(p.x()) > 0.98 || std::abs(p.y()) > 0.98) return;
      ++checked;
      const double expected = 1.0 / std::pow(p.norm(), 3.0);
      EXPECT_NEAR(pixel.colour.x(), expected, 1e-4 * expected) << "scale " << scale;
    });
    EXPECT_GT(checked, 1000);
  }
}

TEST(Textures, LookupReturnsTheTexelsColour) {
  std::vector<float> rgb(8 * 4 * 3);
  for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = static_cast<float>(i % 29) / 29.0f;
  const TextureImage image(8, 4, rgb);
  EXPECT_EQ(image.levelCount(), 4);  // 8×4, 4×2, 2×1, 1×1
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 8; ++x) {
      // uv of the texel centre: (0, 0) is the bottom-left corner, row 0 the top.
      const float u = (static_cast<float>(x) + 0.5f) / 8.0f,
                  v = 1.0f - (static_cast<float>(y) + 0.5f) / 4.0f;
      const size_t i = (static_cast<size_t>(y) * 8 + static_cast<size_t>(x)) * 3;
      const Rgb expected(rgb[i], rgb[i + 1], rgb[i + 2]);
      EXPECT_NEAR((image.lookup(u, v, 0.0f) - expected).norm(), 0.0f, 1e-6f) << x << "," << y;
      EXPECT_NEAR((image.lookup(u + 3.0f, v - 2.0f, 0.0f) - expected).norm(), 0.0f, 1e-5f)
          << "uv wraps";
    }
  }
  // The coarsest level is the mean of the whole image.
  Rgb mean = Rgb::Zero();
  for (size_t i = 0; i < rgb.size(); i += 3) mean += Rgb(rgb[i], rgb[i + 1], rgb[i + 2]);
  mean /= 32.0f;
  EXPECT_NEAR((image.lookup(0.3f, 0.7f, 10.0f) - mean).norm(), 0.0f, 1e-5f);
}

// An unlit quad textured with 4×4 blocks of constant colour fills the view: away from block
// borders every pixel shows its block's texel colour.
TEST(Textures, RenderedPixelsShowTheTexelColour) {
  const DisplayModel display = smallDisplay(1, 320, 240);
  Scene scene;
  Texture texture;
  texture.width = texture.height = 16;
  for (int y = 0; y < 16; ++y) {
    for (int x = 0; x < 16; ++x) {
      const int block = (y / 4) * 4 + x / 4;
      texture.pixels.insert(texture.pixels.end(),
                            {block / 16.0f, 1.0f - block / 16.0f, (block % 3) / 2.0f});
    }
  }
  const int tex = scene.addTexture(texture);
  const int material = scene.addMaterial(Material::makeEmissive(Rgb::Ones(), tex));
  Mesh quad = makeGrid(2, 2, 1, 1);  // z = 0, x, y ∈ [-1, 1], uv = (x + 1) / 2, (y + 1) / 2
  quad.material = material;
  scene.addMesh(quad);
  scene.worldBox = Box3{Eigen::Vector3d::Constant(-1), Eigen::Vector3d::Constant(1)};
  const PhysicalScene physical(scene, display.displayableBox);
  RenderOptions options;
  options.textureFiltering = false;
  RenderCounters counters;
  long checked = 0;
  forEachRenderedPixel(
      display, 1, physical, options,
      [&](const RenderedPixel& pixel) {
        const auto t = hitPlane(pixel.ray, Eigen::Vector3d::UnitZ(), 0.0);
        if (!t) return;
        const Eigen::Vector3d p = pixel.ray.origin + *t * pixel.ray.direction;
        const double u = (p.x() + 1) / 2, v = (p.y() + 1) / 2;
        const double tx = u * 16, ty = (1 - v) * 16;  // texel coordinates, row 0 at the top
        // Bilinear blends within half a texel of a block border: skip a full texel there.
        const double bx = std::fmod(tx, 4.0), by = std::fmod(ty, 4.0);
        if (u <= 0 || u >= 1 || v <= 0 || v >= 1 || bx < 1.0 || bx > 3.0 || by < 1.0 || by > 3.0)
          return;
        const int block = static_cast<int>(ty / 4) * 4 + static_cast<int>(tx / 4);
        const Rgb expected(block / 16.0f, 1.0f - block / 16.0f, (block % 3) / 2.0f);
        ++checked;
        EXPECT_NEAR((pixel.colour - expected).norm(), 0.0f, 1e-5f)
            << pixel.column << "," << pixel.row;
      },
      &counters);
  EXPECT_GT(checked, 1000);
  EXPECT_GT(counters.textureLookups, 1000);
  EXPECT_EQ(physical.counters().texturesLoaded, 1);
}

// A texture file's size is checked from its header, before its pixels are allocated: a PNG of
// a few bytes claiming 30000x30000 grey pixels (10.8 GB as the tracer's floats; a 782 KB
// 16384x16384 one took 8 GB and 44 s to load before) is refused and named, the fallback used.
TEST(Textures, AFileIsSizedFromItsHeaderBeforeItsPixelsAreRead) {
  const std::string bomb = ::testing::TempDir() + "parallax_texture_bomb.png";
  writePngClaiming30000Squared(bomb);
  TextureImage image;
  std::string error;
  EXPECT_FALSE(TextureImage::load(bomb, true, TextureImage::kMaxFilePixels, &image, &error));
  EXPECT_NE(error.find("30000x30000 is 900000000 pixels"), std::string::npos) << error;

  Scene scene;
  const int tex = scene.addTextureFile(bomb, Rgb(0.25f, 0.5f, 0.75f));
  scene.addMaterial(Material::makeEmissive(Rgb::Ones(), tex));
  scene.addMesh(makeGrid(2, 2, 1, 1));
  scene.worldBox = Box3{Eigen::Vector3d::Constant(-1), Eigen::Vector3d::Constant(1)};
  const PhysicalScene physical(scene, smallDisplay(1, 32, 24).displayableBox);
  EXPECT_EQ(physical.counters().texturesFailed, 1);
  ASSERT_FALSE(physical.warnings().empty());
  EXPECT_NE(physical.warnings()[0].find(bomb + ": 30000x30000"), std::string::npos)
      << physical.warnings()[0];
  std::filesystem::remove(bomb);

  // The limit holds exactly: an 8x4 picture loads within 32 pixels, not within 31.
  const std::string small = ::testing::TempDir() + "parallax_texture_8x4.png";
  writePng(Frame(8, 4), small);
  EXPECT_TRUE(TextureImage::load(small, true, 32, &image, &error)) << error;
  EXPECT_EQ(image.width(), 8);
  EXPECT_FALSE(TextureImage::load(small, true, 31, &image, &error));
  EXPECT_NE(error.find("8x4 is 32 pixels"), std::string::npos) << error;
  std::filesystem::remove(small);
}

// Counters: a diffuse scene without lights traces primary rays only and loads no textures.
Scene diffuseQuadScene() {
  Scene scene;
  const int white = scene.addMaterial(Material::makeDiffuse({0.5f, 0.5f, 0.5f}));
  const int unusedTexture = scene.addTextureFile("/nonexistent/never-read.png");
  scene.addMaterial(Material::makeDiffuse(Rgb::Ones(), unusedTexture));  // referenced by no mesh
  Mesh back = makeGrid(2, 2, 4, 4);
  back.material = white;
  scene.addMesh(back, true, at({0, 0, -0.5}));
  scene.ambient = {0.2f, 0.2f, 0.2f};
  scene.worldBox = Box3{Eigen::Vector3d::Constant(-1), Eigen::Vector3d::Constant(1)};
  return scene;
}

TEST(LeaveOut, DiffuseSceneWithoutLightsTracesPrimaryRaysOnly) {
  const DisplayModel display = smallDisplay(1, 160, 120);
  const PhysicalScene physical(diffuseQuadScene(), display.displayableBox);
  EXPECT_FALSE(physical.features().shadowPass());
  EXPECT_FALSE(physical.features().reflectionPass());
  EXPECT_EQ(physical.features().depth, 1) << "depth 5 requested, but nothing can bounce";
  EXPECT_EQ(physical.counters().texturesLoaded, 0);
  EXPECT_EQ(physical.counters().texturesFailed, 0) << "an unused texture is never even opened";
  EXPECT_EQ(physical.counters().texturesSkipped, 1);
  const RayTextures textures = generateRayTextures(display, 0);
  RenderCounters c;
  renderFrame(physical, textures, RenderOptions{}, &c);
  EXPECT_GT(c.primary, 1000);
  EXPECT_EQ(c.shadow, 0);
  EXPECT_EQ(c.reflection, 0);
  EXPECT_EQ(c.refraction, 0);
  EXPECT_EQ(c.textureLookups, 0);
  EXPECT_EQ(c.deepest, 1);
  EXPECT_EQ(c.masked + c.missedBounds + c.primary, c.pixels) << "every pixel is accounted for";
}

TEST(LeaveOut, PhaseTimesShowTheShadowPassesNeverRanAndTimingLeavesTheImageAlone) {
  const DisplayModel display = smallDisplay(1, 160, 120);
  const PhysicalScene physical(diffuseQuadScene(), display.displayableBox);
  const RayTextures textures = generateRayTextures(display, 0);
  RenderOptions timed;
  timed.timePhases = true;
  RenderCounters plain, withTimes;
  const Frame a = renderFrame(physical, textures, RenderOptions{}, &plain);
  const Frame b = renderFrame(physical, textures, timed, &withTimes);
  EXPECT_EQ(a.pixels, b.pixels);
  for (int p = 0; p < kRenderPhases; ++p)
    EXPECT_EQ(plain.phaseThreadMs[p], 0.0) << "not timed unless asked";
  for (RenderPhase ran : {RenderPhase::kGenerate, RenderPhase::kIntersect, RenderPhase::kShade}) {
    EXPECT_GT(withTimes.phaseThreadMs[static_cast<int>(ran)], 0.0) << renderPhaseName(ran);
  }
  for (RenderPhase leftOut : {RenderPhase::kOcclude, RenderPhase::kGather}) {
    EXPECT_EQ(withTimes.phaseThreadMs[static_cast<int>(leftOut)], 0.0)
        << renderPhaseName(leftOut) << ": no lights";
  }
}

TEST(LeaveOut, FlatVertexNormalsAreDroppedWithoutChangingTheImageAndSmoothOnesKept) {
  const DisplayModel display = smallDisplay(1, 160, 120);
  const RayTextures textures = generateRayTextures(display, 0);
  Scene withNormals =
      floorUnderHoveringBox(Material::makeDiffuse({0.2f, 0.6f, 0.3f}), {-0.3, -1.0, -0.4});
  withNormals.materials[0].specular = {0.5f, 0.5f, 0.5f};  // a highlight uses the normal too
  withNormals.materials[0].shininess = 32.0f;
  Scene withoutNormals = withNormals;
  for (Mesh& mesh : withoutNormals.meshes) mesh.normals.clear();
  ASSERT_FALSE(withNormals.meshes[1].normals.empty()) << "the box comes with its (flat) normals";
  const PhysicalScene flat(withNormals, display.displayableBox);
  const PhysicalScene none(withoutNormals, display.displayableBox);
  EXPECT_GE(flat.counters().flatNormalMeshes, 1);
  const Frame a = renderFrame(flat, textures, RenderOptions{});
  const Frame b = renderFrame(none, textures, RenderOptions{});
  ASSERT_EQ(a.pixels.size(), b.pixels.size());
  float worst = 0.0f;
  for (size_t i = 0; i < a.pixels.size(); ++i)
    worst = std::max(worst, (a.pixels[i] - b.pixels[i]).cwiseAbs().maxCoeff());
  EXPECT_LT(worst, 1e-5f);

  Scene smooth;
  Mesh sphere = makeSphere(0.5, 24, 12);
  sphere.material = smooth.addMaterial(Material::makeDiffuse({0.5f, 0.5f, 0.5f}));
  smooth.addMesh(sphere);
  smooth.addLight(Light::makeDirectional({0, -1, 0}, Rgb::Ones()));
  smooth.worldBox = Box3{Eigen::Vector3d::Constant(-1), Eigen::Vector3d::Constant(1)};
  const PhysicalScene kept(smooth, display.displayableBox);
  EXPECT_EQ(kept.counters().flatNormalMeshes, 0);
  ASSERT_EQ(kept.meshes().size(), 1u);
  EXPECT_FALSE(kept.meshes()[0].normals.empty()) << "a sphere's normals vary across each triangle";
}

TEST(LeaveOut, AMirrorAddsReflectionRaysOnlyWhereItIsSeen) {
  const DisplayModel display = smallDisplay(1, 160, 120);
  Scene scene = diffuseQuadScene();
  const int mirror = scene.addMaterial(Material::makeMirror({0.9f, 0.9f, 0.9f}));
  Mesh small = makeGrid(0.6, 0.6, 1, 1);
  small.material = mirror;
  scene.addMesh(
      small, true,
      at({0.2, 0.1, 0.3}) * Eigen::Affine3d(Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitY())));
  const RayTextures textures = generateRayTextures(display, 0);
  RenderCounters c;
  {
    const PhysicalScene physical(scene, display.displayableBox);
    renderFrame(physical, textures, RenderOptions{}, &c);
  }
  // The same scene with the mirror painted emissive red and everything else black shows where
  // the mirror is the first thing a ray meets.
  Scene probe = scene;
  for (Material& m : probe.materials) m = Material::makeEmissive(Rgb::Zero());
  probe.materials[static_cast<size_t>(mirror)] = Material::makeEmissive({1, 0, 0});
  probe.ambient = Rgb::Zero();
  const PhysicalScene physicalProbe(probe, display.displayableBox);
  const Frame seen = renderFrame(physicalProbe, textures, RenderOptions{});
  long mirrorPixels = 0;
  for (const Rgb& p : seen.pixels) mirrorPixels += p.x() > 0.5f ? 1 : 0;
  EXPECT_GT(mirrorPixels, 100);
  EXPECT_EQ(c.reflection, mirrorPixels);
  EXPECT_EQ(c.shadow, 0);
  EXPECT_EQ(c.refraction, 0);
}

TEST(BadScenes, ClearErrorsOrWarningsNeverACrash) {
  const DisplayModel display = smallDisplay(1, 64, 48);
  const RayTextures textures = generateRayTextures(display, 0);
  {
    Scene empty;
    EXPECT_THROW(PhysicalScene(empty, display.displayableBox), InputError);
  }
  {
    Scene nan = diffuseQuadScene();
    nan.meshes[0].positions[3].x() = std::numeric_limits<double>::quiet_NaN();
    try {
      PhysicalScene physical(nan, display.displayableBox);
      FAIL() << "a NaN vertex must be rejected";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("meshes[0].positions[3]"), std::string::npos)
          << e.what();
    }
  }
  {
    // Degenerate triangles (repeated index, collinear points) are dropped and counted.
    Scene degenerate = diffuseQuadScene();
    Mesh& m = degenerate.meshes[0];
    m.triangles.push_back({0, 0, 1});
    m.triangles.push_back({0, 1, 2});  // first row of the grid: collinear
    const PhysicalScene physical(degenerate, display.displayableBox);
    EXPECT_EQ(physical.counters().trianglesDegenerate, 2);
    EXPECT_EQ(physical.counters().trianglesBuilt, 32);
  }
  {
    // A missing texture: a warning and the fallback colour, not a crash.
    Scene missing;
    const int tex = missing.addTextureFile("/nonexistent/texture.png", Rgb(0.25f, 0.5f, 0.75f));
    missing.addMaterial(Material::makeEmissive(Rgb::Ones(), tex));
    Mesh quad = makeGrid(2, 2, 1, 1);
    missing.addMesh(quad);
    missing.worldBox = Box3{Eigen::Vector3d::Constant(-1), Eigen::Vector3d::Constant(1)};
    const PhysicalScene physical(missing, display.displayableBox);
    EXPECT_EQ(physical.counters().texturesFailed, 1);
    ASSERT_FALSE(physical.warnings().empty());
    EXPECT_NE(physical.warnings()[0].find("/nonexistent/texture.png"), std::string::npos);
    const Frame frame = renderFrame(physical, textures, RenderOptions{});
    long fallback = 0;
    for (const Rgb& p : frame.pixels)
      fallback += (p - Rgb(0.25f, 0.5f, 0.75f)).norm() < 1e-6f ? 1 : 0;
    EXPECT_GT(fallback, 100);
  }
  {
    // Geometry outside B_P: dropped or clipped, and counted. B_W's depth is what limits the
    // scale here (B_P is 0.5 m deep), so B_P's faces are at z = ±1 in world units.
    Scene outside = diffuseQuadScene();
    Mesh far = makeBox({0.5, 0.5, 0.5});
    outside.addMesh(far, true, at({0, 0, 5}));  // wholly outside
    Mesh across = makeBox({0.5, 0.5, 0.5});
    outside.addMesh(across, true, at({0, 0, 1}));  // straddles the z = 1 face
    const PhysicalScene physical(outside, display.displayableBox);
    EXPECT_EQ(physical.counters().trianglesOutside,
              12 + 2);  // the far box + the across box's outer face
    EXPECT_EQ(physical.counters().trianglesClipped, 8);  // its four side faces
    const float limit = static_cast<float>(display.displayableBox.max.z()) + 1e-5f;
    EXPECT_LE(physical.boundsMax().z(), limit);
  }
}

// The Cornell box at B_W scales 1e-3 and 1e4 and moved 1e4 from the origin renders the same
// frames (within 1/255 per channel on at least 99.9% of pixels).
TEST(ExtremeScales, CornellBoxRendersTheSameAtAnyScaleAndOffset) {
  const DisplayModel display = smallDisplay(2, 200, 150);
  const PhysicalScene reference(makeCornellScene(), display.displayableBox);
  struct Variant {
    double scale;
    Eigen::Vector3d offset;
  };
  for (const Variant& v :
       {Variant{1e-3, Eigen::Vector3d::Zero()}, Variant{1e4, Eigen::Vector3d::Zero()},
        Variant{1.0, Eigen::Vector3d::Constant(1e4)},
        Variant{1e-3, Eigen::Vector3d(1e4, -1e4, 1e4)}}) {
    const PhysicalScene scaled(makeCornellScene(v.scale, v.offset), display.displayableBox);
    for (int module = 0; module < 2; ++module) {
      const RayTextures textures = generateRayTextures(display, module);
      const std::vector<std::uint8_t> a =
          renderFrame(reference, textures, RenderOptions{}).toSrgb8();
      const std::vector<std::uint8_t> b = renderFrame(scaled, textures, RenderOptions{}).toSrgb8();
      long differing = 0;
      for (size_t i = 0; i < a.size(); i += 3) {
        bool off = false;
        for (size_t k = 0; k < 3; ++k) off = off || std::abs(int(a[i + k]) - int(b[i + k])) > 1;
        differing += off ? 1 : 0;
      }
      const double fraction = static_cast<double>(differing) / static_cast<double>(a.size() / 3);
      EXPECT_LE(fraction, 0.001) << "scale " << v.scale << " offset " << v.offset.transpose()
                                 << " module " << module;
    }
  }
}

}  // namespace
}  // namespace parallax
