#include "tracer/scene.h"

#include <fmt/format.h>

#include <cmath>
#include <limits>

#include "common/input_error.h"

namespace parallax {
namespace {

[[noreturn]] void fail(const std::string& field, const std::string& reason) {
  throw InputError({"", field, 0}, reason);
}

bool finite(const Eigen::Vector3d& v) { return v.allFinite(); }
bool finiteNonNegative(const Rgb& c) { return c.allFinite() && (c.array() >= 0.0f).all(); }

void validateMaterial(const Material& m, const std::string& field, size_t textureCount) {
  if (!finiteNonNegative(m.diffuse)) fail(field + ".diffuse", "must be finite and >= 0");
  if (!finiteNonNegative(m.specular)) fail(field + ".specular", "must be finite and >= 0");
  if (!finiteNonNegative(m.reflectance)) fail(field + ".reflectance", "must be finite and >= 0");
  if (!finiteNonNegative(m.absorption)) fail(field + ".absorption", "must be finite and >= 0");
  if (!finiteNonNegative(m.emission)) fail(field + ".emission", "must be finite and >= 0");
  if (!std::isfinite(m.shininess) || m.shininess < 0.0f) {
    fail(field + ".shininess", fmt::format("must be finite and >= 0, got {}", m.shininess));
  }
  // An IOR below 1 relative to air is physically odd but harmless; 0, negatives and NaN are not.
  if (!std::isfinite(m.ior) || !(m.ior > 0.0f)) {
    fail(field + ".ior", fmt::format("must be finite and > 0, got {}", m.ior));
  }
  if (m.diffuseTexture < -1 || m.diffuseTexture >= static_cast<int>(textureCount)) {
    fail(field + ".diffuse_texture", fmt::format("index {} out of range (scene has {} textures)",
                                                 m.diffuseTexture, textureCount));
  }
}

void validateMesh(const Mesh& mesh, const std::string& field, size_t materialCount) {
  const size_t n = mesh.positions.size();
  if (n > std::numeric_limits<std::uint32_t>::max())
    fail(field + ".positions", "too many vertices");
  for (size_t i = 0; i < n; ++i) {
    if (!finite(mesh.positions[i])) {
      fail(fmt::format("{}.positions[{}]", field, i), "vertex is not finite (NaN or Inf)");
    }
  }
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    for (int k = 0; k < 3; ++k) {
      if (mesh.triangles[t][static_cast<size_t>(k)] >= n) {
        fail(fmt::format("{}.triangles[{}]", field, t),
             fmt::format("index {} out of range (mesh has {} vertices)",
                         mesh.triangles[t][static_cast<size_t>(k)], n));
      }
    }
  }
  if (!mesh.normals.empty()) {
    if (mesh.normals.size() != n) {
      fail(field + ".normals",
           fmt::format("has {} entries for {} vertices", mesh.normals.size(), n));
    }
    for (size_t i = 0; i < n; ++i) {
      if (!mesh.normals[i].allFinite()) fail(fmt::format("{}.normals[{}]", field, i), "not finite");
    }
  }
  if (!mesh.uvs.empty()) {
    if (mesh.uvs.size() != n) {
      fail(field + ".uvs", fmt::format("has {} entries for {} vertices", mesh.uvs.size(), n));
    }
    for (size_t i = 0; i < n; ++i) {
      if (!mesh.uvs[i].allFinite()) fail(fmt::format("{}.uvs[{}]", field, i), "not finite");
    }
  }
  if (!mesh.colors.empty()) {
    if (mesh.colors.size() != n) {
      fail(field + ".colors", fmt::format("has {} entries for {} vertices", mesh.colors.size(), n));
    }
    for (size_t i = 0; i < n; ++i) {
      if (!finiteNonNegative(mesh.colors[i])) {
        fail(fmt::format("{}.colors[{}]", field, i), "must be finite and >= 0");
      }
    }
  }
  if (mesh.material < 0 || mesh.material >= static_cast<int>(materialCount)) {
    fail(field + ".material", fmt::format("index {} out of range (scene has {} materials)",
                                          mesh.material, materialCount));
  }
}

}  // namespace

