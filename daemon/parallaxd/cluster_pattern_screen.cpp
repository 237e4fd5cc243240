#include "daemon/parallaxd/cluster_pattern_screen.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <map>

#include "common/check.h"
#include "daemon/parallaxd/image_message.h"

namespace parallax::daemon {

std::vector<hw::ModuleLinkInfo> ClusterPatternScreen::modules() {
  std::vector<hw::ModuleLinkInfo> all;
  for (const nlohmann::json& answer : step_({{"op", "modules"}}, "")) {
    for (const nlohmann::json& m : answer.at("modules")) {
      hw::ModuleLinkInfo info;
      info.module = m.at("module").get<int>();
      info.info.width = m.at("width").get<uint32_t>();
      info.info.height = m.at("height").get<uint32_t>();
      info.info.pixelFormats = m.at("pixel_formats").get<uint32_t>();
      all.push_back(info);
    }
  }
  std::sort(all.begin(), all.end(),
            [](const auto& a, const auto& b) { return a.module < b.module; });
  return all;
}

bool ClusterPatternScreen::setMode(hw::DisplayMode mode) {
  step_({{"op", "mode"}, {"pattern", mode == hw::DisplayMode::kPattern}}, "");
  return true;  // a rank whose modules did not switch has thrown, named
}

void ClusterPatternScreen::show(const std::vector<std::shared_ptr<const hw::Image>>& frames,
                                const std::string& what) {
  // Each distinct image once (a group's pattern, the dark frame), and which module shows which.
  std::map<const hw::Image*, int> number;
  std::string payload;
  std::vector<int> imageOf;
  for (const auto& frame : frames) {
    PARALLAX_CHECK(frame != nullptr);
    auto [it, added] = number.emplace(frame.get(), static_cast<int>(number.size()));
    if (added) appendImageMessage(&payload, it->second, *frame);
    imageOf.push_back(it->second);
  }
  step_({{"op", "show"}, {"what", what}, {"image_of", imageOf}}, payload);
}

void ClusterPatternScreen::end() noexcept {
  try {
    step_({{"op", "end"}}, "");
  } catch (...) {  // a rank that cannot go back to playback: its link is down or the job ends
  }
}

nlohmann::json linkModulesAnswer(const hw::LinkClient& link, const std::vector<int>& owned) {
  nlohmann::json modules = nlohmann::json::array();
  const auto& onLink = link.modules();
  if (onLink.size() != owned.size()) {
    return {
        {"ok", false},
        {"error", fmt::format("its link has {} modules, it owns {}", onLink.size(), owned.size())}};
  }
  for (size_t i = 0; i < onLink.size(); ++i) {
    modules.push_back({{"module", owned[i]},
                       {"width", onLink[i].info.width},
                       {"height", onLink[i].info.height},
                       {"pixel_formats", onLink[i].info.pixelFormats}});
  }
  return {{"ok", true}, {"modules", modules}};
}

nlohmann::json showPatternsAnswer(hw::LinkClient& link, const std::vector<int>& owned,
                                  const nlohmann::json& op, const std::string& payload) {
  const std::vector<int> imageOf = op.at("image_of").get<std::vector<int>>();
  std::vector<std::shared_ptr<const hw::Image>> images;
  for (auto& [id, image] : readImageMessage(payload)) {
    PARALLAX_CHECK_OP(id, ==, static_cast<int>(images.size()));
    images.push_back(std::move(image));
  }
  std::vector<std::shared_ptr<const hw::Image>> mine;
  for (int m : owned) {
    const int image = imageOf.at(static_cast<size_t>(m));
    mine.push_back(images.at(static_cast<size_t>(image)));
  }
  const std::vector<std::string> failures = hw::showOnLink(link, mine, owned);
  if (failures.empty()) return {{"ok", true}};
  return {{"ok", false},
          {"error",
           fmt::format("{}: {}", op.at("what").get<std::string>(), fmt::join(failures, "; "))}};
}

}  // namespace parallax::daemon
