#include "tracer/model_animation_import.h"

#include <assimp/anim.h>
#include <assimp/scene.h>
#include <fmt/format.h>

#include <cmath>
#include <map>

#include "common/input_error.h"

namespace parallax {
namespace {

// When a file leaves ticks per second out (0), assimp's own viewer and most engines take 25.
constexpr double kDefaultTicksPerSecond = 25.0;

[[noreturn]] void fail(const std::string& file, const std::string& field,
                       const std::string& reason) {
  throw InputError({file, field, 0}, reason);
}

bool finite(const aiVector3D& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

bool finite(const aiMatrix4x4& m) {
  for (unsigned r = 0; r < 4; ++r) {
    for (unsigned c = 0; c < 4; ++c) {
      if (!std::isfinite(m[r][c])) return false;
    }
  }
  return true;
}

Eigen::Affine3d toAffine(const aiMatrix4x4& m) {
  Eigen::Matrix4d out;
  out << m.a1, m.a2, m.a3, m.a4, m.b1, m.b2, m.b3, m.b4, m.c1, m.c2, m.c3, m.c4, m.d1, m.d2, m.d3,
      m.d4;
  return Eigen::Affine3d(out);
}

// Keys of one kind (position, rotation or scale): times in seconds, non-decreasing and finite,
// values finite; `convert` checks and converts one value (false: `unusable` is the error).
template <typename Key, typename Value, typename Convert>
void readKeys(const Key* keys, unsigned count, double ticksPerSecond, const std::string& file,
              const std::string& field, long* keysSoFar, std::vector<double>* times,
              std::vector<Value>* values, Convert convert, const char* unusable) {
  if (count == 0) return;
  if (!keys) fail(file, field, fmt::format("{} keys announced but none stored", count));
  *keysSoFar += count;
  if (*keysSoFar > AnimationLimits::kKeys)
    fail(file, field,
         fmt::format("more than {} animation keys in the file", AnimationLimits::kKeys));
  times->reserve(count);
  values->reserve(count);
  for (unsigned k = 0; k < count; ++k) {
    const std::string where = fmt::format("{}[{}]", field, k);
    const double t = keys[k].mTime / ticksPerSecond;
    if (!std::isfinite(t)) fail(file, where, fmt::format("time {} is not finite", keys[k].mTime));
    if (!times->empty() && t < times->back())
      fail(file, where,
           fmt::format("time {} ticks goes back before the previous key's", keys[k].mTime));
    Value value;
    if (!convert(keys[k].mValue, &value)) fail(file, where, unusable);
    times->push_back(t);
    values->push_back(value);
  }
}

bool toVector(const aiVector3D& v, Eigen::Vector3d* out) {
  if (!finite(v)) return false;
  *out = Eigen::Vector3d(v.x, v.y, v.z);
  return true;
}

bool toRotation(const aiQuaternion& q, Eigen::Quaterniond* out) {
  const Eigen::Quaterniond r(q.w, q.x, q.y, q.z);
  const double norm = r.norm();
  if (!std::isfinite(norm) || norm < 1e-12) return false;
  *out = r.normalized();
  return true;
}

ModelNode restNode(const aiNode& node, int parent, const std::string& file, int index,
                   std::vector<std::string>* warnings) {
  ModelNode n;
  n.name = node.mName.C_Str();
  n.parent = parent;
  if (!finite(node.mTransformation)) {
    warnings->push_back(fmt::format(
        "{}: node \"{}\" has a non-finite transform; taken as the identity", file, n.name));
    return n;
  }
  aiVector3D scaling, position;
  aiQuaternion rotation;
  node.mTransformation.Decompose(scaling, rotation, position);
  Eigen::Quaterniond r;
  if (!toVector(position, &n.translation) || !toVector(scaling, &n.scale) ||
      !toRotation(rotation, &r)) {
    warnings->push_back(
        fmt::format("{}: nodes[{}] \"{}\": transform does not decompose; taken as the identity",
                    file, index, n.name));
    return ModelNode{n.name, parent};
  }
  n.rotation = r;
  return n;
}

AnimationClip readClip(const aiAnimation& a, int index, const std::map<std::string, int>& nodeOf,
                       const std::string& file, long* keys, std::vector<std::string>* warnings) {
  AnimationClip clip;
  clip.name = a.mName.length > 0 ? a.mName.C_Str() : fmt::format("animation {}", index + 1);
  const std::string field = fmt::format("animations[{}] \"{}\"", index, clip.name);
  if (!std::isfinite(a.mTicksPerSecond) || a.mTicksPerSecond < 0.0)
    fail(file, field + ".ticksPerSecond", fmt::format("{} is not usable", a.mTicksPerSecond));
  double ticksPerSecond = a.mTicksPerSecond;
  if (ticksPerSecond == 0.0) {
    ticksPerSecond = kDefaultTicksPerSecond;
    warnings->push_back(fmt::format("{}: {}: no ticks per second given; {} taken", file, field,
                                    kDefaultTicksPerSecond));
  }
  clip.duration = a.mDuration / ticksPerSecond;
  if (!std::isfinite(clip.duration) || clip.duration < 0.0 ||
      clip.duration > AnimationLimits::kSeconds) {
    fail(file, field + ".duration",
         fmt::format("{} ticks is not a usable duration (0 to {} s)", a.mDuration,
                     AnimationLimits::kSeconds));
  }
  if (a.mNumMorphMeshChannels > 0 || a.mNumMeshChannels > 0) {
    warnings->push_back(fmt::format(
        "{}: {}: its {} morph-target and {} mesh channels are not played (node and skeletal "
        "animation only)",
        file, field, a.mNumMorphMeshChannels, a.mNumMeshChannels));
  }
  if (a.mNumChannels > 0 && !a.mChannels) fail(file, field, "channels announced but none stored");
  if (a.mNumChannels > AnimationLimits::kNodes)
    fail(file, field,
         fmt::format("{} channels, more than the {} allowed", a.mNumChannels,
                     AnimationLimits::kNodes));
  for (unsigned c = 0; c < a.mNumChannels; ++c) {
    const std::string where = fmt::format("{}.channels[{}]", field, c);
    const aiNodeAnim* source = a.mChannels[c];
    if (!source) fail(file, where, "missing");
    const auto node = nodeOf.find(source->mNodeName.C_Str());
    if (node == nodeOf.end()) {
      fail(file, where,
           fmt::format("names node \"{}\", which the model does not have",
                       source->mNodeName.C_Str()));
    }
    NodeChannel channel;
    channel.node = node->second;
    readKeys(source->mPositionKeys, source->mNumPositionKeys, ticksPerSecond, file,
             where + ".positionKeys", keys, &channel.positionTimes, &channel.positions, toVector,
             "value is not finite");
    readKeys(source->mRotationKeys, source->mNumRotationKeys, ticksPerSecond, file,
             where + ".rotationKeys", keys, &channel.rotationTimes, &channel.rotations, toRotation,
             "rotation is not finite or has zero length");
    readKeys(source->mScalingKeys, source->mNumScalingKeys, ticksPerSecond, file,
             where + ".scalingKeys", keys, &channel.scaleTimes, &channel.scales, toVector,
             "value is not finite");
    clip.channels.push_back(std::move(channel));
  }
  return clip;
}

SkinnedPart readSkin(const aiMesh& mesh, unsigned index, int sceneMesh, int meshNode,
                     const std::map<std::string, int>& nodeOf, const Scene& scene,
                     const std::string& file, long* weights, std::vector<std::string>* warnings) {
  const std::string field = fmt::format("meshes[{}] \"{}\"", index, mesh.mName.C_Str());
  if (mesh.mNumBones > AnimationLimits::kBonesPerMesh)
    fail(file, field,
         fmt::format("{} bones, more than the {} allowed", mesh.mNumBones,
                     AnimationLimits::kBonesPerMesh));
  if (!mesh.mBones) fail(file, field, "bones announced but none stored");
  SkinnedPart part;
  part.mesh = sceneMesh;
  part.meshNode = meshNode;
  const Mesh& drawn = scene.meshes.at(static_cast<size_t>(sceneMesh));
  part.bindPositions = drawn.positions;
  part.bindNormals = drawn.normals;
  const size_t vertices = part.bindPositions.size();
  // Weights gathered per vertex first, then laid out flat.
  std::vector<std::vector<std::pair<std::uint32_t, double>>> perVertex(vertices);
  for (unsigned b = 0; b < mesh.mNumBones; ++b) {
    const std::string where = fmt::format("{}.bones[{}]", field, b);
    const aiBone* bone = mesh.mBones[b];
    if (!bone) fail(file, where, "missing");
    const auto node = nodeOf.find(bone->mName.C_Str());
    if (node == nodeOf.end())
      fail(file, where,
           fmt::format("names node \"{}\", which the model does not have", bone->mName.C_Str()));
    if (!finite(bone->mOffsetMatrix)) fail(file, where + ".offsetMatrix", "is not finite");
    if (bone->mNumWeights > 0 && !bone->mWeights)
      fail(file, where, "weights announced but none stored");
    *weights += bone->mNumWeights;
    if (*weights > AnimationLimits::kWeights)
      fail(file, where,
           fmt::format("more than {} bone weights in the file", AnimationLimits::kWeights));
    for (unsigned w = 0; w < bone->mNumWeights; ++w) {
      const aiVertexWeight& weight = bone->mWeights[w];
      if (weight.mVertexId >= vertices) {
        fail(file, fmt::format("{}.weights[{}]", where, w),
             fmt::format("vertex {} of a mesh of {}", weight.mVertexId, vertices));
      }
      if (!std::isfinite(weight.mWeight) || weight.mWeight < 0.0f) {
        fail(file, fmt::format("{}.weights[{}]", where, w),
             fmt::format("weight {} is not a finite number >= 0", weight.mWeight));
      }
      if (weight.mWeight > 0.0f)
        perVertex[weight.mVertexId].emplace_back(b, static_cast<double>(weight.mWeight));
    }
    part.boneNodes.push_back(node->second);
    part.boneOffsets.push_back(toAffine(bone->mOffsetMatrix));
  }
  part.influenceStart.reserve(vertices + 1);
  part.influenceStart.push_back(0);
  size_t unweighted = 0;
  for (const auto& influences : perVertex) {
    double total = 0.0;
    for (const auto& [bone, w] : influences) total += w;
    // Weights that do not sum to 1 (a limit on bones per vertex applied by the exporter) are
    // scaled so the vertex stays where its bones put it.
    if (total > 0.0 && std::isfinite(total)) {
      for (const auto& [bone, w] : influences) {
        part.influenceBone.push_back(bone);
        part.influenceWeight.push_back(w / total);
      }
    }
    part.influenceStart.push_back(static_cast<std::uint32_t>(part.influenceBone.size()));
    if (part.influenceStart.back() == part.influenceStart[part.influenceStart.size() - 2])
      ++unweighted;
  }
  // Assimp drops weights it cannot use (NaN, a joint the skin does not have) without a word.
  if (unweighted > 0) {
    warnings->push_back(fmt::format(
        "{}: {}: {} of its {} vertices have no bone weights; they follow the mesh's node", file,
        field, unweighted, vertices));
  }
  return part;
}

}  // namespace

std::vector<FlatNode> flattenNodes(const aiScene& model, const std::string& file) {
  std::vector<FlatNode> nodes;
  std::vector<FlatNode> stack{{model.mRootNode, -1}};
  while (!stack.empty()) {
    const FlatNode here = stack.back();
    stack.pop_back();
    if (!here.node) continue;
    if (static_cast<long>(nodes.size()) >= AnimationLimits::kNodes)
      fail(file, "nodes", fmt::format("more than {} nodes", AnimationLimits::kNodes));
    const int index = static_cast<int>(nodes.size());
    nodes.push_back(here);
    if (here.node->mNumChildren > 0 && !here.node->mChildren) continue;
    // Pushed in reverse so children come out in the file's order.
    for (unsigned c = here.node->mNumChildren; c-- > 0;)
      stack.push_back({here.node->mChildren[c], index});
  }
  return nodes;
}

ModelAnimation importAnimation(const aiScene& model, const std::vector<FlatNode>& flat,
                               const std::vector<int>& sceneMeshOf,
                               const std::vector<PlacedMesh>& placed, const Scene& scene,
                               const std::string& file, std::vector<std::string>* warnings) {
  ModelAnimation animation;
  animation.file = file;
  std::map<std::string, int> nodeOf;  // a name given twice: the first node, as assimp's viewer
  for (size_t i = 0; i < flat.size(); ++i) {
    animation.nodes.push_back(
        restNode(*flat[i].node, flat[i].parent, file, static_cast<int>(i), warnings));
    nodeOf.emplace(animation.nodes.back().name, static_cast<int>(i));
  }
  if (model.mNumAnimations > AnimationLimits::kClips)
    fail(file, "animations",
         fmt::format("{} animations, more than the {} allowed", model.mNumAnimations,
                     AnimationLimits::kClips));
  long keys = 0;
  for (unsigned a = 0; a < model.mNumAnimations; ++a) {
    if (!model.mAnimations || !model.mAnimations[a])
      fail(file, fmt::format("animations[{}]", a), "missing");
    animation.clips.push_back(
        readClip(*model.mAnimations[a], static_cast<int>(a), nodeOf, file, &keys, warnings));
  }

  long weights = 0;
  std::map<unsigned, size_t> skinOf;  // assimp mesh → its SkinnedPart
  for (const PlacedMesh& p : placed) {
    const aiMesh* mesh = p.source < model.mNumMeshes ? model.mMeshes[p.source] : nullptr;
    if (!mesh || mesh->mNumBones == 0) {
      animation.rigidParts.push_back({p.instance, p.node});
      continue;
    }
    auto skin = skinOf.find(p.source);
    if (skin == skinOf.end()) {
      skin = skinOf.emplace(p.source, animation.skinnedParts.size()).first;
      animation.skinnedParts.push_back(readSkin(*mesh, p.source, sceneMeshOf.at(p.source), p.node,
                                                nodeOf, scene, file, &weights, warnings));
    }
    animation.skinnedParts[skin->second].instances.push_back(p.instance);
  }

  // Which instances each clip moves: those under an animated node, and skins with such a bone.
  for (AnimationClip& clip : animation.clips) {
    std::vector<bool> moves(animation.nodes.size(), false);
    for (const NodeChannel& c : clip.channels) moves[static_cast<size_t>(c.node)] = true;
    for (size_t i = 0; i < animation.nodes.size(); ++i) {
      const int parent = animation.nodes[i].parent;
      if (parent >= 0 && moves[static_cast<size_t>(parent)]) moves[i] = true;
    }
    for (const RigidPart& part : animation.rigidParts) {
      if (moves[static_cast<size_t>(part.node)]) clip.movingInstances.push_back(part.instance);
    }
    for (const SkinnedPart& part : animation.skinnedParts) {
      bool moved = moves[static_cast<size_t>(part.meshNode)];
      for (int bone : part.boneNodes) moved = moved || moves[static_cast<size_t>(bone)];
      if (moved)
        clip.movingInstances.insert(clip.movingInstances.end(), part.instances.begin(),
                                    part.instances.end());
    }
  }
  return animation;
}

}  // namespace parallax
