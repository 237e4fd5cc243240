#pragma once
// The Scene: plain data that a C++ fixture, the model loader or a Lua script fills, and that
// the tracer turns into an Embree BVH in physical space (DESIGN.md, "World → physical").
//
// World space is the scene's own: any unit, any origin. Positions are doubles so a scene far
// from the origin (or very large or very small) keeps its precision until it is mapped into the
// displayable box B_P; everything after that mapping is float.
//
// Conventions: right-handed, counter-clockwise triangles face their geometric normal
// (e1 × e2), though shading is two-sided. Colours are linear RGB; frames are written as sRGB.
// Lengths inside materials and lights (absorption, point-light falloff) are in world units, so
// a scene renders the same image whatever scale its B_W has.
//
// Meshes are drawn only through instances (addMesh adds an identity instance by default).
// Indices into meshes / materials / textures are plain ints that validate() checks.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "calibration/display/box3.h"

namespace parallax {

using Rgb = Eigen::Vector3f;  // linear RGB

enum class MaterialKind : std::uint8_t {
  kDiffuse,     // Lambert, optional Phong highlight, optional texture
  kMirror,      // perfect specular reflection scaled by `reflectance`
  kDielectric,  // glass: Fresnel-weighted reflection + refraction, TIR, optional absorption
  kEmissive,    // unlit: emits `emission` (× texture × vertex colour), never shadowed
};

const char* materialKindName(MaterialKind kind);

struct Material {
  std::string name;
  MaterialKind kind = MaterialKind::kDiffuse;

  // kDiffuse
  Rgb diffuse{0.8f, 0.8f, 0.8f};   // albedo; multiplied by the texture and vertex colours
  int diffuseTexture = -1;         // index into Scene::textures, -1 for none
  Rgb specular{0.0f, 0.0f, 0.0f};  // Phong highlight colour; zero: no highlight
  float shininess = 32.0f;         // Phong exponent
  // kMirror
  Rgb reflectance{0.9f, 0.9f, 0.9f};
  // kDielectric
  float ior = 1.5f;                  // relative to the surrounding air (1)
  Rgb absorption{0.0f, 0.0f, 0.0f};  // Beer–Lambert coefficient per world unit inside
  // kEmissive (also added on top of any other kind)
  Rgb emission{0.0f, 0.0f, 0.0f};

  static Material makeDiffuse(const Rgb& albedo, int texture = -1);
  static Material makePhong(const Rgb& albedo, const Rgb& specular, float shininess);
  static Material makeMirror(const Rgb& reflectance);
  static Material makeDielectric(float ior, const Rgb& absorption = Rgb::Zero());
  static Material makeEmissive(const Rgb& emission, int texture = -1);
};

// A diffuse texture: an image file read through OpenImageIO, or pixels given inline (a
// procedural texture from a script). Loaded only if a drawn material references it. When the
// file cannot be read, the tracer warns and uses `fallback` instead.
struct Texture {
  std::string path;           // empty when `pixels` is given
  int width = 0, height = 0;  // inline image size
  std::vector<float> pixels;  // inline linear RGB, width × height × 3, row 0 at the top
  Rgb fallback{0.6f, 0.6f, 0.6f};
  bool srgb = true;  // 8-bit files are sRGB-encoded; converted to linear on load
};
// UVs: (0, 0) is the image's bottom-left corner, (1, 1) its top-right (OBJ / OpenGL
// convention); they wrap (repeat) outside [0, 1]. Row 0 of `Texture::pixels` is the top row.

struct Mesh {
  std::string name;
  std::vector<Eigen::Vector3d> positions;               // world (object) space
  std::vector<std::array<std::uint32_t, 3>> triangles;  // indices into positions
  std::vector<Eigen::Vector3f> normals;  // empty, or one per position (smooth shading)
  std::vector<Eigen::Vector2f> uvs;      // empty, or one per position
  std::vector<Rgb> colors;               // empty, or one per position (multiplies the material)
  int material = 0;                      // index into Scene::materials
  // Spheres inside the closed solid the triangles bound (object space: centre, radius), known
  // to the shape that made it (mesh_shapes.h): a ray through one crosses the mesh. Empty: none.
  std::vector<Eigen::Vector4d> interior;
  // A ring that holds every triangle (object space), known to the shape that made it: the
  // points within `halfHeight` of the plane through `centre` across `axis` (unit) whose distance
  // from the axis is in [inner, outer]. A ray that crosses that slab only inside the inner
  // radius or only outside the outer one misses the mesh. halfHeight 0: none.
  struct Ring {
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    Eigen::Vector3d axis = Eigen::Vector3d::UnitY();
    double inner = 0.0, outer = 0.0, halfHeight = 0.0;
  };
  Ring ring;
};

struct Instance {
  int mesh = 0;
  Eigen::Affine3d worldFromObject = Eigen::Affine3d::Identity();
};

enum class LightKind : std::uint8_t { kDirectional, kPoint };

struct Light {
  LightKind kind = LightKind::kDirectional;
  Eigen::Vector3d direction{0.0, -1.0, 0.0};  // kDirectional: the way the light travels (world)
  Eigen::Vector3d position{0.0, 0.0, 0.0};    // kPoint: world position
  Rgb intensity{1.0f, 1.0f, 1.0f};  // directional: irradiance; point: irradiance at 1 world unit

