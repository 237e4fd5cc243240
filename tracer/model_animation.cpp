#include "tracer/model_animation.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace parallax {
namespace {

// The value at `t` from keys at strictly increasing `times`: the first/last key outside them,
// `mix` between the two keys around t inside; `rest` when there are no keys.
template <typename T, typename Mix>
T sample(const std::vector<double>& times, const std::vector<T>& values, double t, const T& rest,
         Mix mix) {
  if (times.empty()) return rest;
  if (t <= times.front()) return values.front();
  if (t >= times.back()) return values.back();
  const size_t i =
      static_cast<size_t>(std::upper_bound(times.begin(), times.end(), t) - times.begin());
  const double a = (t - times[i - 1]) / (times[i] - times[i - 1]);
  return mix(values[i - 1], values[i], a);
}

Eigen::Vector3d lerp(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double s) {
  return a + s * (b - a);
}

Eigen::Quaterniond slerp(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b, double s) {
  return a.slerp(s, b);  // the shorter way round
}

Eigen::Affine3d compose(const Eigen::Vector3d& t, const Eigen::Quaterniond& r,
                        const Eigen::Vector3d& s) {
  Eigen::Affine3d m = Eigen::Affine3d::Identity();
  m.linear() = r.toRotationMatrix() * s.asDiagonal();
  m.translation() = t;
  return m;
}

// The matrix that maps normals: the cofactor matrix, det · M^-T. Unlike the inverse it stays
// finite for a singular bone (a key scaling to zero), where it gives zero normals, which the
// tracer replaces by the face normal.
Eigen::Matrix3d normalMatrix(const Eigen::Matrix3d& m) {
  Eigen::Matrix3d c;
  c.col(0) = m.col(1).cross(m.col(2));
  c.col(1) = m.col(2).cross(m.col(0));
  c.col(2) = m.col(0).cross(m.col(1));
  return c;
}

// A zero normal (opposed bones cancelling) is left to the tracer's face-normal fallback.
Eigen::Vector3f unitOrZero(const Eigen::Vector3d& normal) {
  const double length = normal.norm();
  if (!(length > 0.0) || !std::isfinite(length)) return Eigen::Vector3f::Zero();
  return (normal / length).cast<float>();
}

void grow(Box3* box, const Eigen::Vector3d& p) {
  box->min = box->min.cwiseMin(p);
  box->max = box->max.cwiseMax(p);
}

}  // namespace

