#include "tracer/physical_scene.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <optional>

#include "common/check.h"
#include "tracer/embree_device.h"
#include "tracer/glass_shadows.h"

namespace parallax {
namespace {

// A polygon vertex during clipping: its physical position and its barycentric coordinates in
// the source triangle (to interpolate normals, uvs and colours of the new vertices).
struct ClipVertex {
  Eigen::Vector3d p;
  Eigen::Vector3d bary;
};

// Sutherland–Hodgman against the six faces of `box`. Returns the inside polygon (possibly
// empty). Vertices within `tolerance` of a face count as inside, so geometry that lies exactly
// on B_P's boundary (a scene filling B_W) is not shaved by rounding.
std::vector<ClipVertex> clipToBox(std::vector<ClipVertex> polygon, const Box3& box,
                                  double tolerance) {
  for (int axis = 0; axis < 3 && !polygon.empty(); ++axis) {
    for (int side = 0; side < 2 && !polygon.empty(); ++side) {
      // Signed distance inside the face: >= 0 keeps.
      auto inside = [&](const ClipVertex& v) {
        return side == 0 ? v.p[axis] - (box.min[axis] - tolerance)
                         : (box.max[axis] + tolerance) - v.p[axis];
      };
      std::vector<ClipVertex> out;
      for (size_t i = 0; i < polygon.size(); ++i) {
        const ClipVertex& a = polygon[i];
        const ClipVertex& b = polygon[(i + 1) % polygon.size()];
        const double da = inside(a), db = inside(b);
        if (da >= 0.0) out.push_back(a);
        if ((da >= 0.0) != (db >= 0.0)) {
          const double t = da / (da - db);
          out.push_back({a.p + t * (b.p - a.p), a.bary + t * (b.bary - a.bary)});
        }
      }
      polygon = std::move(out);
    }
  }
  if (polygon.size() < 3) polygon.clear();
  return polygon;
}

bool insideBox(const Eigen::Vector3d& p, const Box3& box, double tolerance) {
  return (p.array() >= box.min.array() - tolerance).all() &&
         (p.array() <= box.max.array() + tolerance).all();
}

bool degenerate(const Eigen::Vector3f& a, const Eigen::Vector3f& b, const Eigen::Vector3f& c) {
  const Eigen::Vector3f n = (b - a).cross(c - a);
  // Zero (or non-finite) area in float is what the tracer would see: Embree never reports a hit
  // on it and its normal is undefined.
  return !(n.squaredNorm() > 0.0f) || !n.allFinite();
}

// Every triangle's three vertex normals are its face normal (or all its opposite, which the hit
// record flips to the incoming side just the same): interpolating them changes nothing. The
// tolerance, 1e-6 in the cosine (0.08°), sits above float rounding of unit vectors (~1e-7).
bool normalsAreFlat(const PhysicalMesh& mesh) {
  constexpr double kParallel = 1.0 - 1e-6;
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const Eigen::Vector3d face = mesh.faceNormals[t].cast<double>();
    int sameSide = 0, oppositeSide = 0;
    for (std::uint32_t v : mesh.triangles[t]) {
      const Eigen::Vector3d n = mesh.normals[v].cast<double>();
      const double length = n.norm();
      if (!(length > 0.0) || !std::isfinite(length)) return false;
      const double cosine = n.dot(face) / length;
      sameSide += cosine >= kParallel ? 1 : 0;
      oppositeSide += cosine <= -kParallel ? 1 : 0;
    }
    if (sameSide != 3 && oppositeSide != 3) return false;
  }
  return true;
}

// What the tests that use a bound sphere round (a distance squared and a projection, a few
// ulps of the scene's size), and Embree's own triangle test: the sphere is widened by it.
float sphereMargin(const Eigen::Vector3f& boundsMin, const Eigen::Vector3f& boundsMax) {
  return 1e-4f * (boundsMax - boundsMin).norm() + 1e-6f;
}

// The sphere about the meshes' box centre through their farthest corner: a ball that holds a
// triangle's corners holds the triangle (it is convex). Centre and radius, widened by `margin`.
Eigen::Vector4f boundingSphere(const std::vector<const PhysicalMesh*>& meshes, float margin) {
  Eigen::AlignedBox3f box;
  for (const PhysicalMesh* mesh : meshes)
    for (const auto& t : mesh->triangles)
      for (std::uint32_t index : t) box.extend(mesh->positions[index]);
  const Eigen::Vector3f centre = box.center();
  float radius = 0.0f;
  for (const PhysicalMesh* mesh : meshes)
    for (const auto& t : mesh->triangles)
      for (std::uint32_t index : t)
        radius = std::max(radius, (mesh->positions[index] - centre).norm());
  return {centre.x(), centre.y(), centre.z(), radius * (1.0f + 1e-4f) + margin};
}

}  // namespace

