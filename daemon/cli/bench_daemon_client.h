#pragma once
// What the benchmarks that run the real parallaxd share (`parallax bench daemon`, `bench
// cluster`): finding the binaries beside parallax, asking the daemon, waiting for its stats and
// averaging a stage over a window of frames.

#include <sys/types.h>

#include <functional>
#include <nlohmann/json.hpp>
#include <string>

namespace parallax::cli {

// `name` next to the running parallax (or in its parallaxd/ folder); throws when not built.
std::string siblingBinary(const std::string& name);
// The daemon's answer, or null when it does not answer.
nlohmann::json askOrNull(const std::string& socket, const nlohmann::json& request);
// Polls `stats` (every 100 ms) until `done` says so; throws when the daemon reports an error,
// when the process `daemon` (a child of this one, when given) has exited, or after
// `timeoutSeconds`, naming `what`.
nlohmann::json waitForStats(const std::string& socket,
                            const std::function<bool(const nlohmann::json&)>& done,
                            const char* what, int timeoutSeconds, pid_t daemon = -1);
// Mean of a StageTiming (loop_stats.h: count, mean_ms) over the frames between two replies.
double windowMeanMs(const nlohmann::json& before, const nlohmann::json& after);
// The scene as the daemon's config names it: a library name, or a .lua file by its absolute path
// (the config lives elsewhere).
std::string sceneForConfig(const std::string& scene);
// The ray-texture cache the benches share per user (~/.cache/parallax; else under `work`), so
// that a second run does not time their generation.
std::string benchCacheDir(const std::string& work);
// /proc/loadavg's line, for the benchmark's header.
std::string loadAverage();

}  // namespace parallax::cli
