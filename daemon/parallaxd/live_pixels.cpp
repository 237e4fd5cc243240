#include "daemon/parallaxd/live_pixels.h"

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstring>
#include <stdexcept>

#include "common/check.h"

namespace parallax::daemon {
namespace {

// The first box's margin, a fraction of its diagonal on every side: bounds that breathe a
// little (an object turning) stay inside it.
constexpr float kFirstMargin = 0.02f;
constexpr float kMaxMargin = 1.0f;

// What a full frame holds outside the footprint: black where masked, else the background.
Frame backdropFrame(const RayTextures& textures, const SceneFootprint& footprint,
                    const Rgb& background) {
  Frame frame(textures.width(), textures.height());
  for (int y = 0; y < frame.height; ++y) {
    const FootprintRow& row = footprint.row(y);
    for (int x = 0; x < frame.width; ++x) {
      const bool outside = x < row.begin || x >= row.end;
      frame.at(x, y) = outside && !textures.at(x, y).masked() ? background : Rgb::Zero();
    }
  }
  return frame;
}

// The footprint's bytes, row by row: the images of one build differ nowhere else. A family
// number no other build (of any LivePixels) has.
std::shared_ptr<const hw::ImageRegions> regionsOf(const SceneFootprint& footprint) {
  static std::atomic<std::uint64_t> families{0};
  auto regions = std::make_shared<hw::ImageRegions>();
  regions->family = ++families;
  const auto rowBytes = static_cast<std::uint32_t>(footprint.width()) * 3;
  for (int y = 0; y < footprint.height(); ++y) {
    const FootprintRow& row = footprint.row(y);
    if (row.begin >= row.end) continue;
    const std::uint32_t start = static_cast<std::uint32_t>(y) * rowBytes;
    regions->spans.push_back({start + 3 * static_cast<std::uint32_t>(row.begin),
                              start + 3 * static_cast<std::uint32_t>(row.end)});
  }
  return regions;
}

}  // namespace

std::string LivePixelsStats::line() const {
  if (builds == 0) return "  live pixels: none made (not an animated scene yet)";
  return fmt::format(
      "  live pixels: {} of {} ({:.0f}%) inside the scene's footprint, the rest from the "
      "backdrop ({:.1f} MiB); module images {} recycled with the backdrop in place, {} new; {} "
      "build(s), the last {:.0f} ms",
      livePixels, pixels, pixels > 0 ? 100.0 * static_cast<double>(livePixels) / pixels : 0.0,
      static_cast<double>(backdropBytes) / (1 << 20), recycledImages, newImages, builds,
      lastBuildMs);
}

LivePixelsStats LivePixels::stats() const {
  LivePixelsStats stats = stats_;
  stats.recycledImages = recycledBefore_;
  stats.newImages = newBefore_;
  for (const Module& m : modules_) {
    stats.recycledImages += m.recycled;
    stats.newImages += m.made;
  }
  return stats;
}

void LivePixels::prepare(const PhysicalScene& scene, const std::vector<RayTextures>& textures,
                         std::uint64_t texturesVersion, const std::vector<ModuleEncoder>& encoders,
                         std::uint64_t encodersVersion) {
  if (!encoders.empty() && encoders.size() != textures.size())
    throw std::invalid_argument("LivePixels: one encoder a module, or none");
  if (textures.empty()) {
    clear();
    return;
  }
  const Eigen::Vector3f& lo = scene.boundsMin();
  const Eigen::Vector3f& hi = scene.boundsMax();
  // Every module's footprint is made for the same box.
  const bool sameInputs = modules_.size() == textures.size() &&
                          texturesVersion == texturesVersion_ &&
                          encodersVersion == encodersVersion_ && scene.background() == background_;
  if (sameInputs && modules_.front().footprint.holds(lo, hi)) return;
  const auto started = std::chrono::steady_clock::now();
  Eigen::Vector3f boxMin = lo, boxMax = hi;
  if (sameInputs) {
    // The bounds left the box: a bigger one around both, with more room.
    boxMin = boxMin.cwiseMin(modules_.front().footprint.boxMin());
    boxMax = boxMax.cwiseMax(modules_.front().footprint.boxMax());
    margin_ = std::min(kMaxMargin, 2.0f * margin_);
  } else {
    margin_ = kFirstMargin;
  }
  const float pad = margin_ * (boxMax - boxMin).norm();
  boxMin -= Eigen::Vector3f::Constant(pad);
  boxMax += Eigen::Vector3f::Constant(pad);
  texturesVersion_ = texturesVersion;
  encodersVersion_ = encodersVersion;
  background_ = scene.background();
  forget(textures.size());
  tbb::parallel_for(size_t{0}, textures.size(), [&](size_t i) {
    Module& m = modules_[i];
    m.footprint = SceneFootprint(textures[i], boxMin, boxMax);
    const Frame frame = backdropFrame(textures[i], m.footprint, background_);
    m.backdrop = encoders.empty() ? frame.toSrgb8() : encoders[i].encode(frame);
    m.regions = regionsOf(m.footprint);
  });
  ++stats_.builds;
  stats_.lastBuildMs =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started).count();
  stats_.livePixels = stats_.pixels = 0;
  stats_.backdropBytes = 0;
  for (const Module& m : modules_) {
    stats_.livePixels += m.footprint.livePixels();
    stats_.pixels += m.footprint.pixels();
    stats_.backdropBytes += m.backdrop.size();
  }
}