PhysicalScene::PhysicalScene(const Scene& scene, const Box3& displayableBox,
                             const std::vector<bool>* dynamicInstances, PhysicalScene* previous) {
  const auto start = std::chrono::steady_clock::now();
  scene.validate();
  physicalFromWorld_ = parallax::physicalFromWorld(scene.effectiveWorldBox(), displayableBox);
  features_ = analyseScene(scene);
  materials_ = scene.materials;
  background_ = scene.background;
  ambient_ = scene.ambient;
  animated_ = scene.animated;

  for (const Light& light : scene.lights) {
    PhysicalLight l;
    l.kind = light.kind;
    l.intensity = light.intensity;
    // A uniform scale keeps directions; only positions move.
    l.toLight = (-light.direction.normalized()).cast<float>();
    l.position = physicalFromWorld_.point(light.position).cast<float>();
    lights_.push_back(l);
  }

  if (dynamicInstances) {
    PARALLAX_CHECK_OP(dynamicInstances->size(), ==, scene.instances.size());
    dynamicInstances_ = *dynamicInstances;
  }
  instanceMeshes_.assign(scene.instances.size(), -1);
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    const size_t before = meshes_.size();
    addInstance(scene, scene.instances[i], displayableBox);
    if (meshes_.size() > before) {
      instanceMeshes_[i] = static_cast<int>(before);
      meshInstances_.push_back(static_cast<int>(i));
    }
  }
  for (const std::string& name : features_.unsampledTextureMaterials) {
    warnings_.push_back("material " + name +
                        " has a texture but its mesh has no UVs: texture ignored");
  }

  // Build: high-quality SAH for a static scene (built once, traced for many frames); the
  // dynamic flags and a medium-quality build for an animated one (rebuilt every frame: on
  // orbit.lua its rays take 5-8% less of Embree's time than after a low-quality build, for about
  // 0.1 ms more a build; the same hits).
  RTCDevice device = embreeDevice();
  // The partial scenes take the same flags: the same leaf layout, so a ray meets a triangle
  // with the same arithmetic (the same u, v, t to the bit) in any of them.
  scene_ = newScene();
  if (split()) dynamicScene_ = newScene();
  boundsMin_ = Eigen::Vector3f::Constant(std::numeric_limits<float>::infinity());
  boundsMax_ = -boundsMin_;
  // Glass lets shadow rays through (glass_shadows.h) by a filter on the dielectric geometries
  // only: other geometries, and scenes without glass or without shadow rays, never call it.
  glassShadows_ = features_.shadowPass() && features_.dielectrics;
  if (glassShadows_ &&
      rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_FILTER_FUNCTION_SUPPORTED) == 0) {
    glassShadows_ = false;
    warnings_.push_back("this Embree has no filter functions: glass casts opaque shadows");
  }
  for (size_t g = 0; g < meshes_.size(); ++g) {
    const PhysicalMesh& mesh = meshes_[g];
    RTCGeometry geometry = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetGeometryBuildQuality(geometry,
                               animated_ ? RTC_BUILD_QUALITY_MEDIUM : RTC_BUILD_QUALITY_HIGH);
    auto* vertices = static_cast<float*>(
        rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                3 * sizeof(float), mesh.positions.size()));
    auto* indices = static_cast<std::uint32_t*>(
        rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                3 * sizeof(std::uint32_t), mesh.triangles.size()));
    throwIfEmbreeFailed("geometry allocation");
    for (size_t i = 0; i < mesh.positions.size(); ++i) {
      for (int k = 0; k < 3; ++k) vertices[3 * i + static_cast<size_t>(k)] = mesh.positions[i][k];
    }
    for (size_t t = 0; t < mesh.triangles.size(); ++t) {
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t index = mesh.triangles[t][static_cast<size_t>(k)];
        indices[3 * t + static_cast<size_t>(k)] = index;
        boundsMin_ = boundsMin_.cwiseMin(mesh.positions[index]);
        boundsMax_ = boundsMax_.cwiseMax(mesh.positions[index]);
      }
    }
    if (glassShadows_ &&
        materials_[static_cast<size_t>(mesh.material)].kind == MaterialKind::kDielectric) {
      rtcSetGeometryOccludedFilterFunction(geometry, glassShadowFilter);
    }
    rtcCommitGeometry(geometry);
    const unsigned id = rtcAttachGeometry(scene_, geometry);
    PARALLAX_CHECK_OP(id, ==, static_cast<unsigned>(g));
    if (split() && dynamicInstances_[static_cast<size_t>(meshInstances_[g])]) {
      rtcAttachGeometryByID(dynamicScene_, geometry, id);
    }
    geometries_.push_back(geometry);  // kept for the partial scenes
  }
  rtcCommitScene(scene_);
  if (dynamicScene_) rtcCommitScene(dynamicScene_);
  if (split()) boundDynamicMeshes();
  boundOccluders();
  // The faces' test and the extra BVHs side by side: on orbit.lua each took 0.6 ms a frame on
  // one thread while the other core waited.
  const std::vector<bool> candidates = withoutMeshCandidates();
  tbb::parallel_invoke([&] { markBareFaces(candidates); },
                       [&] { buildWithoutMeshScenes(candidates); });
  dropWithoutMeshScenesOfMeshesWithoutBareFaces();
  throwIfEmbreeFailed("the scene build");
  if (counters_.trianglesBuilt == 0) {
    boundsMin_ = boundsMax_ = Eigen::Vector3f::Zero();
    warnings_.push_back(
        "no triangle lies inside the displayable box: the frame shows only the background");
  }
  loadTextures(scene, previous);
  counters_.buildMs =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

