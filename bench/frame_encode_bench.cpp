// Frame encoding (linear float → the module's 8-bit bytes, what the daemon does to every module
// frame before the link), ns per channel over a 1024×768 frame of a rendered-like mix of values:
//   encodeFrame           Frame::toSrgb8, an ideal sRGB module (no photometric correction);
//   encodeFrameCorrected  ModuleEncoder with a full photometric correction (colour matrix, black
//                         lift, a 16×12 gain map, a gamma 2.3 response): the budget is
//                         ≤ 15% over encodeFrame, both measured in this one run.
// Prints figures; never fails on time. Run: build/bench/frame_encode_bench

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "tracer/frame.h"
#include "tracer/module_encoder.h"

namespace parallax {
namespace {

Frame litFrame() {
  Frame frame(1024, 768);
  // Mostly [0, 1] with some over-exposed, some black: what a lit scene gives.
  std::mt19937 random(7);
  std::uniform_real_distribution<float> value(-0.05f, 1.2f);
  for (Rgb& p : frame.pixels) p = Rgb(value(random), value(random), value(random));
  return frame;
}

void countChannels(benchmark::State& state, const Frame& frame) {
  state.counters["ns/channel"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * static_cast<double>(frame.pixels.size()) * 3.0,
      benchmark::Counter::kIsRate | benchmark::Counter::kInvert, benchmark::Counter::kIs1000);
}

void encodeFrame(benchmark::State& state) {
  const Frame frame = litFrame();
  for (auto _ : state) {
    std::vector<std::uint8_t> bytes = frame.toSrgb8();
    benchmark::DoNotOptimize(bytes.data());
  }
  countChannels(state, frame);
}
BENCHMARK(encodeFrame)->Unit(benchmark::kMillisecond);

void encodeFrameCorrected(benchmark::State& state) {
  const Frame frame = litFrame();
  ModuleColourCorrection c;
  c.driveFromContent << 0.80f, 0.06f, 0.02f, 0.05f, 0.74f, 0.04f, 0.01f, 0.07f, 0.83f;
  c.lift = Eigen::Vector3f(0.004f, 0.005f, 0.003f);
  c.blackDrive = Eigen::Vector3f(0.002f, 0.003f, 0.002f);
  c.gainWidth = 16;
  c.gainHeight = 12;
  c.gain.clear();
  for (int j = 0; j < 12; ++j) {
    for (int i = 0; i < 16; ++i) {
      const float dx = (i - 7.5f) / 7.5f, dy = (j - 5.5f) / 5.5f;
      c.gain.push_back(1.0f / (1.0f - 0.2f * (dx * dx + dy * dy) / 2.0f));
    }
  }
  for (auto& channel : c.response) {
    for (int k = 0; k < 256; ++k) channel[static_cast<size_t>(k)] = std::pow(k / 255.0f, 2.3f);
    channel[255] = 1.0f;
  }
  const ModuleEncoder encoder(c, frame.width, frame.height);
  for (auto _ : state) {
    std::vector<std::uint8_t> bytes = encoder.encode(frame);
    benchmark::DoNotOptimize(bytes.data());
  }
  countChannels(state, frame);
}
BENCHMARK(encodeFrameCorrected)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace parallax

BENCHMARK_MAIN();
