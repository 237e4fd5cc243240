#include "daemon/cli/sweep_video.h"

#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>
#include <vector>

#include "common/input_error.h"

namespace parallax::cli {
namespace {

struct Codec {
  const char* name;
  int fourcc;
};

std::vector<Codec> codecsFor(const std::string& extension) {
  const Codec h264{"H.264", cv::VideoWriter::fourcc('a', 'v', 'c', '1')};
  const Codec mpeg4{"MPEG-4 part 2", cv::VideoWriter::fourcc('m', 'p', '4', 'v')};
  if (extension == ".mp4" || extension == ".mkv") return {h264, mpeg4};
  if (extension == ".avi") return {{"Motion JPEG", cv::VideoWriter::fourcc('M', 'J', 'P', 'G')}};
  return {};
}

}  // namespace

SweepVideo::SweepVideo(const std::string& path, int width, int height, double fps,
                       const std::string& option)
    : writer_(std::make_unique<cv::VideoWriter>()), path_(path), width_(width), height_(height) {
  const std::string extension = std::filesystem::path(path).extension().string();
  const std::vector<Codec> codecs = codecsFor(extension);
  if (codecs.empty()) throw InputError({path, option, 0}, "a video must end in .mp4, .mkv or .avi");
  if (!(fps > 0.0 && fps <= 240.0) || width < 2 || height < 2)
    throw InputError({path, option, 0}, fmt::format("{}x{} at {} fps", width, height, fps));
  for (const Codec& codec : codecs) {
    // FFmpeg only: another backend would pick different codecs under the same fourcc.
    if (writer_->open(path, cv::CAP_FFMPEG, codec.fourcc, fps, cv::Size(width, height), true)) {
      codec_ = codec.name;
      return;
    }
  }
  throw InputError({path, option, 0},
                   "no video codec opened (OpenCV's FFmpeg backend could not write this file)");
}

SweepVideo::~SweepVideo() { close(); }

void SweepVideo::add(const Frame& frame) {
  if (frame.width != width_ || frame.height != height_)
    throw std::logic_error(fmt::format("video frame {}x{}, expected {}x{}", frame.width,
                                       frame.height, width_, height_));
  const std::vector<std::uint8_t> rgb = frame.toSrgb8();
  cv::Mat bgr(height_, width_, CV_8UC3);
  for (int y = 0; y < height_; ++y) {
    const std::uint8_t* from = rgb.data() + static_cast<size_t>(y) * width_ * 3;
    auto* to = bgr.ptr<std::uint8_t>(y);
    for (int x = 0; x < width_; ++x) {
      to[3 * x + 0] = from[3 * x + 2];
      to[3 * x + 1] = from[3 * x + 1];
      to[3 * x + 2] = from[3 * x + 0];
    }
  }
  writer_->write(bgr);
  ++frames_;
}

void SweepVideo::close() {
  if (writer_ && writer_->isOpened()) writer_->release();
}

std::pair<double, double> parseRange(const std::string& text, const std::string& option) {
  const size_t colon = text.find(':', text.empty() ? 0 : 1);  // "-0.5:0.5": not the sign
  const auto number = [&](const std::string& part) {
    size_t used = 0;
    double v = 0.0;
    try {
      v = std::stod(part, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != part.size() || !std::isfinite(v))
      throw InputError({"", option, 0}, fmt::format("\"{}\": expected A:B, two numbers", text));
    return v;
  };
  if (colon == std::string::npos)
    throw InputError({"", option, 0}, fmt::format("\"{}\": expected A:B, two numbers", text));
  return {number(text.substr(0, colon)), number(text.substr(colon + 1))};
}

std::string sequenceFrameFolder(const std::string& folder, int frame) {
  return fmt::format("{}/frame_{:04d}", folder, frame);
}

std::vector<std::string> sequenceFrameFolders(const std::string& folder) {
  std::vector<std::string> folders;
  while (
      std::filesystem::is_directory(sequenceFrameFolder(folder, static_cast<int>(folders.size()))))
    folders.push_back(sequenceFrameFolder(folder, static_cast<int>(folders.size())));
  return folders;
}

}  // namespace parallax::cli
