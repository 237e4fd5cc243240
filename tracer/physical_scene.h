#pragma once
// A Scene mapped into the display's physical space and built into an Embree BVH: the form the
// integrator traces. World → physical is physicalFromWorld(B_W, B_P) (uniform scale, centred);
// instances are flattened into one triangle geometry each (positions transformed in double,
// stored as float); triangles outside B_P are dropped and those crossing its faces clipped;
// degenerate triangles are dropped; textures are loaded only when a drawn surface samples them.

#include <embree3/rtcore.h>

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "calibration/display/box3.h"
#include "calibration/display/world_to_physical.h"
#include "tracer/scene.h"
#include "tracer/scene_features.h"
#include "tracer/texture_image.h"

namespace parallax {

struct SceneBuildCounters {
  long trianglesIn = 0;          // drawn triangles over all instances
  long trianglesDegenerate = 0;  // zero area after mapping: dropped
  long trianglesOutside = 0;     // wholly outside B_P: dropped
  long trianglesClipped = 0;     // crossing B_P's faces: replaced by their inside part
  long trianglesBuilt = 0;       // in the BVH
  int flatNormalMeshes =
      0;  // vertex normals equal to the face normals: dropped, never interpolated
  int texturesLoaded = 0;
  int texturesFailed = 0;   // unreadable: warned, replaced by their fallback colour
  int texturesSkipped = 0;  // nothing samples them: never read
  int texturesReused = 0;   // taken over from the previous frame's scene (of those loaded)
  double buildMs = 0.0;
};

// One Embree geometry: a flattened instance in physical space.
struct PhysicalMesh {
  std::vector<Eigen::Vector3f> positions;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::vector<Eigen::Vector3f> normals;  // empty or per position
  std::vector<Eigen::Vector2f> uvs;      // empty or per position
  std::vector<Rgb> colors;               // empty or per position
  // Per triangle: (p1 − p0) × (p2 − p0) normalised (CCW side), and that cross product's length
  // (twice the area). Computed once here rather than at every hit.
  std::vector<Eigen::Vector3f> faceNormals;
  std::vector<float> crossLengths;
  // Per triangle, the faces (kFrontBare: the CCW side, kBackBare: the other) the whole mesh lies
  // behind, as far as float rounding tells: a shadow ray that leaves such a face cannot meet
  // this mesh again. A flat mesh's triangles are bare on both sides, a convex mesh's on the
  // outside, a torus's on the outside of its outer half. For the meshes of a scene with
  // occluders() that a shadow ray can leave (diffuse ones), and for those with a withoutMesh()
  // scene; empty otherwise (none bare).
  static constexpr std::int32_t kFrontBare = 1, kBackBare = 2;
  std::vector<std::int32_t> bareFaces;
  // Whether triangle `prim` is bare on its CCW side (`frontSide`) or the other; false when the
  // faces were not worked out.
  bool bareOn(unsigned prim, bool frontSide) const {
    return !bareFaces.empty() && (bareFaces[prim] & (frontSide ? kFrontBare : kBackBare)) != 0;
  }
  // Mesh::interior in physical space, when the instance's transform keeps spheres spheres and
  // every triangle was built whole (none clipped or dropped); else empty.
  std::vector<Eigen::Vector4f> interior;
  // Mesh::ring in physical space, on the same terms (halfHeight 0: none), a little wider.
  struct Ring {
    Eigen::Vector3f centre = Eigen::Vector3f::Zero();
    Eigen::Vector3f axis = Eigen::Vector3f::UnitY();
    float inner = 0.0f, outer = 0.0f, halfHeight = 0.0f;
  };
  Ring ring;
  int material = 0;
};

// A mesh's bound for the shadow rays' test (shadow_ray_kernel.h): a ray that passes it cannot
// meet the mesh. A sphere that holds it (a little wider), and for a flat mesh its plane too: a
// ray that stays on one side of the plane passes it, as a shadow ray leaving a floor does.
struct OccluderBound {
  Eigen::Vector4f sphere = Eigen::Vector4f::Zero();  // centre x, y, z, radius (physical)
  // A flat mesh: the unit normal n and n · p of its plane; its corners lie within planeMargin of
  // it, the rounding of a ray's distance from it (and of Embree's test) included. A zero normal
  // for any other mesh.
  Eigen::Vector4f plane = Eigen::Vector4f::Zero();
  float planeMargin = 0.0f;
  // A closed mesh that stops light (not glass): spheres inside it (centre x, y, z, radius), one
  // for a convex mesh, the shape's own for a torus (Mesh::interior). A ray that passes through
  // one crosses the mesh: blocked, with no trip through Embree.
  static constexpr int kMaxCores = 24;
  std::array<Eigen::Vector4f, kMaxCores> cores{};
  int coreCount = 0;
  // Cores kCoresPerGroup at a time in a sphere that holds them: a ray that passes one is not
  // tested against its cores.
  static constexpr int kCoresPerGroup = 6;
  std::array<Eigen::Vector4f, kMaxCores / kCoresPerGroup> coreGroups{};
  // The mesh's ring (PhysicalMesh::ring), when its shape knows one: halfHeight 0 without.
  PhysicalMesh::Ring ring;
  bool flat() const { return planeMargin > 0.0f; }
  bool hasCore() const { return coreCount > 0; }
};

struct PhysicalLight {
  LightKind kind = LightKind::kDirectional;
  Eigen::Vector3f toLight = Eigen::Vector3f::UnitY();  // directional: unit, toward the light
  Eigen::Vector3f position = Eigen::Vector3f::Zero();  // point
  Rgb intensity = Rgb::Ones();
};

class PhysicalScene {
 public:
  // Validates the scene (InputError), maps it into `displayableBox` and builds the BVH.
  // `dynamicInstances` (one flag per Scene instance, for the frame cache): also builds a BVH of
  // the flagged instances alone (dynamicHandle), and buildStaticScene() one of the others.
  // `previous` (an animated scene's previous frame): its textures are taken over (moved out of
  // it) where this scene names the same texture and its file has not changed since, instead of
  // being read and filtered again every frame.
  PhysicalScene(const Scene& scene, const Box3& displayableBox,
                const std::vector<bool>* dynamicInstances = nullptr,
                PhysicalScene* previous = nullptr);
  ~PhysicalScene();
  PhysicalScene(const PhysicalScene&) = delete;
  PhysicalScene& operator=(const PhysicalScene&) = delete;

