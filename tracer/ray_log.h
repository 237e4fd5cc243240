#pragma once
// The benchmark's view of a frame's rays (`parallax bench tracer`): every batch a render traced,
// recorded by renderFrameInto when given a RayLog, and traced again without shading to measure
// the raw Embree cost of exactly the same rays. Not used when rendering for a display.

#include <embree3/rtcore.h>

#include <mutex>
#include <vector>

#include "tracer/physical_scene.h"
#include "tracer/ray_batch.h"

namespace parallax {

// Every batch a render traced, in the order the tiles handed them to Embree.
struct RayLog {
  struct Batch {
    bool occlusion = false;
    bool coherent = false;  // primary rays and their shadow rays
    int generation = 0;     // 0: primary (and its shadow rays)
    std::vector<RTCRay> rays;
  };
  std::mutex mutex;
  std::vector<Batch> batches;
};

enum class RayKind { kAll, kPrimary, kShadow, kSecondary };

// Traces the logged batches of `kind` again (in parallel, no shading) with `traversal`; returns
// the wall-clock ms of the Embree calls (a pass that only copies each batch into packets is
// timed too and subtracted). `rays` (optional) receives how many rays that was, `cpuMs`
// (optional) the process CPU time of those calls (all threads).
double replayRayLog(const PhysicalScene& scene, const RayLog& log, Traversal traversal,
                    RayKind kind = RayKind::kAll, long* rays = nullptr, double* cpuMs = nullptr);

}  // namespace parallax
