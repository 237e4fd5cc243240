#pragma once
// The animations of a loaded model file (glTF, FBX, COLLADA, X, ... through assimp): its node
// hierarchy, the key frames of each animation clip, and its skinned meshes. Assimp reads keys,
// bones and weights but evaluates nothing; this file does: node channels (position, rotation
// and scale keys, linear and spherical-linear interpolation, the first/last key held outside
// them) give each node's transform at a time, the nodes' global transforms place the rigid
// parts, and skinned meshes are deformed on the CPU from their bones (global × offset matrix,
// weighted per vertex). Imported by model_animation_import.h; played by px.set_animation.

#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "calibration/display/box3.h"
#include "tracer/scene.h"

namespace parallax {

struct ModelNode {
  std::string name;
  int parent = -1;  // always before this node in ModelAnimation::nodes (-1: the root)
  // The rest pose, as T · R · S (what a channel without keys of a kind keeps).
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d scale = Eigen::Vector3d::Ones();
};

// One node's keys in one clip. Times in seconds, strictly increasing; rotations unit length.
struct NodeChannel {
  int node = 0;
  std::vector<double> positionTimes, rotationTimes, scaleTimes;
  std::vector<Eigen::Vector3d> positions, scales;
  std::vector<Eigen::Quaterniond> rotations;
};

struct AnimationClip {
  std::string name;       // the file's, or "animation N" (1-based) when it gives none
  double duration = 0.0;  // seconds
  std::vector<NodeChannel> channels;
  std::vector<int> movingInstances;  // Scene instances whose pose this clip changes
};

// An instance that follows one node (a mesh hung in the hierarchy).
struct RigidPart {
  int instance = 0;
  int node = 0;
};

// A mesh deformed by bones: vertex = Σ weight · (bone node's global · offset) · bind vertex;
// a vertex without weights follows the mesh's own node. The deformed positions are in the
// model's space, so its instances are placed by the model's placement and normalisation alone.
struct SkinnedPart {
  int mesh = 0;  // Scene mesh whose positions (and normals) are rewritten
  std::vector<int> instances;
  int meshNode = 0;
  std::vector<Eigen::Vector3d> bindPositions;
  std::vector<Eigen::Vector3f> bindNormals;  // empty when the mesh has none
  std::vector<int> boneNodes;
  std::vector<Eigen::Affine3d> boneOffsets;  // mesh space → bone space in the bind pose
  // Influences of vertex v: [influenceStart[v], influenceStart[v + 1]); weights sum to 1.
  std::vector<std::uint32_t> influenceStart;
  std::vector<std::uint32_t> influenceBone;
  std::vector<double> influenceWeight;
};

class ModelAnimation {
 public:
  std::string file;  // the model file, for messages
  std::vector<ModelNode> nodes;
  std::vector<RigidPart> rigidParts;
  std::vector<SkinnedPart> skinnedParts;
  std::vector<AnimationClip> clips;
  // Model space → world: the caller's placement times the load's normalisation (height).
  Eigen::Affine3d placement = Eigen::Affine3d::Identity();
  Eigen::Affine3d normalisation = Eigen::Affine3d::Identity();
  // Model space (after normalisation) bounds of every clip's poses and the rest pose, sampled
  // at every key time (or 256 even steps when there are more) and at the clip's ends.
  Box3 motionBounds;
  int motionBoundsIndex = -1;  // this model's entry in Scene::motionBounds

  // Index of the clip called `name`, or -1.
  int findClip(const std::string& name) const;
  // Seconds into clip `clip` for an animation time: t in [0, duration] as it is, any other t
  // wrapped into it (a clip plays in a loop).
  double clipTime(int clip, double seconds) const;
  // Each node's model-space transform at `seconds` into `clip` (already wrapped); clip -1: rest.
  std::vector<Eigen::Affine3d> nodeTransforms(int clip, double seconds) const;
  // Writes the pose into the scene: rigid parts' instance transforms, skinned meshes'
  // positions and normals, and this model's Scene::motionBounds entry (placed).
  void pose(int clip, double seconds, Scene* scene) const;
  // Deformed positions of one skinned part for these node transforms (model space).
  void skin(const SkinnedPart& part, const std::vector<Eigen::Affine3d>& nodes,
            std::vector<Eigen::Vector3d>* positions, std::vector<Eigen::Vector3f>* normals) const;
  // Sets motionBounds by posing every clip (after the import and the normalisation).
  void measureMotionBounds(const Scene& scene);
  // The placed motion bounds (world space).
  Box3 placedMotionBounds() const;
};

}  // namespace parallax
