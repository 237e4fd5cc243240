#pragma once
// assimp's node hierarchy, animation clips and bones → ModelAnimation (model_animation.h),
// read as hostile input: a channel or bone naming a node the file does not have, a weight on a
// vertex the mesh does not have, NaN or infinite keys, offsets or weights, keys going back in
// time, and counts past the limits below are an InputError naming the file and the field
// ("animations[1] \"Walk\".channels[4].rotationKeys[7]").

#include <string>
#include <vector>

#include "tracer/model_animation.h"

struct aiNode;
struct aiScene;

namespace parallax {

struct AnimationLimits {
  static constexpr long kNodes = 1 << 20;
  static constexpr long kClips = 4096;
  static constexpr long kKeys = 1 << 22;  // over all channels of all clips
  static constexpr long kBonesPerMesh = 1 << 16;
  static constexpr long kWeights = 1 << 25;  // over all bones of all meshes
  static constexpr double kSeconds = 1e6;    // the longest clip
};

// The hierarchy in preorder (parents first). Throws past AnimationLimits::kNodes.
struct FlatNode {
  const aiNode* node = nullptr;
  int parent = -1;
};
std::vector<FlatNode> flattenNodes(const aiScene& model, const std::string& file);

// An instance the loader made: aiMesh `source` hung under flattened node `node`.
struct PlacedMesh {
  int instance = 0;
  int node = 0;
  unsigned source = 0;
};

// The nodes, clips and skinned meshes of `model`. `sceneMeshOf` maps assimp's meshes to the
// Scene's (-1: not drawn); the skinned ones' bind poses are read from `scene`. A mesh with bones
// becomes a SkinnedPart, any other placed mesh a RigidPart. Placement, normalisation and motion
// bounds are left to the caller. Warnings (morph targets not played, ticks per second not given)
// go to `warnings`.
ModelAnimation importAnimation(const aiScene& model, const std::vector<FlatNode>& nodes,
                               const std::vector<int>& sceneMeshOf,
                               const std::vector<PlacedMesh>& placed, const Scene& scene,
                               const std::string& file, std::vector<std::string>* warnings);

}  // namespace parallax