PhysicalScene::~PhysicalScene() {
  if (scene_) rtcReleaseScene(scene_);
  if (dynamicScene_) rtcReleaseScene(dynamicScene_);
  if (staticScene_) rtcReleaseScene(staticScene_);
  for (RTCScene s : withoutMesh_)
    if (s) rtcReleaseScene(s);
  for (RTCGeometry g : geometries_) rtcReleaseGeometry(g);
}

void PhysicalScene::boundDynamicMeshes() {
  // Per dynamic mesh (or all of them together past kMaxDynamicSpheres) the corners of its
  // triangles. A ball that holds a triangle's corners holds the triangle (it is convex), so the
  // sphere about the box's centre through the farthest corner bounds the mesh. Half the box's
  // diagonal bounds it too, but is sqrt(3) times a ball's radius and 1.4 times a torus's: on
  // orbit.lua it sent twice the shadow rays through dynamicHandle().
  std::vector<std::vector<const PhysicalMesh*>> groups;
  for (size_t g = 0; g < meshes_.size(); ++g) {
    if (!dynamicInstances_[static_cast<size_t>(meshInstances_[g])]) continue;
    if (meshes_[g].triangles.empty()) continue;
    groups.push_back({&meshes_[g]});
  }
  if (groups.size() > kMaxDynamicSpheres) {
    for (size_t i = 1; i < groups.size(); ++i) groups[0].push_back(groups[i][0]);
    groups.resize(1);
  }
  const float margin = sphereMargin(boundsMin_, boundsMax_);
  dynamicSpheres_.clear();
  for (const auto& group : groups) dynamicSpheres_.push_back(boundingSphere(group, margin));
}