  RTCScene handle() const { return scene_; }
  // The frame cache's partial BVHs: the same geometries under the same IDs (mesh indices), so
  // a hit in either names the same mesh as in handle(). Null unless the scene was split.
  RTCScene dynamicHandle() const { return dynamicScene_; }
  RTCScene staticHandle() const { return staticScene_; }
  // Builds staticHandle() (once; not thread-safe: before any tracing of this scene).
  void buildStaticScene();
  bool split() const { return !dynamicInstances_.empty(); }
  // The dynamic instances' bounds as spheres (centre x, y, z, radius; physical), a little wider
  // than the meshes, which no ray can meet without crossing: a ray that passes them all needs no
  // trip through dynamicHandle(). One per dynamic mesh, or one around them all when there are
  // more than kMaxDynamicSpheres. Empty unless split.
  static constexpr size_t kMaxDynamicSpheres = 8;
  const std::vector<Eigen::Vector4f>& dynamicSpheres() const { return dynamicSpheres_; }
  // For a mirror's or glass's mesh with a bare face (PhysicalMesh::bareFaces): a BVH of every
  // other mesh, under the same IDs, for the reflection and refraction rays that leave a bare face
  // of it. They cannot meet that mesh again, and Embree's walk down the mesh they start on was
  // about half of what such a ray cost. Null for other meshes, and for all when building them
  // would pass kMaxWithoutMeshTriangles (they are built with the scene, every frame of an
  // animated one).
  static constexpr size_t kMaxWithoutMeshScenes = 4;
  static constexpr long kMaxWithoutMeshTriangles = 1 << 17;
  RTCScene withoutMesh(unsigned mesh) const { return withoutMesh_[mesh]; }
  bool hasWithoutMeshScenes() const { return withoutMeshScenes_ > 0; }
  // Every mesh's bound (OccluderBound), in mesh order, when the scene has at most
  // kMaxOccluders meshes; empty otherwise (the shadow rays then all go to Embree).
  static constexpr size_t kMaxOccluders = 8;
  const std::vector<OccluderBound>& occluders() const { return occluders_; }
  // Per Scene instance: whether the split counted it dynamic.
  bool dynamicInstance(int instance) const {
    return split() && dynamicInstances_[static_cast<size_t>(instance)];
  }
  // Per Scene instance: the index of its mesh in meshes(), -1 when nothing of it was built
  // (wholly outside the displayable box, or degenerate).
  const std::vector<int>& instanceMeshes() const { return instanceMeshes_; }
  const WorldToPhysical& physicalFromWorld() const { return physicalFromWorld_; }
  const SceneFeatures& features() const { return features_; }
  const SceneBuildCounters& counters() const { return counters_; }
  const std::vector<PhysicalMesh>& meshes() const { return meshes_; }
  const std::vector<Material>& materials() const { return materials_; }
  const std::vector<PhysicalLight>& lights() const { return lights_; }
  // Per Scene::textures; empty TextureImage for textures that were left out.
  const std::vector<TextureImage>& textures() const { return textures_; }
  const Rgb& background() const { return background_; }
  const Rgb& ambient() const { return ambient_; }
  // Bounds of the built triangles (physical); rays that miss it are never traversed.
  const Eigen::Vector3f& boundsMin() const { return boundsMin_; }
  const Eigen::Vector3f& boundsMax() const { return boundsMax_; }
  // World units per physical metre (absorption and point-light falloff are in world units).
  float worldPerPhysical() const { return static_cast<float>(1.0 / physicalFromWorld_.scale); }
  bool animated() const { return animated_; }
  // Shadow rays pass through glass with its transmittance (glass_shadows.h): the scene has lit
  // surfaces, lights and drawn glass, and Embree supports filter functions.
  bool glassShadows() const { return glassShadows_; }
  std::vector<std::string> warnings() const { return warnings_; }

