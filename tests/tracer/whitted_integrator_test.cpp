#include "tracer/whitted_integrator.h"

#include <gtest/gtest.h>

#include <cmath>

#include "tests/tracer/tracer_test_util.h"
#include "tracer/mesh_shapes.h"
#include "tracer/optics.h"
#include "tracer/scene_fixtures.h"

namespace parallax {
namespace {

using test::expectPaintedAt;
using test::forEachRenderedPixel;
using test::hitPlane;
using test::positionColouredRect;
using test::RenderedPixel;
using test::smallDisplay;
using test::WorldRay;
using test::worldRayOf;

// Secondary rays start a few hundred float ulps off the surface (offsetRayOrigin), which at
// grazing incidence moves where they land by ~1e-5 m physical: 1e-4 world units here (scale
// 0.25), under 1/100 of a pixel's footprint on the screen.
constexpr double kPathTolerance = 1e-4;

// The paper's Fig. 6: every covered pixel's colour is the world position where its primary
// ray meets the plane x + y + z = 1, mapped through B_W → B_P, to 1e-5 (rays within 3° of the
// plane: to the rounding of the ray, amplified by their grazing angle).
TEST(WhittedIntegrator, XyzTriangleColourIsTheExactWorldPosition) {
  const DisplayModel display = smallDisplay(3, 320, 240);
  const Scene scene = makeXyzTriangleScene();
  const PhysicalScene physical(scene, display.displayableBox);
  const Eigen::Vector3d n(1, 1, 1);
  for (int module = 0; module < 3; ++module) {
    const RayTextures textures = generateRayTextures(display, module);
    const Frame frame = renderFrame(physical, textures, RenderOptions{});
    long covered = 0, background = 0, grazing = 0;
    double worst = 0.0;
    for (int row = 0; row < textures.height(); ++row) {
      for (int column = 0; column < textures.width(); ++column) {
        const auto ray = worldRayOf(textures, column, row, physical.physicalFromWorld());
        if (!ray) continue;
        const auto t = hitPlane(*ray, n, 1.0);
        if (!t) continue;
        const Eigen::Vector3d p = ray->origin + *t * ray->direction;
        const Rgb& c = frame.at(column, row);
        // Well inside the triangle (1e-4 from its edges): the colour is the position.
        if (p.minCoeff() > 1e-4) {
          ++covered;
          const double error = (c.cast<double>() - p).cwiseAbs().maxCoeff();
          // A ray that grazes the plane moves its hit by 1/cos times any rounding of the ray
          // itself (float coordinates of a few units: ~5e-7), so the 1e-5 holds for rays at
          // least ~3° off the plane; the few grazing ones are held to that rounding instead.
          const double cosine = std::abs(ray->direction.dot(n.normalized()));
          if (cosine >= 0.05) {
            worst = std::max(worst, error);
            EXPECT_LT(error, 1e-5) << "module " << module << " pixel " << column << "," << row;
          } else {
            ++grazing;
            EXPECT_LT(error * cosine, 5e-7)
                << "module " << module << " pixel " << column << "," << row;
          }
        } else if (p.minCoeff() < -1e-4) {
          ++background;
          EXPECT_EQ(c, Rgb::Zero());
        }
      }
    }
    EXPECT_GT(covered - grazing, 300) << "the triangle must cover a good part of module " << module
                                      << " at angles where 1e-5 is meaningful";
    EXPECT_GT(background, 300);
    RecordProperty("worst_error_module_" + std::to_string(module), std::to_string(worst));
    RecordProperty("grazing_pixels_module_" + std::to_string(module), std::to_string(grazing));
  }
}

// A mirror floor y = -1 in front of a position-coloured back wall z = -1: rays that hit the
// floor continue as if from the mirror image, so their colour is the wall point the reflected
// ray meets.
TEST(WhittedIntegrator, MirrorPlaneReflectsAsTheLawOfReflectionSays) {
  const DisplayModel display = smallDisplay(2, 200, 150);
  Scene scene;
  const int mirror = scene.addMaterial(Material::makeMirror(Rgb::Ones()));
  const int wall = scene.addMaterial(Material::makeEmissive(Rgb::Ones()));
  scene.addMesh(positionColouredRect(0, 2, 1, -1.0, 1.0, 2.0, mirror));
  scene.meshes.back().colors.clear();  // the mirror itself has no colour
  scene.addMesh(positionColouredRect(0, 1, 2, -1.0, 1.0, 2.0, wall));
  scene.worldBox = Box3{Eigen::Vector3d::Constant(-1), Eigen::Vector3d::Constant(1)};
  const PhysicalScene physical(scene, display.displayableBox);
  long reflected = 0;
  forEachRenderedPixel(display, 2, physical, RenderOptions{}, [&](const RenderedPixel& pixel) {
    const WorldRay& ray = pixel.ray;
    const auto tFloor = hitPlane(ray, Eigen::Vector3d::UnitY(), -1.0);
    const auto tWall = hitPlane(ray, Eigen::Vector3d::UnitZ(), -1.0);
    if (!tFloor || (tWall && *tWall < *tFloor)) return;
    const Eigen::Vector3d p = ray.origin + *tFloor * ray.direction;
    if (std::abs(p.x()) > 0.98 || std::abs(p.z()) > 0.98) return;
    WorldRay bounced{p, Eigen::Vector3d(ray.direction.x(), -ray.direction.y(), ray.direction.z())};
    const auto t2 = hitPlane(bounced, Eigen::Vector3d::UnitZ(), -1.0);
    if (!t2) return;
    const Eigen::Vector3d q = bounced.origin + *t2 * bounced.direction;
    if (std::abs(q.x()) > 0.98 || std::abs(q.y()) > 0.98) return;
    ++reflected;
    EXPECT_GT(pixel.colour.z(), 0.5f);
    expectPaintedAt(pixel, q.x(), q.y(), kPathTolerance);
  });
  EXPECT_GT(reflected, 200);
}

// Snell refraction of a world ray at a plane with unit normal n facing the incoming side;
// eta = n_i / n_t. Independent of the tracer's float version.
std::optional<Eigen::Vector3d> snell(const Eigen::Vector3d& d, const Eigen::Vector3d& n,
                                     double eta) {
  const double cosI = -d.dot(n);
  const double sin2T = eta * eta * (1.0 - cosI * cosI);
  if (sin2T >= 1.0) return std::nullopt;
  return (eta * d + (eta * cosI - std::sqrt(1.0 - sin2T)) * n).normalized();
}

struct SlabResult {
  long checked = 0;
  double meanLateralShift = 0.0;
};

// A glass slab between z = -0.2 and z = 0.2 in front of a position-coloured wall at z = -1.
// Depth 3 traces exactly: front face, back face, wall (the internal reflections stop there).
SlabResult checkSlab(float ior) {
  const DisplayModel display = smallDisplay(2, 160, 120);
  Scene scene;
  const int glass = scene.addMaterial(Material::makeDielectric(ior));
  const int wall = scene.addMaterial(Material::makeEmissive(Rgb::Ones()));
  Mesh slab = makeBox({1.8, 1.8, 0.4});
  slab.material = glass;
  scene.addMesh(slab);
  scene.addMesh(positionColouredRect(0, 1, 2, -1.0, 1.0, 2.0, wall));
  scene.worldBox = Box3{Eigen::Vector3d::Constant(-1), Eigen::Vector3d::Constant(1)};
  scene.maxDepth = 3;
  const PhysicalScene physical(scene, display.displayableBox);
  RenderOptions options;
  options.minWeight = 0.0f;
  SlabResult result;
  double shiftSum = 0.0;
  forEachRenderedPixel(display, 2, physical, options, [&](const RenderedPixel& pixel) {
    const WorldRay& ray = pixel.ray;
    const auto t0 = hitPlane(ray, Eigen::Vector3d::UnitZ(), 0.2);
    if (!t0) return;
    const Eigen::Vector3d p0 = ray.origin + *t0 * ray.direction;
    const auto inside = snell(ray.direction, Eigen::Vector3d::UnitZ(), 1.0 / ior);
    WorldRay in{p0, *inside};
    const Eigen::Vector3d p1 =
        in.origin + *hitPlane(in, Eigen::Vector3d::UnitZ(), -0.2) * in.direction;
    const auto out = snell(in.direction, Eigen::Vector3d::UnitZ(), ior);
    if (!out) return;
    WorldRay leaving{p1, *out};
    const Eigen::Vector3d q =
        leaving.origin + *hitPlane(leaving, Eigen::Vector3d::UnitZ(), -1.0) * leaving.direction;
    if (std::abs(p0.x()) > 0.85 || std::abs(p0.y()) > 0.85 || std::abs(p1.x()) > 0.85 ||
        std::abs(p1.y()) > 0.85 || std::abs(q.x()) > 0.98 || std::abs(q.y()) > 0.98) {
      return;
    }
    // Where the wall would be hit without the slab: the lateral shift is the difference.
    const Eigen::Vector3d unbent =
        ray.origin + *hitPlane(ray, Eigen::Vector3d::UnitZ(), -1.0) * ray.direction;
    shiftSum += (q - unbent).head<2>().norm();
    ++result.checked;
    EXPECT_GT(pixel.colour.z(), 0.8f) << "transmission through two faces near normal incidence";
    expectPaintedAt(pixel, q.x(), q.y(), kPathTolerance);
    if (ior == 1.0f) {
      EXPECT_NEAR(pixel.colour.z(), 1.0f, 1e-6f)
          << "an index-matched slab neither reflects nor absorbs";
    }
  });
  result.meanLateralShift = result.checked ? shiftSum / static_cast<double>(result.checked) : 0.0;
  return result;
}

TEST(WhittedIntegrator, GlassSlabShiftsRaysLaterallyBySnellsLaw) {
  const SlabResult r = checkSlab(1.5f);
  EXPECT_GT(r.checked, 1000);
  // The display's rays meet the slab at up to ~25°: a visible shift, not a rounding error.
  EXPECT_GT(r.meanLateralShift, 1e-3);
}

TEST(WhittedIntegrator, IndexOfRefractionOneLeavesRaysUnbent) {
  const SlabResult r = checkSlab(1.0f);
  EXPECT_GT(r.checked, 1000);
  EXPECT_LT(r.meanLateralShift, 1e-6);
}

// A 45° prism: rays enter its front face, meet the hypotenuse past the critical angle
// (41.8° for n = 1.5), are totally reflected downward and leave through the bottom face onto a
// position-coloured floor.
TEST(WhittedIntegrator, TotalInternalReflectionInAPrism) {
  const DisplayModel display = smallDisplay(2, 160, 120);
  Scene scene;
  const int glass = scene.addMaterial(Material::makeDielectric(1.5f));
  const int floor = scene.addMaterial(Material::makeEmissive(Rgb::Ones()));
  Mesh prism;
  prism.material = glass;
  // Cross-section in (y, z): A = (0.5, 0.5), B = (-0.5, 0.5), C = (-0.5, -0.5); along x ±0.9.
  for (double x : {-0.9, 0.9}) {
    prism.positions.push_back({x, 0.5, 0.5});
    prism.positions.push_back({x, -0.5, 0.5});
    prism.positions.push_back({x, -0.5, -0.5});
  }
  // Outward, counter-clockwise: front (z = 0.5), bottom (y = -0.5), hypotenuse, two ends.
  prism.triangles = {{0, 1, 4}, {0, 4, 3}, {1, 2, 5}, {1, 5, 4},
                     {2, 0, 3}, {2, 3, 5}, {0, 2, 1}, {3, 4, 5}};
  scene.addMesh(prism);
  scene.addMesh(positionColouredRect(0, 2, 1, -1.0, 1.0, 2.0, floor));
  scene.worldBox = Box3{Eigen::Vector3d::Constant(-1), Eigen::Vector3d::Constant(1)};
  scene.maxDepth = 4;
  const PhysicalScene physical(scene, display.displayableBox);
  RenderOptions options;
  options.minWeight = 0.0f;
  const Eigen::Vector3d hypotenuseNormal = Eigen::Vector3d(0, 1, -1).normalized();  // outward
  long totallyReflected = 0;
  forEachRenderedPixel(display, 2, physical, options, [&](const RenderedPixel& pixel) {
    const WorldRay& ray = pixel.ray;
    const auto t0 = hitPlane(ray, Eigen::Vector3d::UnitZ(), 0.5);
    if (!t0) return;
    const Eigen::Vector3d p0 = ray.origin + *t0 * ray.direction;
    if (std::abs(p0.x()) > 0.8 || p0.y() > 0.45 || p0.y() < -0.45) return;
    WorldRay in{p0, *snell(ray.direction, Eigen::Vector3d::UnitZ(), 1.0 / 1.5)};
    const Eigen::Vector3d p1 = in.origin + *hitPlane(in, hypotenuseNormal, 0.0) * in.direction;
    // Past the critical angle there is no refracted ray: the analytic answer is TIR.
    EXPECT_FALSE(snell(in.direction, -hypotenuseNormal, 1.5).has_value()) << "expected TIR";
    WorldRay down{p1, in.direction - 2.0 * in.direction.dot(hypotenuseNormal) * hypotenuseNormal};
    const auto t2 = hitPlane(down, Eigen::Vector3d::UnitY(), -0.5);
    if (!t2) return;
    const Eigen::Vector3d p2 = down.origin + *t2 * down.direction;
    if (std::abs(p2.x()) > 0.8 || p2.z() > 0.45 || p2.z() < -0.45 || std::abs(p1.x()) > 0.8) return;
    WorldRay out{p2, *snell(down.direction, Eigen::Vector3d::UnitY(), 1.5)};
    const Eigen::Vector3d q =
        out.origin + *hitPlane(out, Eigen::Vector3d::UnitY(), -1.0) * out.direction;
    if (std::abs(q.x()) > 0.98 || std::abs(q.z()) > 0.98) return;
    ++totallyReflected;
    EXPECT_GT(pixel.colour.z(), 0.8f)
        << "TIR loses nothing; only the two refracting faces reflect a little";
    expectPaintedAt(pixel, q.x(), q.z(), kPathTolerance);
  });
  EXPECT_GT(totallyReflected, 500);
}

// Nearest intersection of a world ray with the exact sphere |x| = r (nullopt on a miss).
std::optional<double> hitSphere(const WorldRay& ray, double r, bool farSide = false) {
  const double b = ray.origin.dot(ray.direction);
  const double c = ray.origin.squaredNorm() - r * r;
  const double disc = b * b - c;
  if (disc < 0.0) return std::nullopt;
  const double t = farSide ? -b + std::sqrt(disc) : -b - std::sqrt(disc);
  if (!(t > 0.0)) return std::nullopt;
  return t;
}

// The tessellated sphere (192 × 96) departs from the exact one by at most r·(1 − cos(π/192)) ≈
// 7e-5 r in position and a few 1e-5 rad in its interpolated normal; paths are compared with
// the exact sphere's analytic answer to this tolerance (world units, sphere radius 0.5).
constexpr double kSphereTolerance = 2e-3;

struct SphereSetup {
  Scene scene;
  int sphereMaterial = 0;
};

SphereSetup sphereBeforeWall(const Material& sphereMaterial, int maxDepth) {
  SphereSetup s;
  s.sphereMaterial = s.scene.addMaterial(sphereMaterial);
  const int wall = s.scene.addMaterial(Material::makeEmissive(Rgb::Ones()));
  Mesh sphere = makeSphere(0.5, 192, 96);
  sphere.material = s.sphereMaterial;
  s.scene.addMesh(sphere);
  s.scene.addMesh(positionColouredRect(0, 1, 2, -1.0, 1.0, 2.0, wall));
  s.scene.worldBox = Box3{Eigen::Vector3d::Constant(-1), Eigen::Vector3d::Constant(1)};
  s.scene.maxDepth = maxDepth;
  return s;
}

// Rays meeting a mirror sphere beyond 45° from its front reflect backwards onto the wall.
TEST(WhittedIntegrator, MirrorSphereReflectsAsTheLawOfReflectionSays) {
  const DisplayModel display = smallDisplay(2, 240, 180);
  const SphereSetup setup = sphereBeforeWall(Material::makeMirror(Rgb::Ones()), 5);
  const PhysicalScene physical(setup.scene, display.displayableBox);
  long checked = 0;
  forEachRenderedPixel(display, 2, physical, RenderOptions{}, [&](const RenderedPixel& pixel) {
    const WorldRay& ray = pixel.ray;
    const auto t = hitSphere(ray, 0.5);
    if (!t) return;
    const Eigen::Vector3d p = ray.origin + *t * ray.direction;
    const Eigen::Vector3d n = p.normalized();
    const double cosine = -ray.direction.dot(n);
    if (cosine < std::cos(75.0 * 3.14159265358979 / 180.0))
      return;  // grazing: tessellation dominates
    WorldRay bounced{p, ray.direction - 2.0 * ray.direction.dot(n) * n};
    const auto t2 = hitPlane(bounced, Eigen::Vector3d::UnitZ(), -1.0);
    if (!t2) return;
    const Eigen::Vector3d q = bounced.origin + *t2 * bounced.direction;
    if (std::abs(q.x()) > 0.95 || std::abs(q.y()) > 0.95) return;
    ++checked;
    EXPECT_GT(pixel.colour.z(), 0.5f) << pixel.column << "," << pixel.row;
    expectPaintedAt(pixel, q.x(), q.y(), kSphereTolerance);
  });
  EXPECT_GT(checked, 30) << "the 45°–75° ring that reflects onto the wall";
}

// Through a glass sphere and out again onto the wall: two refractions by Snell's law.
TEST(WhittedIntegrator, GlassSphereRefractsAsSnellsLawSays) {
  const DisplayModel display = smallDisplay(2, 240, 180);
  const float ior = 1.5f;
  const SphereSetup setup = sphereBeforeWall(Material::makeDielectric(ior), 3);
  const PhysicalScene physical(setup.scene, display.displayableBox);
  RenderOptions options;
  options.minWeight = 0.0f;
  long checked = 0;
  forEachRenderedPixel(display, 2, physical, options, [&](const RenderedPixel& pixel) {
    const WorldRay& ray = pixel.ray;
    const auto t = hitSphere(ray, 0.5);
    if (!t) return;
    const Eigen::Vector3d p = ray.origin + *t * ray.direction;
    const Eigen::Vector3d n = p.normalized();
    if (-ray.direction.dot(n) < std::cos(50.0 * 3.14159265358979 / 180.0)) return;
    WorldRay inside{p, *snell(ray.direction, n, 1.0 / ior)};
    const Eigen::Vector3d p1 = inside.origin + *hitSphere(inside, 0.5, true) * inside.direction;
    const auto out = snell(inside.direction, -p1.normalized(), ior);
    if (!out) return;
    WorldRay leaving{p1, *out};
    const auto t2 = hitPlane(leaving, Eigen::Vector3d::UnitZ(), -1.0);
    if (!t2) return;
    const Eigen::Vector3d q = leaving.origin + *t2 * leaving.direction;
    if (std::abs(q.x()) > 0.95 || std::abs(q.y()) > 0.95) return;
    ++checked;
    EXPECT_GT(pixel.colour.z(), 0.5f) << pixel.column << "," << pixel.row;
    expectPaintedAt(pixel, q.x(), q.y(), kSphereTolerance);
  });
  EXPECT_GT(checked, 500);
}

TEST(Optics, SnellFresnelAndTotalInternalReflection) {
  const Eigen::Vector3f n(0, 0, 1);
  Eigen::Vector3f t;
  float cosT = 0.0f;
  // Normal incidence: straight through, R = ((n1 - n2) / (n1 + n2))² = 0.04 for glass.
  ASSERT_TRUE(refract({0, 0, -1}, n, 1.0f / 1.5f, &t, &cosT));
  EXPECT_NEAR((t - Eigen::Vector3f(0, 0, -1)).norm(), 0.0f, 1e-6f);
  EXPECT_NEAR(fresnelDielectric(1.0f, cosT, 1.0f / 1.5f), 0.04f, 1e-6f);
  // 30° in air → asin(sin 30° / 1.5) = 19.47° in glass.
  const float a = 30.0f * 3.14159265f / 180.0f;
  ASSERT_TRUE(refract({std::sin(a), 0, -std::cos(a)}, n, 1.0f / 1.5f, &t, &cosT));
  EXPECT_NEAR(std::asin(t.x()) * 180.0f / 3.14159265f, 19.4712f, 1e-3f);
  // From glass, just below and just above the critical angle asin(1/1.5) = 41.81°.
  for (float deg : {41.5f, 42.2f}) {
    const float b = deg * 3.14159265f / 180.0f;
    const bool transmits = refract({std::sin(b), 0, -std::cos(b)}, n, 1.5f, &t, &cosT);
    EXPECT_EQ(transmits, deg < 41.81f) << deg;
  }
  // IOR 1: unbent, nothing reflected.
  ASSERT_TRUE(refract(Eigen::Vector3f(0.6f, 0, -0.8f), n, 1.0f, &t, &cosT));
  EXPECT_NEAR((t - Eigen::Vector3f(0.6f, 0, -0.8f)).norm(), 0.0f, 1e-6f);
  EXPECT_NEAR(fresnelDielectric(0.8f, cosT, 1.0f), 0.0f, 1e-7f);
  // Reflection keeps the tangential part and flips the normal one.
  EXPECT_NEAR((reflect({0.6f, 0, -0.8f}, n) - Eigen::Vector3f(0.6f, 0, 0.8f)).norm(), 0.0f, 1e-7f);
}

}  // namespace
}  // namespace parallax