int ModelAnimation::findClip(const std::string& name) const {
  for (size_t i = 0; i < clips.size(); ++i) {
    if (clips[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

double ModelAnimation::clipTime(int clip, double seconds) const {
  const double duration = clips.at(static_cast<size_t>(clip)).duration;
  if (seconds >= 0.0 && seconds <= duration) return seconds;
  if (!(duration > 0.0)) return 0.0;
  const double wrapped = std::fmod(seconds, duration);
  return wrapped < 0.0 ? wrapped + duration : wrapped;
}

std::vector<Eigen::Affine3d> ModelAnimation::nodeTransforms(int clip, double seconds) const {
  std::vector<Eigen::Affine3d> local(nodes.size());
  for (size_t i = 0; i < nodes.size(); ++i)
    local[i] = compose(nodes[i].translation, nodes[i].rotation, nodes[i].scale);
  if (clip >= 0) {
    for (const NodeChannel& c : clips.at(static_cast<size_t>(clip)).channels) {
      const ModelNode& n = nodes[static_cast<size_t>(c.node)];
      local[static_cast<size_t>(c.node)] =
          compose(sample(c.positionTimes, c.positions, seconds, n.translation, lerp),
                  sample(c.rotationTimes, c.rotations, seconds, n.rotation, slerp),
                  sample(c.scaleTimes, c.scales, seconds, n.scale, lerp));
    }
  }
  // Parents come first, so one pass turns local transforms into model-space ones.
  for (size_t i = 0; i < nodes.size(); ++i) {
    const int parent = nodes[i].parent;
    if (parent >= 0) local[i] = local[static_cast<size_t>(parent)] * local[i];
  }
  return local;
}

void ModelAnimation::skin(const SkinnedPart& part, const std::vector<Eigen::Affine3d>& transforms,
                          std::vector<Eigen::Vector3d>* positions,
                          std::vector<Eigen::Vector3f>* normals) const {
  const size_t bones = part.boneNodes.size();
  std::vector<Eigen::Matrix<double, 3, 4>> skinning(bones);
  std::vector<Eigen::Matrix3d> normalSkinning(bones);
  for (size_t b = 0; b < bones; ++b) {
    const Eigen::Affine3d m =
        transforms[static_cast<size_t>(part.boneNodes[b])] * part.boneOffsets[b];
    skinning[b] = m.matrix().topRows<3>();
    normalSkinning[b] = normalMatrix(m.linear());
  }
  const Eigen::Affine3d& own = transforms[static_cast<size_t>(part.meshNode)];
  const Eigen::Matrix3d ownNormal = normalMatrix(own.linear());
  const size_t count = part.bindPositions.size();
  positions->resize(count);
  const bool withNormals = !part.bindNormals.empty();
  if (withNormals) normals->resize(count);
  for (size_t v = 0; v < count; ++v) {
    const std::uint32_t begin = part.influenceStart[v], end = part.influenceStart[v + 1];
    const Eigen::Vector4d p = part.bindPositions[v].homogeneous();
    if (begin == end) {
      (*positions)[v] = own * part.bindPositions[v];
      if (withNormals) (*normals)[v] = unitOrZero(ownNormal * part.bindNormals[v].cast<double>());
      continue;
    }
    Eigen::Matrix<double, 3, 4> m = Eigen::Matrix<double, 3, 4>::Zero();
    Eigen::Matrix3d n = Eigen::Matrix3d::Zero();
    for (std::uint32_t k = begin; k < end; ++k) {
      m += part.influenceWeight[k] * skinning[part.influenceBone[k]];
      if (withNormals) n += part.influenceWeight[k] * normalSkinning[part.influenceBone[k]];
    }
    (*positions)[v] = m * p;
    if (withNormals) {
      (*normals)[v] = unitOrZero(n * part.bindNormals[v].cast<double>());
    }
  }
}

void ModelAnimation::pose(int clip, double seconds, Scene* scene) const {
  const std::vector<Eigen::Affine3d> transforms = nodeTransforms(clip, seconds);
  const Eigen::Affine3d worldFromModel = placement * normalisation;
  for (const RigidPart& part : rigidParts) {
    scene->instances.at(static_cast<size_t>(part.instance)).worldFromObject =
        worldFromModel * transforms[static_cast<size_t>(part.node)];
  }
  for (const SkinnedPart& part : skinnedParts) {
    Mesh& mesh = scene->meshes.at(static_cast<size_t>(part.mesh));
    skin(part, transforms, &mesh.positions, &mesh.normals);
    for (int instance : part.instances)
      scene->instances.at(static_cast<size_t>(instance)).worldFromObject = worldFromModel;
  }
  if (motionBoundsIndex >= 0)
    scene->motionBounds.at(static_cast<size_t>(motionBoundsIndex)) = placedMotionBounds();
}

void ModelAnimation::measureMotionBounds(const Scene& scene) {
  Box3 box;
  box.min = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  box.max = -box.min;
  std::vector<Eigen::Vector3d> positions;
  std::vector<Eigen::Vector3f> normals;
  auto addPose = [&](int clip, double seconds) {
    const std::vector<Eigen::Affine3d> transforms = nodeTransforms(clip, seconds);
    for (const RigidPart& part : rigidParts) {
      const Instance& instance = scene.instances.at(static_cast<size_t>(part.instance));
      const Eigen::Affine3d m = normalisation * transforms[static_cast<size_t>(part.node)];
      for (const Eigen::Vector3d& p : scene.meshes.at(static_cast<size_t>(instance.mesh)).positions)
        grow(&box, m * p);
    }
    for (const SkinnedPart& part : skinnedParts) {
      skin(part, transforms, &positions, &normals);
      for (const Eigen::Vector3d& p : positions) grow(&box, normalisation * p);
    }
  };
  constexpr size_t kMaxSamples = 256;
  addPose(-1, 0.0);
  for (size_t c = 0; c < clips.size(); ++c) {
    std::vector<double> times{0.0, clips[c].duration};
    for (const NodeChannel& channel : clips[c].channels) {
      for (const auto* keys : {&channel.positionTimes, &channel.rotationTimes, &channel.scaleTimes})
        times.insert(times.end(), keys->begin(), keys->end());
    }
    std::sort(times.begin(), times.end());
    times.erase(std::unique(times.begin(), times.end()), times.end());
    if (times.size() > kMaxSamples) {
      times.clear();
      for (size_t k = 0; k <= kMaxSamples; ++k)
        times.push_back(clips[c].duration * static_cast<double>(k) / kMaxSamples);
    }
    for (double t : times) addPose(static_cast<int>(c), t);
  }
  motionBounds = box.min.allFinite() ? box : Box3{};
}

Box3 ModelAnimation::placedMotionBounds() const {
  Box3 placed;
  placed.min = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  placed.max = -placed.min;
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3d p((corner & 1) ? motionBounds.max.x() : motionBounds.min.x(),
                            (corner & 2) ? motionBounds.max.y() : motionBounds.min.y(),
                            (corner & 4) ? motionBounds.max.z() : motionBounds.min.z());
    grow(&placed, placement * p);
  }
  return placed;
}

}  // namespace parallax