namespace {

// A sphere inside a closed convex mesh (centre, radius; radius 0 when the mesh is not closed and
// convex, or too large to check): about the mean of its corners, as far as its nearest face's
// plane, less a margin far wider than the float rounding of a ray's distance from the centre.
// Convex: every corner lies behind every face's plane (CCW side out), within the rounding of the
// corners. Closed: every edge, its ends welded by position, is shared by exactly two faces.
Eigen::Vector4f coreSphere(const PhysicalMesh& mesh) {
  constexpr double kMaxWork = 1 << 20;
  constexpr double kEpsilon = std::numeric_limits<float>::epsilon();
  const Eigen::Vector4f none = Eigen::Vector4f::Zero();
  if (mesh.triangles.size() < 4) return none;
  double extent = 0.0;
  for (const Eigen::Vector3f& p : mesh.positions)
    extent = std::max(extent, static_cast<double>(p.cwiseAbs().maxCoeff()));
  const double tolerance = 16.0 * kEpsilon * extent;
  // Corners within the tolerance are one (a sphere's seam and poles repeat their corners, a few
  // ulps apart once transformed): looked up in a grid of cells twice the tolerance wide.
  const double cell = 2.0 * tolerance;
  if (!(cell > 0.0)) return none;
  std::map<std::array<std::int64_t, 3>, std::vector<std::uint32_t>> grid;
  std::vector<Eigen::Vector3d> corners;
  std::vector<std::uint32_t> weld(mesh.positions.size());
  for (size_t v = 0; v < mesh.positions.size(); ++v) {
    const Eigen::Vector3d p = mesh.positions[v].cast<double>();
    std::array<std::int64_t, 3> key;
    for (int k = 0; k < 3; ++k)
      key[static_cast<size_t>(k)] = static_cast<std::int64_t>(std::floor(p[k] / cell));
    std::optional<std::uint32_t> found;
    for (int dx = -1; dx <= 1 && !found; ++dx) {
      for (int dy = -1; dy <= 1 && !found; ++dy) {
        for (int dz = -1; dz <= 1 && !found; ++dz) {
          const auto it = grid.find({key[0] + dx, key[1] + dy, key[2] + dz});
          if (it == grid.end()) continue;
          for (std::uint32_t id : it->second) {
            if ((corners[id] - p).cwiseAbs().maxCoeff() <= tolerance) {
              found = id;
              break;
            }
          }
        }
      }
    }
    if (!found) {
      found = static_cast<std::uint32_t>(corners.size());
      corners.push_back(p);
      grid[key].push_back(*found);
    }
    weld[v] = *found;
  }
  if (static_cast<double>(mesh.triangles.size()) * static_cast<double>(corners.size()) > kMaxWork)
    return none;
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> edges;
  for (const auto& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) {
      std::uint32_t a = weld[t[static_cast<size_t>(k)]],
                    b = weld[t[static_cast<size_t>((k + 1) % 3)]];
      if (a == b) return none;
      if (a > b) std::swap(a, b);
      ++edges[{a, b}];
    }
  }
  for (const auto& [edge, count] : edges)
    if (count != 2) return none;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& c : corners) centre += c;
  centre /= static_cast<double>(corners.size());
  double radius = std::numeric_limits<double>::infinity();
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d p0 = mesh.positions[t[0]].cast<double>();
    const Eigen::Vector3d n = (mesh.positions[t[1]].cast<double>() - p0)
                                  .cross(mesh.positions[t[2]].cast<double>() - p0)
                                  .normalized();
    if (!n.allFinite()) return none;
    for (const Eigen::Vector3d& c : corners)
      if (n.dot(c - p0) > tolerance) return none;
    radius = std::min(radius, -n.dot(centre - p0));
  }
  // Far more than the rounding of the kernel's distance test (a few ulps of the scene's size).
  radius = radius * (1.0 - 1e-3) - 1e3 * tolerance;
  if (!(radius > 0.0) || !std::isfinite(radius)) return none;
  return {static_cast<float>(centre.x()), static_cast<float>(centre.y()),
          static_cast<float>(centre.z()), static_cast<float>(radius)};
}

}  // namespace

void PhysicalScene::boundOccluders() {
  occluders_.clear();
  if (meshes_.size() > kMaxOccluders) return;
  const float margin = sphereMargin(boundsMin_, boundsMax_);
  // A plane's: the float rounding of a distance from it, n · a − c, and of Embree's test of
  // which side of a triangle a ray starts (its errors grow with v0 − o, inside the bounds).
  constexpr double kEpsilon = std::numeric_limits<float>::epsilon();
  const double reach = (boundsMax_ - boundsMin_).cast<double>().norm() +
                       boundsMin_.cwiseAbs().cwiseMax(boundsMax_.cwiseAbs()).cast<double>().norm();
  for (const PhysicalMesh& mesh : meshes_) {
    OccluderBound bound;
    bound.sphere = boundingSphere({&mesh}, margin);
    // Flat: every corner within float rounding of the largest triangle's plane (in double).
    size_t largest = 0;
    for (size_t t = 1; t < mesh.triangles.size(); ++t)
      if (mesh.crossLengths[t] > mesh.crossLengths[largest]) largest = t;
    const auto corner = [&](size_t t, int k) {
      return mesh.positions[mesh.triangles[t][static_cast<size_t>(k)]].cast<double>();
    };
    const Eigen::Vector3d n = (corner(largest, 1) - corner(largest, 0))
                                  .cross(corner(largest, 2) - corner(largest, 0))
                                  .normalized();
    const double c = n.dot(corner(largest, 0));
    double deviation = 0.0, extent = 0.0;
    for (const auto& t : mesh.triangles) {
      for (std::uint32_t index : t) {
        const Eigen::Vector3d p = mesh.positions[index].cast<double>();
        deviation = std::max(deviation, std::abs(n.dot(p) - c));
        extent = std::max(extent, p.cwiseAbs().maxCoeff());
      }
    }
    if (n.allFinite() && deviation <= 16.0 * kEpsilon * extent && reach > 0.0) {
      bound.plane = {static_cast<float>(n.x()), static_cast<float>(n.y()),
                     static_cast<float>(n.z()), static_cast<float>(c)};
      bound.planeMargin = static_cast<float>(deviation + 16.0 * kEpsilon * reach);
    }
    const bool passesLight = glassShadows_ && materials_[static_cast<size_t>(mesh.material)].kind ==
                                                  MaterialKind::kDielectric;
    if (!passesLight && !bound.flat()) {
      if (!mesh.interior.empty()) {
        for (const Eigen::Vector4f& sphere : mesh.interior) {
          if (bound.coreCount == OccluderBound::kMaxCores) break;
          bound.cores[static_cast<size_t>(bound.coreCount++)] = sphere;
        }
      } else if (const Eigen::Vector4f core = coreSphere(mesh); core.w() > 0.0f) {
        bound.cores[0] = core;
        bound.coreCount = 1;
      }
      for (int first = 0; first < bound.coreCount; first += OccluderBound::kCoresPerGroup) {
        const int last = std::min(bound.coreCount, first + OccluderBound::kCoresPerGroup);
        Eigen::Vector3f centre = Eigen::Vector3f::Zero();
        for (int k = first; k < last; ++k) centre += bound.cores[static_cast<size_t>(k)].head<3>();
        centre /= static_cast<float>(last - first);
        float radius = 0.0f;
        for (int k = first; k < last; ++k) {
          const Eigen::Vector4f& core = bound.cores[static_cast<size_t>(k)];
          radius = std::max(radius, (core.head<3>() - centre).norm() + core.w());
        }
        bound.coreGroups[static_cast<size_t>(first / OccluderBound::kCoresPerGroup)] = {
            centre.x(), centre.y(), centre.z(), radius * (1.0f + 1e-4f) + margin};
      }
    }
    bound.ring = mesh.ring;  // an outer bound: glass's too
    occluders_.push_back(bound);
  }
}

