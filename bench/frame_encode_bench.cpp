// Frame::toSrgb8 (linear float → sRGB bytes, what the daemon does to every module frame before
// the link): ns per channel over a 1024×768 frame of a rendered-like mix of values. Prints
// figures; never fails on time. Run: build/bench/frame_encode_bench

#include <benchmark/benchmark.h>

#include <cstdint>
#include <random>
#include <vector>

#include "tracer/frame.h"

namespace parallax {
namespace {

void encodeFrame(benchmark::State& state) {
  Frame frame(1024, 768);
  // Mostly [0, 1] with some over-exposed, some black: what a lit scene gives.
  std::mt19937 random(7);
  std::uniform_real_distribution<float> value(-0.05f, 1.2f);
  for (Rgb& p : frame.pixels) p = Rgb(value(random), value(random), value(random));
  for (auto _ : state) {
    std::vector<std::uint8_t> bytes = frame.toSrgb8();
    benchmark::DoNotOptimize(bytes.data());
  }
  state.counters["ns/channel"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * static_cast<double>(frame.pixels.size()) * 3.0,
      benchmark::Counter::kIsRate | benchmark::Counter::kInvert, benchmark::Counter::kIs1000);
}
BENCHMARK(encodeFrame)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace parallax

BENCHMARK_MAIN();
