// Ray-texture generation for whole displays into preallocated buffers (the daemon regenerates
// into memory it already holds): wall time, pixels/s and peak resident memory. Prints figures;
// never fails on time. Run: build/bench/ray_textures_bench [--benchmark_filter=default]

#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <vector>

#include "calibration/display/display_presets.h"
#include "calibration/display/ray_textures.h"

namespace parallax {
namespace {

double processCpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

double peakResidentMiB() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // ru_maxrss is KiB on Linux
}

void generateDisplay(benchmark::State& state, const DisplayModel& model) {
  // One compact buffer for the whole display, allocated and touched once, outside the timing.
  std::vector<CompactRay> buffer(static_cast<size_t>(model.pixelCount()));
  const double cpuBefore = processCpuSeconds();
  for (auto _ : state) {
    size_t offset = 0;
    for (size_t i = 0; i < model.modules.size(); ++i) {
      const size_t n = static_cast<size_t>(model.modules[i].pixelCount());
      generateRayTexturesInto(model, static_cast<int>(i), std::span(buffer).subspan(offset, n));
      offset += n;
    }
    benchmark::DoNotOptimize(buffer.data());
    benchmark::ClobberMemory();
  }
  // CPU seconds of all threads per generation: with the machine shared, wall time alone misleads;
  // cpu_s / cores is the wall time an idle machine would show.
  state.counters["cpu_s_all_threads"] =
      (processCpuSeconds() - cpuBefore) / static_cast<double>(state.iterations());
  long valid = 0;
  for (const CompactRay& r : buffer) valid += r.masked() ? 0 : 1;
  const double pixels = static_cast<double>(model.pixelCount());
  state.counters["pixels"] = pixels;
  state.counters["pixels_per_s"] =
      benchmark::Counter(pixels, benchmark::Counter::kIsIterationInvariantRate);
  state.counters["valid_fraction"] = static_cast<double>(valid) / pixels;
  state.counters["bytes_per_pixel"] = static_cast<double>(sizeof(CompactRay));
  state.counters["buffer_MiB"] = pixels * sizeof(CompactRay) / (1024.0 * 1024.0);
  state.counters["peak_rss_MiB"] = peakResidentMiB();
}

DisplayModel variant(const std::string& preset, double k, ScreenTransfer transfer,
                     double k1 = 0.0) {
  NominalDisplayOptions options;
  options.preset = preset;
  options.curvature = k;
  options.transfer = transfer;
  DisplayModel model = makeNominalDisplay(options);
  for (OpticalModule& m : model.modules) m.k1 = k1;
  return model;
}

void BM_Default_Conical_Flat(benchmark::State& s) {
  generateDisplay(s, variant("default", 0.0, ScreenTransfer::kConical));
}
void BM_Default_Linear_Flat(benchmark::State& s) {
  generateDisplay(s, variant("default", 0.0, ScreenTransfer::kLinear));
}
void BM_Default_Conical_Curved(benchmark::State& s) {
  generateDisplay(s, variant("default", 0.5, ScreenTransfer::kConical));
}
// A calibrated display has lens distortion: every pixel then pays the radial undistortion.
void BM_Default_Conical_Distorted(benchmark::State& s) {
  generateDisplay(s, variant("default", 0.5, ScreenTransfer::kConical, -0.08));
}
void BM_Demo_Conical_Flat(benchmark::State& s) {
  generateDisplay(s, variant("demo", 0.0, ScreenTransfer::kConical));
}

BENCHMARK(BM_Default_Conical_Flat)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(3.0);
BENCHMARK(BM_Default_Linear_Flat)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(3.0);
BENCHMARK(BM_Default_Conical_Curved)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(3.0);
BENCHMARK(BM_Default_Conical_Distorted)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(3.0);
BENCHMARK(BM_Demo_Conical_Flat)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace parallax

BENCHMARK_MAIN();