std::vector<bool> PhysicalScene::withoutMeshCandidates() const {
  std::vector<bool> candidates(meshes_.size(), false);
  if (meshes_.size() < 2) return candidates;  // nothing else to meet: the background
  size_t count = 0;
  for (size_t g = 0; g < meshes_.size() && count < kMaxWithoutMeshScenes; ++g) {
    const MaterialKind kind = materials_[static_cast<size_t>(meshes_[g].material)].kind;
    if (kind != MaterialKind::kMirror && kind != MaterialKind::kDielectric) continue;
    candidates[g] = true;
    ++count;
  }
  if (static_cast<long>(count) * counters_.trianglesBuilt > kMaxWithoutMeshTriangles)
    candidates.assign(meshes_.size(), false);
  return candidates;
}

void PhysicalScene::buildWithoutMeshScenes(const std::vector<bool>& candidates) {
  withoutMesh_.assign(meshes_.size(), nullptr);
  std::vector<size_t> built;
  for (size_t g = 0; g < meshes_.size(); ++g) {
    if (!candidates[g]) continue;
    withoutMesh_[g] = newScene();
    for (size_t other = 0; other < geometries_.size(); ++other) {
      if (other != g)
        rtcAttachGeometryByID(withoutMesh_[g], geometries_[other], static_cast<unsigned>(other));
    }
    built.push_back(g);
  }
  tbb::parallel_for(size_t{0}, built.size(),
                    [&](size_t i) { rtcCommitScene(withoutMesh_[built[i]]); });
  throwIfEmbreeFailed("the scenes without one mesh");
}

void PhysicalScene::dropWithoutMeshScenesOfMeshesWithoutBareFaces() {
  withoutMeshScenes_ = 0;
  for (size_t g = 0; g < meshes_.size(); ++g) {
    if (!withoutMesh_[g]) continue;
    const std::vector<std::int32_t>& bare = meshes_[g].bareFaces;
    if (std::none_of(bare.begin(), bare.end(), [](std::int32_t b) { return b != 0; })) {
      rtcReleaseScene(withoutMesh_[g]);
      withoutMesh_[g] = nullptr;
    } else {
      ++withoutMeshScenes_;
    }
  }
}

void PhysicalScene::markBareFaces(const std::vector<bool>& specular) {
  // Every triangle against every vertex: bounded, so a dense mesh costs no more than this.
  constexpr double kMaxWork = 1 << 20;
  constexpr double kEpsilon = std::numeric_limits<float>::epsilon();
  for (size_t g = 0; g < meshes_.size(); ++g) {
    PhysicalMesh& mesh = meshes_[g];
    mesh.bareFaces.clear();
    // Shadow rays leave diffuse surfaces, with occluders to test them against; reflection and
    // refraction rays leave mirrors and glass, with a scene without their mesh.
    const bool diffuse =
        materials_[static_cast<size_t>(mesh.material)].kind == MaterialKind::kDiffuse;
    if (!(diffuse && !occluders_.empty()) && !specular[g]) continue;
    std::vector<std::uint8_t> used(mesh.positions.size(), 0);
    for (const auto& t : mesh.triangles)
      for (std::uint32_t index : t) used[index] = 1;
    std::vector<Eigen::Vector3d> corners;
    double extent = 0.0;
    for (size_t v = 0; v < used.size(); ++v) {
      if (!used[v]) continue;
      corners.push_back(mesh.positions[v].cast<double>());
      extent = std::max(extent, corners.back().cwiseAbs().maxCoeff());
    }
    if (static_cast<double>(mesh.triangles.size()) * static_cast<double>(corners.size()) > kMaxWork)
      continue;
    // A corner in front of a triangle's plane by less than the float rounding of the corners
    // (as for a flat mesh's plane, boundOccluders) counts as on it: a shadow ray starts
    // offsetRayOrigin's step off its face (hundreds of ulps, Wächter and Binder's offset, which
    // already keeps Embree from finding the face it leaves) and moves away from the plane.
    const double tolerance = 16.0 * kEpsilon * extent;
    mesh.bareFaces.assign(mesh.triangles.size(), 0);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, mesh.triangles.size(), 32),
                      [&](const tbb::blocked_range<size_t>& range) {
                        for (size_t t = range.begin(); t != range.end(); ++t) {
                          mesh.bareFaces[t] = bareSidesOf(mesh, t, corners, tolerance);
                        }
                      });
  }
}