const char* materialKindName(MaterialKind kind) {
  switch (kind) {
    case MaterialKind::kDiffuse:
      return "diffuse";
    case MaterialKind::kMirror:
      return "mirror";
    case MaterialKind::kDielectric:
      return "dielectric";
    case MaterialKind::kEmissive:
      return "emissive";
  }
  return "?";
}

Material Material::makeDiffuse(const Rgb& albedo, int texture) {
  Material m;
  m.kind = MaterialKind::kDiffuse;
  m.diffuse = albedo;
  m.diffuseTexture = texture;
  return m;
}

Material Material::makePhong(const Rgb& albedo, const Rgb& specularColor, float exponent) {
  Material m = makeDiffuse(albedo);
  m.specular = specularColor;
  m.shininess = exponent;
  return m;
}

Material Material::makeMirror(const Rgb& reflectanceColor) {
  Material m;
  m.kind = MaterialKind::kMirror;
  m.reflectance = reflectanceColor;
  return m;
}

Material Material::makeDielectric(float indexOfRefraction, const Rgb& absorptionPerUnit) {
  Material m;
  m.kind = MaterialKind::kDielectric;
  m.ior = indexOfRefraction;
  m.absorption = absorptionPerUnit;
  return m;
}

Material Material::makeEmissive(const Rgb& emitted, int texture) {
  Material m;
  m.kind = MaterialKind::kEmissive;
  m.emission = emitted;
  m.diffuseTexture = texture;
  return m;
}

Light Light::makeDirectional(const Eigen::Vector3d& travelDirection, const Rgb& irradiance) {
  Light l;
  l.kind = LightKind::kDirectional;
  l.direction = travelDirection;
  l.intensity = irradiance;
  return l;
}

Light Light::makePoint(const Eigen::Vector3d& at, const Rgb& intensityAtUnit) {
  Light l;
  l.kind = LightKind::kPoint;
  l.position = at;
  l.intensity = intensityAtUnit;
  return l;
}

int Scene::addMaterial(Material material) {
  materials.push_back(std::move(material));
  return static_cast<int>(materials.size()) - 1;
}

int Scene::addTexture(Texture texture) {
  textures.push_back(std::move(texture));
  return static_cast<int>(textures.size()) - 1;
}

int Scene::addTextureFile(const std::string& path, const Rgb& fallback) {
  Texture t;
  t.path = path;
  t.fallback = fallback;
  return addTexture(std::move(t));
}

int Scene::addMesh(Mesh mesh, bool instanced, const Eigen::Affine3d& worldFromObject) {
  meshes.push_back(std::move(mesh));
  const int index = static_cast<int>(meshes.size()) - 1;
  if (instanced) addInstance(index, worldFromObject);
  return index;
}

int Scene::addInstance(int mesh, const Eigen::Affine3d& worldFromObject) {
  instances.push_back({mesh, worldFromObject});
  return static_cast<int>(instances.size()) - 1;
}

long Scene::triangleCount() const {
  long count = 0;
  for (const Instance& instance : instances) {
    if (instance.mesh >= 0 && instance.mesh < static_cast<int>(meshes.size())) {
      count += static_cast<long>(meshes[static_cast<size_t>(instance.mesh)].triangles.size());
    }
  }
  return count;
}

Box3 Scene::geometryBounds() const {
  Box3 box;
  box.min = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  box.max = -box.min;
  bool any = false;
  for (const Instance& instance : instances) {
    if (instance.mesh < 0 || instance.mesh >= static_cast<int>(meshes.size())) continue;
    const Mesh& mesh = meshes[static_cast<size_t>(instance.mesh)];
    for (const auto& tri : mesh.triangles) {
      for (std::uint32_t index : tri) {
        if (index >= mesh.positions.size()) continue;
        const Eigen::Vector3d p = instance.worldFromObject * mesh.positions[index];
        box.min = box.min.cwiseMin(p);
        box.max = box.max.cwiseMax(p);
        any = true;
      }
    }
  }
  if (!any) return Box3{};
  for (const Box3& motion : motionBounds) {
    box.min = box.min.cwiseMin(motion.min);
    box.max = box.max.cwiseMax(motion.max);
  }
  return box;
}