  static Light makeDirectional(const Eigen::Vector3d& travelDirection, const Rgb& irradiance);
  static Light makePoint(const Eigen::Vector3d& position, const Rgb& intensity);
};

struct Scene {
  std::string name = "scene";
  std::vector<Mesh> meshes;
  std::vector<Instance> instances;
  std::vector<Material> materials;
  std::vector<Texture> textures;
  std::vector<Light> lights;
  Rgb background{0.0f, 0.0f, 0.0f};
  Rgb ambient{0.0f, 0.0f, 0.0f};  // constant term added to diffuse surfaces (× albedo)
  // B_W: the part of world space shown in the display's B_P. Unset: the bounds of the drawn
  // geometry. Geometry outside it is clipped (and counted).
  std::optional<Box3> worldBox;
  // An animated scene is rebuilt every frame (Embree's dynamic build flags); a static one is
  // built once with the high-quality SAH builder.
  bool animated = false;
  // Instances an update() has moved (a script's set_transform targets so far): the frame cache
  // (frame_cache.h) traces them every frame and keeps the primary hits on the rest. A hint
  // only: the cache notices any other instance that moves, so a wrong hint costs time, not
  // correctness.
  std::set<int> movedInstances;
  int maxDepth = 5;  // Whitted recursion limit (1: primary rays only)
  // World-space boxes that animated models (model_animation.h) fill over all their clips, so
  // geometryBounds(), and with it an unset B_W, covers the whole motion and does not follow it
  // frame by frame. Each model keeps its entry placed as it moves the model.
  std::vector<Box3> motionBounds;

  // Small builders for fixtures, loaders and bindings. Each returns the new index.
  int addMaterial(Material material);
  int addTexture(Texture texture);
  int addTextureFile(const std::string& path, const Rgb& fallback = Rgb(0.6f, 0.6f, 0.6f));
  // Adds the mesh and, when `instanced`, one instance with the given transform.
  int addMesh(Mesh mesh, bool instanced = true,
              const Eigen::Affine3d& worldFromObject = Eigen::Affine3d::Identity());
  int addInstance(int mesh, const Eigen::Affine3d& worldFromObject);
  void addLight(const Light& light) { lights.push_back(light); }

  long triangleCount() const;  // drawn triangles (over instances)
  // Bounds of the drawn geometry and of motionBounds in world space (empty box when there is
  // no geometry).
  Box3 geometryBounds() const;
  // B_W as used: worldBox, or geometryBounds().
  Box3 effectiveWorldBox() const;

  // Throws InputError naming the first offending field (e.g. "meshes[2].positions[17]"):
  // non-finite numbers, indices out of range, per-vertex arrays of the wrong length, negative
  // or non-finite material parameters, zero light directions, nothing to draw, maxDepth < 1.
  // Degenerate triangles are not errors: the BVH builder drops and counts them.
  void validate() const;
};

}  // namespace parallax