std::int32_t PhysicalScene::bareSidesOf(const PhysicalMesh& mesh, size_t t,
                                        const std::vector<Eigen::Vector3d>& corners,
                                        double tolerance) {
  const Eigen::Vector3d p0 = mesh.positions[mesh.triangles[t][0]].cast<double>();
  const Eigen::Vector3d n = (mesh.positions[mesh.triangles[t][1]].cast<double>() - p0)
                                .cross(mesh.positions[mesh.triangles[t][2]].cast<double>() - p0)
                                .normalized();
  if (!n.allFinite()) return 0;
  bool front = true, back = true;
  for (const Eigen::Vector3d& corner : corners) {
    const double height = n.dot(corner - p0);
    front = front && height <= tolerance;
    back = back && height >= -tolerance;
    if (!front && !back) break;
  }
  return (front ? PhysicalMesh::kFrontBare : 0) | (back ? PhysicalMesh::kBackBare : 0);
}

RTCScene PhysicalScene::newScene() const {
  RTCScene s = rtcNewScene(embreeDevice());
  rtcSetSceneFlags(s, animated_ ? RTC_SCENE_FLAG_DYNAMIC : RTC_SCENE_FLAG_NONE);
  rtcSetSceneBuildQuality(s, animated_ ? RTC_BUILD_QUALITY_MEDIUM : RTC_BUILD_QUALITY_HIGH);
  return s;
}

void PhysicalScene::buildStaticScene() {
  PARALLAX_CHECK(split());
  if (staticScene_) return;
  staticScene_ = newScene();
  for (size_t g = 0; g < geometries_.size(); ++g) {
    if (!dynamicInstances_[static_cast<size_t>(meshInstances_[g])])
      rtcAttachGeometryByID(staticScene_, geometries_[g], static_cast<unsigned>(g));
  }
  rtcCommitScene(staticScene_);
  throwIfEmbreeFailed("the static scene build");
}

