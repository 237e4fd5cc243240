#include "hw/simulator/shared_room.h"

#include <fmt/format.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>

#include "common/check.h"
#include "hw/simulator/simulated_hardware.h"

namespace parallax::hw {
namespace {

// A room file: this header, then the pixels.
struct RoomFileHeader {
  char magic[4] = {'P', 'X', 'R', 'M'};
  int32_t width = 0, height = 0, format = 0;
  uint64_t bytes = 0;
};

}  // namespace

SharedRoom::SharedRoom(std::string folder, std::vector<int> own)
    : folder_(std::move(folder)), own_(std::move(own)), written_(own_.size(), 0) {
  if (folder_.empty()) return;  // no room: the other modules are dark to this camera
  std::filesystem::create_directories(folder_);
  removeOwn();  // a simulator restarted after a crash: its old files are not what it shows
}

std::string SharedRoom::pathOf(int module) const {
  return fmt::format("{}/module_{:03d}.frame", folder_, module);
}

void SharedRoom::removeOwn() {
  for (size_t i = 0; i < own_.size(); ++i) {
    std::error_code ignored;
    std::filesystem::remove(pathOf(own_[i]), ignored);
    written_[i] = 0;
  }
}

void SharedRoom::update(const SimulatedHardware& hardware) {
  PARALLAX_CHECK_OP(hardware.moduleCount(), ==, static_cast<int>(own_.size()));
  if (folder_.empty()) return;
  const bool pattern = hardware.mode() == DisplayMode::kPattern;
  if (!pattern) {
    if (pattern_) removeOwn();
    pattern_ = false;
    return;
  }
  const bool entering = !pattern_;
  pattern_ = true;
  for (size_t i = 0; i < own_.size(); ++i) {
    const int m = static_cast<int>(i);
    const uint64_t hash = hardware.shownContentHash(m);
    if (!entering && hash == written_[i] && hash != 0) continue;
    const Image& shown = hardware.shownFrame(m);
    RoomFileHeader h;
    h.width = shown.width;
    h.height = shown.height;
    h.format = static_cast<int32_t>(shown.format);
    h.bytes = shown.pixels.size();
    // Written beside the file and renamed over it: a reader sees the old frame or the new one.
    const std::string path = pathOf(own_[i]);
    const std::string temporary = fmt::format("{}.{}.tmp", path, ::getpid());
    {
      std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
      out.write(reinterpret_cast<const char*>(&h), sizeof h);
      out.write(reinterpret_cast<const char*>(shown.pixels.data()),
                static_cast<std::streamsize>(shown.pixels.size()));
      if (!out) continue;  // a full disk: that module's light is missing from the others' pictures
    }
    std::error_code failed;
    std::filesystem::rename(temporary, path, failed);
    written_[i] = failed ? 0 : hash;
  }
}

Image SharedRoom::read(int module) const {
  if (folder_.empty()) return {};
  std::ifstream in(pathOf(module), std::ios::binary);
  RoomFileHeader h;
  if (!in.read(reinterpret_cast<char*>(&h), sizeof h)) return {};
  if (std::memcmp(h.magic, "PXRM", 4) != 0 || h.width <= 0 || h.height <= 0) return {};
  Image image;
  image.width = h.width;
  image.height = h.height;
  image.format = static_cast<PixelFormat>(h.format);
  if (h.bytes != image.byteSize()) return {};
  image.pixels.resize(h.bytes);
  if (!in.read(reinterpret_cast<char*>(image.pixels.data()), static_cast<std::streamsize>(h.bytes)))
    return {};
  return image;
}

RoomPhysics::RoomPhysics(std::unique_ptr<CameraPhysics> display, int displayModules,
                         std::shared_ptr<const SharedRoom> room)
    : display_(std::move(display)), displayModules_(displayModules), room_(std::move(room)) {}

Image RoomPhysics::render(std::span<const Image* const> frames, int viewModule, int station,
                          const CameraSettings& settings) const {
  const std::vector<int>& own = room_->own();
  PARALLAX_CHECK_OP(frames.size(), ==, own.size());
  std::vector<const Image*> all(static_cast<size_t>(displayModules_), nullptr);
  std::vector<bool> mine(all.size(), false);
  for (size_t i = 0; i < own.size(); ++i) {
    all[static_cast<size_t>(own[i])] = frames[i];
    mine[static_cast<size_t>(own[i])] = true;
  }
  std::vector<Image> others(all.size());
  for (size_t m = 0; m < all.size(); ++m) {
    if (mine[m]) continue;
    others[m] = room_->read(static_cast<int>(m));
    if (!others[m].empty()) all[m] = &others[m];
  }
  return display_->render(all, viewModule, station, settings);
}

}  // namespace parallax::hw
