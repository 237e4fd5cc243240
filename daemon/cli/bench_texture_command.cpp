// parallax bench textures [--lookups N] [--footprint TEXELS]
// OpenImageIO's TextureSystem against our own mip pyramid (built with ImageBufAlgo) and
// trilinear lookup (tracer/texture_image.h), on the same coherent lookups with the same
// footprint: ms for N lookups on all cores, and how far apart their colours are. The tracer
// keeps the faster of the two when they agree. Figures only.

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/texture.h>
#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <iostream>
#include <memory>
#include <thread>

#include "common/input_error.h"
#include "common/process_cpu_time.h"
#include "daemon/cli/commands.h"
#include "tracer/texture_image.h"

namespace parallax::cli {
namespace {

struct BenchTextureArgs {
  int lookups = 400000;
  double footprint = 1.5;  // texels covered by one lookup
  int size = 1024;
};

// A linear-light test image with detail at every scale (so mip levels differ).
std::vector<float> testImage(int size) {
  std::vector<float> rgb(static_cast<size_t>(size) * static_cast<size_t>(size) * 3);
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      const float fx = static_cast<float>(x) / static_cast<float>(size),
                  fy = static_cast<float>(y) / static_cast<float>(size);
      const bool check = ((x / 8) + (y / 8)) % 2 == 0;
      float* p =
          &rgb[(static_cast<size_t>(y) * static_cast<size_t>(size) + static_cast<size_t>(x)) * 3];
      p[0] = 0.5f + 0.5f * std::sin(40.0f * fx) * (check ? 1.0f : 0.6f);
      p[1] = fy * (check ? 0.9f : 0.3f);
      p[2] = 0.5f + 0.4f * std::cos(25.0f * (fx + fy));
    }
  }
  return rgb;
}

