#include "tracer/scene_features.h"

#include <fmt/format.h>

#include <algorithm>

namespace parallax {

bool SceneFeatures::texturePass() const {
  return std::find(textureNeeded.begin(), textureNeeded.end(), true) != textureNeeded.end();
}

int SceneFeatures::texturesNeeded() const {
  return static_cast<int>(std::count(textureNeeded.begin(), textureNeeded.end(), true));
}

SceneFeatures analyseScene(const Scene& scene) {
  SceneFeatures f;
  f.materialDrawn.assign(scene.materials.size(), false);
  f.textureNeeded.assign(scene.textures.size(), false);
  std::vector<bool> meshDrawn(scene.meshes.size(), false);
  for (const Instance& instance : scene.instances) {
    if (instance.mesh >= 0 && instance.mesh < static_cast<int>(scene.meshes.size())) {
      meshDrawn[static_cast<size_t>(instance.mesh)] = true;
    }
  }
  for (size_t i = 0; i < scene.meshes.size(); ++i) {
    const Mesh& mesh = scene.meshes[i];
    if (!meshDrawn[i] || mesh.triangles.empty()) {
      f.meshesUnused += meshDrawn[i] ? 0 : 1;
      continue;
    }
    if (mesh.material < 0 || mesh.material >= static_cast<int>(scene.materials.size())) continue;
    f.materialDrawn[static_cast<size_t>(mesh.material)] = true;
    f.vertexColors = f.vertexColors || !mesh.colors.empty();
    const Material& m = scene.materials[static_cast<size_t>(mesh.material)];
    const bool textured = m.diffuseTexture >= 0 &&
                          m.diffuseTexture < static_cast<int>(scene.textures.size()) &&
                          (m.kind == MaterialKind::kDiffuse || m.kind == MaterialKind::kEmissive);
    if (textured) {
      if (!mesh.uvs.empty()) {
        f.textureNeeded[static_cast<size_t>(m.diffuseTexture)] = true;
      } else {
        f.unsampledTextureMaterials.push_back(m.name.empty() ? fmt::format("#{}", mesh.material)
                                                             : m.name);
      }
    }
  }
  for (size_t i = 0; i < scene.materials.size(); ++i) {
    if (!f.materialDrawn[i]) continue;
    const Material& m = scene.materials[i];
    switch (m.kind) {
      case MaterialKind::kDiffuse:
        f.litSurfaces = true;
        f.phong = f.phong || m.specular.maxCoeff() > 0.0f;
        break;
      case MaterialKind::kMirror:
        f.mirrors = true;
        break;
      case MaterialKind::kDielectric:
        f.dielectrics = true;
        f.absorption = f.absorption || m.absorption.maxCoeff() > 0.0f;
        break;
      case MaterialKind::kEmissive:
        break;
    }
    f.emissive = f.emissive || m.emission.maxCoeff() > 0.0f;
  }
  f.lights = !scene.lights.empty();
  f.requestedDepth = scene.maxDepth;
  // Without mirrors or glass every path ends at its first hit: depth 1 whatever was asked.
  f.depth = f.reflectionPass() ? std::max(1, scene.maxDepth) : 1;
  return f;
}

std::vector<std::string> SceneFeatures::explain() const {
  std::vector<std::string> lines;
  auto ran = [&](const std::string& what, const std::string& why) {
    lines.push_back("  ran:       " + what + " (" + why + ")");
  };
  auto left = [&](const std::string& what, const std::string& why) {
    lines.push_back("  left out:  " + what + " (" + why + ")");
  };
  ran("primary rays", "every unmasked pixel whose ray meets the scene's bounds");
  if (shadowPass()) {
    ran("shadow rays", "lights and lit (diffuse) surfaces");
  } else {
    left("shadow rays", lights ? "no drawn diffuse surface is lit" : "the scene has no lights");
  }
  if (phong) ran("Phong highlights", "a drawn material has a specular colour");
  if (reflectionPass()) {
    ran("reflection rays", mirrors && dielectrics ? "mirrors and glass drawn"
                           : mirrors              ? "a mirror is drawn"
                                                  : "glass is drawn");
  } else {
    left("reflection rays", "no mirror or glass is drawn");
  }
  if (refractionPass()) {
    ran("refraction rays", absorption ? "glass drawn, with absorption" : "glass drawn");
  } else {
    left("refraction rays", "no glass is drawn");
  }
  if (texturePass()) {
    ran(fmt::format("texture sampling ({} of {} textures loaded)", texturesNeeded(),
                    textureNeeded.size()),
        "textured materials on UV-mapped meshes");
  } else {
    left("texture sampling and loading", textureNeeded.empty()
                                             ? "the scene has no textures"
                                             : "no drawn, UV-mapped surface references a texture");
  }
  for (const std::string& name : unsampledTextureMaterials) {
    left("texture of material " + name, "its mesh has no UVs");
  }
  if (depth < requestedDepth) {
    left(fmt::format("depth {}..{}", depth + 1, requestedDepth),
         "no material makes secondary rays; depth capped at 1");
  } else {
    ran(fmt::format("recursion to depth {}", depth), "as requested");
  }
  if (meshesUnused > 0) left(fmt::format("{} mesh(es)", meshesUnused), "no instance draws them");
  return lines;
}

}  // namespace parallax