void PhysicalScene::addInstance(const Scene& scene, const Instance& instance, const Box3& clipBox) {
  const Mesh& source = scene.meshes[static_cast<size_t>(instance.mesh)];
  const double tolerance = 1e-6 * clipBox.size().norm();
  const auto degenerateBefore = counters_.trianglesDegenerate;
  const auto outsideBefore = counters_.trianglesOutside;
  const auto clippedBefore = counters_.trianglesClipped;
  PhysicalMesh mesh;
  mesh.material = source.material;
  const bool hasNormals = !source.normals.empty();
  const bool hasUvs = !source.uvs.empty();
  const bool hasColors = !source.colors.empty();

  // Positions go through double all the way to physical space: a scene 1e4 units from its
  // origin keeps its sub-unit detail.
  std::vector<Eigen::Vector3d> physical(source.positions.size());
  for (size_t i = 0; i < source.positions.size(); ++i) {
    physical[i] = physicalFromWorld_.point(instance.worldFromObject * source.positions[i]);
  }
  // Normals transform with the inverse transpose of the instance's linear part.
  const Eigen::Matrix3d normalFromObject = instance.worldFromObject.linear().inverse().transpose();
  const bool mirrored = instance.worldFromObject.linear().determinant() < 0.0;

  auto normalOf = [&](std::uint32_t i) -> Eigen::Vector3f {
    const Eigen::Vector3d n = normalFromObject * source.normals[i].cast<double>();
    const double length = n.norm();
    return length > 0.0 ? Eigen::Vector3f((n / length).cast<float>()) : Eigen::Vector3f::Zero();
  };
  // Vertices are copied on first use, so unused vertices and dropped triangles cost nothing.
  std::vector<std::uint32_t> remap(source.positions.size(),
                                   std::numeric_limits<std::uint32_t>::max());
  auto useVertex = [&](std::uint32_t i) {
    if (remap[i] == std::numeric_limits<std::uint32_t>::max()) {
      remap[i] = static_cast<std::uint32_t>(mesh.positions.size());
      mesh.positions.push_back(physical[i].cast<float>());
      if (hasNormals) mesh.normals.push_back(normalOf(i));
      if (hasUvs) mesh.uvs.push_back(source.uvs[i]);
      if (hasColors) mesh.colors.push_back(source.colors[i]);
    }
    return remap[i];
  };
  auto addTriangle = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
    // A mirroring transform turns counter-clockwise into clockwise; swap to keep normals out.
    if (mirrored) std::swap(b, c);
    mesh.triangles.push_back({a, b, c});
  };

  for (const auto& tri : source.triangles) {
    ++counters_.trianglesIn;
    const Eigen::Vector3d& a = physical[tri[0]];
    const Eigen::Vector3d& b = physical[tri[1]];
    const Eigen::Vector3d& c = physical[tri[2]];
    if (degenerate(a.cast<float>(), b.cast<float>(), c.cast<float>())) {
      ++counters_.trianglesDegenerate;
      continue;
    }
    if (insideBox(a, clipBox, tolerance) && insideBox(b, clipBox, tolerance) &&
        insideBox(c, clipBox, tolerance)) {
      addTriangle(useVertex(tri[0]), useVertex(tri[1]), useVertex(tri[2]));
      ++counters_.trianglesBuilt;
      continue;
    }
    const std::vector<ClipVertex> polygon =
        clipToBox({{a, {1, 0, 0}}, {b, {0, 1, 0}}, {c, {0, 0, 1}}}, clipBox, tolerance);
    if (polygon.empty()) {
      ++counters_.trianglesOutside;
      continue;
    }
    ++counters_.trianglesClipped;
    // New vertices interpolate the source triangle's attributes at their barycentrics.
    std::vector<std::uint32_t> ids;
    for (const ClipVertex& v : polygon) {
      ids.push_back(static_cast<std::uint32_t>(mesh.positions.size()));
      mesh.positions.push_back(v.p.cast<float>());
      const Eigen::Vector3f w = v.bary.cast<float>();
      if (hasNormals) {
        const Eigen::Vector3f n =
            w[0] * normalOf(tri[0]) + w[1] * normalOf(tri[1]) + w[2] * normalOf(tri[2]);
        mesh.normals.push_back(n.norm() > 0.0f ? Eigen::Vector3f(n.normalized()) : n);
      }
      if (hasUvs)
        mesh.uvs.push_back(w[0] * source.uvs[tri[0]] + w[1] * source.uvs[tri[1]] +
                           w[2] * source.uvs[tri[2]]);
      if (hasColors) {
        mesh.colors.push_back(w[0] * source.colors[tri[0]] + w[1] * source.colors[tri[1]] +
                              w[2] * source.colors[tri[2]]);
      }
    }
    for (size_t k = 1; k + 1 < ids.size(); ++k) {
      const auto& p0 = mesh.positions[ids[0]];
      if (degenerate(p0, mesh.positions[ids[k]], mesh.positions[ids[k + 1]])) continue;
      addTriangle(ids[0], ids[k], ids[k + 1]);
      ++counters_.trianglesBuilt;
    }
  }
  if (mesh.triangles.empty()) return;
  const bool whole = counters_.trianglesDegenerate == degenerateBefore &&
                     counters_.trianglesOutside == outsideBefore &&
                     counters_.trianglesClipped == clippedBefore;
  if ((!source.interior.empty() || source.ring.halfHeight > 0.0) && whole) {
    // Every triangle whole (none clipped, none dropped): the shape's interior spheres, where the
    // instance's transform keeps a sphere a sphere (a rotation, a mirror, one scale).
    const Eigen::Matrix3d linear = instance.worldFromObject.linear();
    const Eigen::Matrix3d gram = linear.transpose() * linear;
    const double scale2 = gram.trace() / 3.0;
    if (scale2 > 0.0 &&
        (gram - scale2 * Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() <= 1e-9 * scale2) {
      const double scale = std::sqrt(scale2) * physicalFromWorld_.scale;
      if (source.ring.halfHeight > 0.0) {
        // Wider by far more than the float rounding of the corners and of the kernel's test.
        const double pad = 1e-3 * (source.ring.outer * scale);
        const Eigen::Vector3d axis = (linear * source.ring.axis).normalized();
        mesh.ring.centre =
            physicalFromWorld_.point(instance.worldFromObject * source.ring.centre).cast<float>();
        mesh.ring.axis = axis.cast<float>();
        mesh.ring.inner = static_cast<float>(std::max(0.0, source.ring.inner * scale - pad));
        mesh.ring.outer = static_cast<float>(source.ring.outer * scale + pad);
        mesh.ring.halfHeight = static_cast<float>(source.ring.halfHeight * scale + pad);
      }
      for (const Eigen::Vector4d& sphere : source.interior) {
        const Eigen::Vector3d centre =
            physicalFromWorld_.point(instance.worldFromObject * Eigen::Vector3d(sphere.head<3>()));
        // The corners' rounding to float moves the faces by ulps: far less than this.
        const double radius = sphere.w() * scale * (1.0 - 1e-4);
        mesh.interior.emplace_back(static_cast<float>(centre.x()), static_cast<float>(centre.y()),
                                   static_cast<float>(centre.z()), static_cast<float>(radius));
      }
    }
  }
  mesh.faceNormals.reserve(mesh.triangles.size());
  mesh.crossLengths.reserve(mesh.triangles.size());
  for (const auto& tri : mesh.triangles) {
    const Eigen::Vector3f& p0 = mesh.positions[tri[0]];
    const Eigen::Vector3f cross = (mesh.positions[tri[1]] - p0).cross(mesh.positions[tri[2]] - p0);
    mesh.faceNormals.push_back(cross.normalized());
    mesh.crossLengths.push_back(cross.norm());
  }
  if (!mesh.normals.empty() && normalsAreFlat(mesh)) {
    // Interpolating them would give the face normal back at every hit, after a square root and
    // a division: a fifth of the per-hit time on the Cornell box's walls.
    mesh.normals.clear();
    ++counters_.flatNormalMeshes;
  }
  meshes_.push_back(std::move(mesh));
}