void runBenchTextures(const BenchTextureArgs& args) {
  if (args.lookups < 1000 || args.lookups > 100000000)
    throw InputError({"", "--lookups", 0}, "must be in 1000..1e8");
  if (!(args.footprint > 0.0) || args.footprint > 1024.0)
    throw InputError({"", "--footprint", 0}, "must be in (0, 1024]");
  const int size = args.size;
  const std::vector<float> rgb = testImage(size);
  const std::string path = (std::filesystem::temp_directory_path() /
                            fmt::format("parallax_bench_texture_{}.exr", ::getpid()))
                               .string();
  {
    OIIO::ImageBuf image(OIIO::ImageSpec(size, size, 3, OIIO::TypeDesc::FLOAT),
                         const_cast<float*>(rgb.data()));
    if (!image.write(path))
      throw InputError({path, "", 0}, "cannot write the test texture: " + image.geterror());
  }

  // Coherent lookups: a grid of uv positions one footprint apart, row after row.
  const int columns = static_cast<int>(std::sqrt(static_cast<double>(args.lookups)));
  const int rows = (args.lookups + columns - 1) / columns;
  const float step = static_cast<float>(args.footprint) / static_cast<float>(size);
  const float lod = static_cast<float>(std::log2(args.footprint));
  const size_t n = static_cast<size_t>(rows) * static_cast<size_t>(columns);
  std::vector<float> ours(n * 3), theirs(n * 3);

  const auto ourStart = std::chrono::steady_clock::now();
  const TextureImage image(size, size, rgb);  // pyramid build included: it is part of the cost
  const double buildMs =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - ourStart)
          .count();
  double cpu0 = processCpuMs();
  auto start = std::chrono::steady_clock::now();
  tbb::parallel_for(tbb::blocked_range<int>(0, rows), [&](const tbb::blocked_range<int>& r) {
    for (int j = r.begin(); j < r.end(); ++j) {
      for (int i = 0; i < columns; ++i) {
        const float u = 0.01f + static_cast<float>(i) * step,
                    v = 0.99f - static_cast<float>(j) * step;
        const Rgb c = image.lookup(u, v, lod);
        float* out =
            &ours[(static_cast<size_t>(j) * static_cast<size_t>(columns) + static_cast<size_t>(i)) *
                  3];
        out[0] = c.x(), out[1] = c.y(), out[2] = c.z();
      }
    }
  });
  const double ourMs =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  const double ourCpu = processCpuMs() - cpu0;

  OIIO::TextureSystem* ts = OIIO::TextureSystem::create(false);
  ts->attribute("automip", 1);
  const OIIO::ustring name(path);
  OIIO::TextureSystem::TextureHandle* handle = ts->get_texture_handle(name);
  // Warm the cache (file read + automatic mip generation) outside the timed lookups, as a
  // renderer would on its first frame.
  {
    OIIO::TextureOpt opt;
    float warm[3];
    const auto warmStart = std::chrono::steady_clock::now();
    ts->texture(handle, ts->get_perthread_info(), opt, 0.5f, 0.5f, step, 0, 0, step, 3, warm);
    std::cout << fmt::format(
        "OIIO first lookup (file read + automip): {:.1f} ms; our pyramid build: {:.1f} ms\n",
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - warmStart)
            .count(),
        buildMs);
  }
  cpu0 = processCpuMs();
  start = std::chrono::steady_clock::now();
  tbb::parallel_for(tbb::blocked_range<int>(0, rows), [&](const tbb::blocked_range<int>& r) {
    OIIO::TextureSystem::Perthread* thread = ts->get_perthread_info();
    OIIO::TextureOpt opt;
    opt.mipmode = OIIO::TextureOpt::MipModeTrilinear;
    opt.interpmode = OIIO::TextureOpt::InterpBilinear;
    opt.swrap = opt.twrap = OIIO::TextureOpt::WrapPeriodic;
    for (int j = r.begin(); j < r.end(); ++j) {
      for (int i = 0; i < columns; ++i) {
        const float u = 0.01f + static_cast<float>(i) * step,
                    v = 0.99f - static_cast<float>(j) * step;
        float* out = &theirs[(static_cast<size_t>(j) * static_cast<size_t>(columns) +
                              static_cast<size_t>(i)) *
                             3];
        // OIIO's t runs down from the top row; ours (v) up from the bottom.
        ts->texture(handle, thread, opt, u, 1.0f - v, step, 0.0f, 0.0f, step, 3, out);
      }
    }
  });
  const double oiioMs =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  const double oiioCpu = processCpuMs() - cpu0;
  OIIO::TextureSystem::destroy(ts);
  std::filesystem::remove(path);

  double sum = 0.0, worst = 0.0;
  for (size_t k = 0; k < ours.size(); ++k) {
    const double d = std::abs(static_cast<double>(ours[k]) - static_cast<double>(theirs[k]));
    sum += d;
    worst = std::max(worst, d);
  }
  std::cout << fmt::format(
      "{} coherent lookups of a {}x{} RGB float texture, footprint {:.2f} texels (lod {:.2f}), "
      "{} threads:\n",
      n, size, size, args.footprint, lod, std::thread::hardware_concurrency());
  std::cout << fmt::format(
      "  OIIO TextureSystem (trilinear, bilinear in a level): {:7.1f} ms wall, {:7.1f} ms CPU "
      "({:.1f} M lookups per CPU-second)\n",
      oiioMs, oiioCpu, static_cast<double>(n) / (oiioCpu * 1e3));
  std::cout << fmt::format(
      "  own pyramid + trilinear lookup:                      {:7.1f} ms wall, {:7.1f} ms CPU "
      "({:.1f} M lookups per CPU-second)\n",
      ourMs, ourCpu, static_cast<double>(n) / (ourCpu * 1e3));
  std::cout << fmt::format(
      "  agreement: mean |difference| {:.4f}, max {:.4f} (colour values 0..1)\n",
      sum / static_cast<double>(ours.size()), worst);
  std::cout << "(wall-clock on a shared machine: noisy)\n";
}

}  // namespace

void addBenchTextureSubcommand(CLI::App* bench) {
  auto args = std::make_shared<BenchTextureArgs>();
  CLI::App* command = bench->add_subcommand(
      "textures", "OIIO TextureSystem vs our mip pyramid: speed and agreement");
  command->add_option("--lookups", args->lookups, "number of lookups");
  command->add_option("--footprint", args->footprint, "texels covered by one lookup");
  command->callback([args] { runBenchTextures(*args); });
}

}  // namespace parallax::cli