Box3 Scene::effectiveWorldBox() const { return worldBox ? *worldBox : geometryBounds(); }

void Scene::validate() const {
  for (size_t i = 0; i < materials.size(); ++i) {
    validateMaterial(materials[i], fmt::format("materials[{}]", i), textures.size());
  }
  for (size_t i = 0; i < textures.size(); ++i) {
    const Texture& t = textures[i];
    const std::string field = fmt::format("textures[{}]", i);
    if (!finiteNonNegative(t.fallback)) fail(field + ".fallback", "must be finite and >= 0");
    if (t.path.empty()) {
      if (t.width <= 0 || t.height <= 0 || t.width > 65536 || t.height > 65536) {
        fail(field,
             fmt::format("inline texture needs a size in 1..65536, got {}x{}", t.width, t.height));
      }
      if (t.pixels.size() != static_cast<size_t>(t.width) * static_cast<size_t>(t.height) * 3) {
        fail(field + ".pixels",
             fmt::format("has {} floats, {}x{} RGB needs {}", t.pixels.size(), t.width, t.height,
                         static_cast<size_t>(t.width) * t.height * 3));
      }
      for (float v : t.pixels) {
        if (!std::isfinite(v)) fail(field + ".pixels", "contains a non-finite value");
      }
    }
  }
  for (size_t i = 0; i < meshes.size(); ++i) {
    validateMesh(meshes[i], fmt::format("meshes[{}]", i), materials.size());
  }
  for (size_t i = 0; i < instances.size(); ++i) {
    const Instance& instance = instances[i];
    const std::string field = fmt::format("instances[{}]", i);
    if (instance.mesh < 0 || instance.mesh >= static_cast<int>(meshes.size())) {
      fail(field + ".mesh", fmt::format("index {} out of range (scene has {} meshes)",
                                        instance.mesh, meshes.size()));
    }
    if (!instance.worldFromObject.matrix().allFinite()) fail(field + ".transform", "not finite");
    if (!(std::abs(instance.worldFromObject.linear().determinant()) > 0.0)) {
      fail(field + ".transform", "is singular (zero scale)");
    }
  }
  for (size_t i = 0; i < lights.size(); ++i) {
    const Light& l = lights[i];
    const std::string field = fmt::format("lights[{}]", i);
    if (!finiteNonNegative(l.intensity)) fail(field + ".intensity", "must be finite and >= 0");
    if (l.kind == LightKind::kDirectional) {
      if (!finite(l.direction) || !(l.direction.norm() > 0.0)) {
        fail(field + ".direction", "must be finite and non-zero");
      }
    } else if (!finite(l.position)) {
      fail(field + ".position", "must be finite");
    }
  }
  if (!finiteNonNegative(background)) fail("background", "must be finite and >= 0");
  if (!finiteNonNegative(ambient)) fail("ambient", "must be finite and >= 0");
  if (maxDepth < 1 || maxDepth > 64)
    fail("max_depth", fmt::format("must be in 1..64, got {}", maxDepth));
  if (triangleCount() == 0)
    fail("meshes", "the scene has nothing to draw (no instanced triangles)");
  for (size_t i = 0; i < motionBounds.size(); ++i) {
    if (!motionBounds[i].min.allFinite() || !motionBounds[i].max.allFinite())
      fail(fmt::format("motion_bounds[{}]", i), "must be finite");
  }
  if (worldBox) {
    if (!worldBox->min.allFinite() || !worldBox->max.allFinite())
      fail("world_box", "must be finite");
    if ((worldBox->max.array() < worldBox->min.array()).any()) fail("world_box", "max below min");
    if (!(worldBox->size().maxCoeff() > 0.0)) fail("world_box", "has no extent");
  }
}

}  // namespace parallax