namespace {

bool sameTexture(const Texture& a, const Texture& b) {
  return a.path == b.path && a.width == b.width && a.height == b.height && a.pixels == b.pixels &&
         a.fallback == b.fallback && a.srgb == b.srgb;
}

}  // namespace

void PhysicalScene::loadTextures(const Scene& scene, PhysicalScene* previous) {
  textures_.resize(scene.textures.size());
  textureSources_.resize(scene.textures.size());
  long filePixels = 0;  // of the texture files loaded so far, against kMaxScenePixels
  for (size_t i = 0; i < scene.textures.size(); ++i) {
    const Texture& t = scene.textures[i];
    TextureSource& source = textureSources_[i];
    source.texture = t;
    if (!features_.textureNeeded[i]) {
      ++counters_.texturesSkipped;
      continue;
    }
    source.used = true;
    if (!t.path.empty()) {
      std::error_code ec;
      source.modified = std::filesystem::last_write_time(t.path, ec);
      source.size = ec ? 0 : std::filesystem::file_size(t.path, ec);
    }
    if (previous && i < previous->textureSources_.size()) {
      // The same texture, from a file that has not changed since: take it over.
      const TextureSource& before = previous->textureSources_[i];
      if (before.used && sameTexture(before.texture, t) && before.modified == source.modified &&
          before.size == source.size && i < previous->textures_.size()) {
        textures_[i] = std::move(previous->textures_[i]);
        if (!t.path.empty() && before.failure.empty())
          filePixels += static_cast<long>(textures_[i].width()) * textures_[i].height();
        previous->textureSources_[i].used = false;  // moved out: not there to take twice
        source.failure = before.failure;
        ++counters_.texturesReused;
        if (source.failure.empty()) {
          ++counters_.texturesLoaded;
        } else {
          ++counters_.texturesFailed;  // warned when it was first read, not every frame
          warnings_.push_back(source.failure);
        }
        continue;
      }
    }
    if (t.path.empty()) {
      textures_[i] = TextureImage(t.width, t.height, t.pixels);
      ++counters_.texturesLoaded;
      continue;
    }
    std::string error;
    const long budget =
        std::min(TextureImage::kMaxFilePixels, TextureImage::kMaxScenePixels - filePixels);
    if (TextureImage::load(t.path, t.srgb, budget, &textures_[i], &error)) {
      filePixels += static_cast<long>(textures_[i].width()) * textures_[i].height();
      ++counters_.texturesLoaded;
    } else {
      ++counters_.texturesFailed;
      const std::string message =
          fmt::format("texture {}: {}; using the fallback colour ({}, {}, {})", t.path, error,
                      t.fallback.x(), t.fallback.y(), t.fallback.z());
      spdlog::warn("{}", message);
      warnings_.push_back(message);
      source.failure = message;
      textures_[i] = TextureImage::constant(t.fallback);
    }
  }
}

}  // namespace parallax