std::shared_ptr<hw::Image> LivePixels::startImage(std::size_t module) const {
  const Module& m = modules_.at(module);
  // The conductor holds the frame on show and the link may still hold the one before.
  constexpr size_t kRecent = 3;
  for (const std::shared_ptr<hw::Image>& old : m.recent) {
    // Only this list holds it, so no other thread can take a new reference to it either. It was
    // made from this footprint's backdrop (`recent` starts empty at every build) and since then
    // written inside the footprint only (encodeTile; images leave here as const): outside it,
    // it still holds the backdrop, and every pixel inside is written again. No copy.
    if (old.use_count() == 1 && old->pixels.size() == m.backdrop.size()) {
      ++m.recycled;
      return old;
    }
  }
  ++m.made;
  auto image = std::make_shared<hw::Image>();
  if (m.recent.size() < kRecent) m.recent.push_back(image);
  image->width = m.footprint.width();
  image->height = m.footprint.height();
  image->format = hw::PixelFormat::kRgb8;
  image->pixels = m.backdrop;
  image->regions = m.regions;
  return image;
}

void LivePixels::encodeTile(std::size_t module, const Frame& frame, const ModuleEncoder* encoder,
                            int x0, int x1, int y0, int y1, hw::Image* image) const {
  const Module& m = modules_.at(module);
  PARALLAX_CHECK_OP(frame.width, ==, m.footprint.width());
  PARALLAX_CHECK_OP(frame.height, ==, m.footprint.height());
  PARALLAX_CHECK_OP(image->pixels.size(), ==, m.backdrop.size());
  const size_t rowBytes = static_cast<size_t>(frame.width) * 3;
  for (int y = y0; y < y1; ++y) {
    const FootprintRow& row = m.footprint.row(y);
    const int begin = std::max(row.begin, x0), end = std::min(row.end, x1);
    if (begin >= end) continue;
    std::uint8_t* bytes = image->pixels.data() + static_cast<size_t>(y) * rowBytes;
    if (encoder) {
      encoder->encodeRow(frame, y, begin, end, bytes);
    } else {
      encodeSrgb8(&frame.at(begin, y), static_cast<size_t>(end - begin),
                  bytes + 3 * static_cast<size_t>(begin));
    }
  }
}

void LivePixels::forget(std::size_t modules) {
  for (const Module& m : modules_) {
    recycledBefore_ += m.recycled;
    newBefore_ += m.made;
  }
  modules_.assign(modules, Module{});
}

void LivePixels::clear() {
  forget(0);
  texturesVersion_ = encodersVersion_ = 0;
  margin_ = 0.0f;
}

}  // namespace parallax::daemon