 private:
  void addInstance(const Scene& scene, const Instance& instance, const Box3& clipBox);
  void loadTextures(const Scene& scene, PhysicalScene* previous);
  // What a texture was made from, to know the same one again in the next frame's scene.
  struct TextureSource {
    Texture texture;
    bool used = false;    // read (or its fallback taken); false: left out
    std::string failure;  // the warning when the file could not be read (the fallback is used)
    std::filesystem::file_time_type modified{};
    std::uintmax_t size = 0;
  };
  std::vector<TextureSource> textureSources_;

  RTCScene scene_ = nullptr;
  RTCScene dynamicScene_ = nullptr;
  RTCScene staticScene_ = nullptr;
  std::vector<RTCGeometry> geometries_;  // retained while a partial scene may still attach them
  std::vector<RTCScene> withoutMesh_;    // per mesh
  int withoutMeshScenes_ = 0;
  // The meshes that get a withoutMesh() scene, if their faces turn out bare.
  std::vector<bool> withoutMeshCandidates() const;
  void buildWithoutMeshScenes(const std::vector<bool>& candidates);
  void dropWithoutMeshScenesOfMeshesWithoutBareFaces();
  // An empty scene with this scene's flags and build quality.
  RTCScene newScene() const;
  std::vector<bool> dynamicInstances_;
  std::vector<Eigen::Vector4f> dynamicSpheres_;
  void boundDynamicMeshes();
  void boundOccluders();
  // `specular`: withoutMeshCandidates().
  void markBareFaces(const std::vector<bool>& specular);
  // PhysicalMesh::bareFaces of triangle t: against every corner, within `tolerance`.
  static std::int32_t bareSidesOf(const PhysicalMesh& mesh, size_t t,
                                  const std::vector<Eigen::Vector3d>& corners, double tolerance);
  std::vector<OccluderBound> occluders_;
  std::vector<int> instanceMeshes_;
  std::vector<int> meshInstances_;  // per mesh: its Scene instance
  WorldToPhysical physicalFromWorld_;
  SceneFeatures features_;
  SceneBuildCounters counters_;
  std::vector<PhysicalMesh> meshes_;
  std::vector<Material> materials_;
  std::vector<PhysicalLight> lights_;
  std::vector<TextureImage> textures_;
  Rgb background_ = Rgb::Zero();
  Rgb ambient_ = Rgb::Zero();
  Eigen::Vector3f boundsMin_ = Eigen::Vector3f::Zero();
  Eigen::Vector3f boundsMax_ = Eigen::Vector3f::Zero();
  bool animated_ = false;
  bool glassShadows_ = false;
  std::vector<std::string> warnings_;
};

}  // namespace parallax
