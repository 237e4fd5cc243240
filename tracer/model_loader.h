#pragma once
// Model files (OBJ + MTL, glTF 2.0, and whatever else assimp reads) into a Scene. Real-world
// files are hostile: Windows paths in MTL (`map_Kd .\tex.jpg`), textures that are missing or
// named in another case, quads and polygons, missing normals, empty and truncated files. Those
// become warnings and fallbacks where a frame can still be made, and an InputError naming the
// file otherwise.

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "tracer/model_animation.h"
#include "tracer/scene.h"

namespace parallax {

struct ModelLoadOptions {
  // Uniformly scales the model so its bounding box is this tall (world units); 0 keeps its own
  // units.
  double targetHeight = 0.0;
  // Where the model goes: applied after the normalisation above, which puts the bottom centre
  // of the model's bounding box at the origin when targetHeight > 0.
  Eigen::Affine3d worldFromModel = Eigen::Affine3d::Identity();
};

struct ModelLoadReport {
  int meshes = 0;
  long triangles = 0;
  int materials = 0;
  int textures = 0;          // texture references added to the scene
  int texturesMissing = 0;   // files not found: the material's colour is the fallback
  int generatedNormals = 0;  // meshes that had no normals
  int animations = 0;        // clips read (only when an animation was asked for)
  int skinnedMeshes = 0;
  std::vector<std::string> warnings;
};

// Appends the model's meshes, materials, textures and instances to `scene`. Throws InputError
// naming the file when it cannot be read or holds no triangles. With `animation` and a file that
// has animations, also reads them (model_animation_import.h: InputError for bad ones), shows
// the rest pose as they evaluate it (skinned meshes deformed by their bones) and adds the
// bounds of every clip's motion to Scene::motionBounds; a file without animations leaves
// `animation` untouched and loads as without it.
ModelLoadReport appendModel(const std::string& path, const ModelLoadOptions& options, Scene* scene,
                            ModelAnimation* animation = nullptr);

// A scene of one model, lit by the paper's four directional lights, B_W = its bounds.
Scene loadModelScene(const std::string& path, ModelLoadReport* report = nullptr);

// `map_Kd .\sub\tex.jpg` → the file it means, relative to `modelDirectory`: backslashes become
// slashes, and when the exact name is missing a case-insensitive match in that folder is
// accepted. Returns the resolved path, or the cleaned one when nothing matches.
std::string resolveTexturePath(const std::string& reference, const std::string& modelDirectory,
                               bool* found);

}  // namespace parallax
