#include "tracer/ray_log.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>

#include "common/process_cpu_time.h"
#include "tracer/glass_shadows.h"
#include "tracer/ray_packets.h"

namespace parallax {

double replayRayLog(const PhysicalScene& scene, const RayLog& log, Traversal traversal,
                    RayKind kind, long* rays, double* cpuMs) {
  auto wanted = [&](const RayLog::Batch& batch) {
    switch (kind) {
      case RayKind::kAll:
        return true;
      case RayKind::kPrimary:
        return !batch.occlusion && batch.generation == 0;
      case RayKind::kShadow:
        return batch.occlusion;
      case RayKind::kSecondary:
        return !batch.occlusion && batch.generation > 0;
    }
    return false;
  };
  long count = 0;
  for (const RayLog::Batch& batch : log.batches)
    count += wanted(batch) ? static_cast<long>(batch.rays.size()) : 0;
  // Each batch is copied from the log into the worker's packets (the layout the renderer traces)
  // right before it is traced, so Embree reads rays as warm in cache as the renderer hands them
  // over. (Packets for the whole frame built in advance are ~100 MB read cold: that replay took
  // ~1.7× the Embree time the profile shows inside a full frame, flattering the ratio.) The copy
  // is timed alone in a second pass and subtracted: what remains is the Embree calls.
  struct Packets {
    RayHitPackets hits;
    OcclusionPackets shadows;
    std::vector<ShadowTransmittance> states;  // scenes with glass shadows: traced as the frame does
    std::vector<std::uint8_t> seen;
    long glassHits = 0;
  };
  tbb::enumerable_thread_specific<Packets> perThread;
  auto pass = [&](bool trace, double* passCpuMs) {
    const double cpuStart = processCpuMs();
    const auto start = std::chrono::steady_clock::now();
    tbb::parallel_for(size_t{0}, log.batches.size(), [&](size_t b) {
      const RayLog::Batch& batch = log.batches[b];
      if (!wanted(batch)) return;
      Packets& p = perThread.local();
      if (batch.occlusion) {
        p.shadows.clear();
        for (const RTCRay& r : batch.rays)
          p.shadows.push({r.org_x, r.org_y, r.org_z}, {r.dir_x, r.dir_y, r.dir_z}, r.tfar);
        ShadowQueryContext query = shadowQueryContext(batch.coherent);
        if (scene.glassShadows()) {
          // Glass is part of the query's cost: its filter runs here as in the frame.
          if (p.states.size() < batch.rays.size()) p.states.resize(batch.rays.size());
          p.seen.assign(batch.rays.size(), 0);
          query = shadowQueryContext(batch.coherent, &scene, p.states.data(), p.seen.data(),
                                     &p.glassHits);
        }
        if (trace) occludedPackets(scene.handle(), p.shadows, traversal, &query);
      } else {
        p.hits.clear();
        for (const RTCRay& r : batch.rays)
          p.hits.push({r.org_x, r.org_y, r.org_z}, {r.dir_x, r.dir_y, r.dir_z}, r.tfar);
        if (trace) intersectPackets(scene.handle(), p.hits, traversal, batch.coherent);
      }
    });
    *passCpuMs = processCpuMs() - cpuStart;
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
        .count();
  };
  double unused = 0.0, copyCpu = 0.0, totalCpu = 0.0;
  pass(false, &unused);  // sizes the per-thread packets
  const double copyWall = pass(false, &copyCpu);
  const double totalWall = pass(true, &totalCpu);
  if (rays) *rays = count;
  if (cpuMs) *cpuMs = std::max(0.0, totalCpu - copyCpu);
  return std::max(0.0, totalWall - copyWall);
}

}  // namespace parallax
