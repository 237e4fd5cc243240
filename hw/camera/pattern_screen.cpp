#include "hw/camera/pattern_screen.h"

#include <fmt/format.h>

#include "common/check.h"

namespace parallax::hw {

std::vector<std::string> showOnLink(LinkClient& link,
                                    const std::vector<std::shared_ptr<const Image>>& frames,
                                    const std::vector<int>& names) {
  PARALLAX_CHECK_OP(frames.size(), ==, names.size());
  for (size_t m = 0; m < frames.size(); ++m) link.submit(static_cast<int>(m), frames[m]);
  link.flush();
  std::vector<std::string> failures;
  for (const FrameOutcome& o : link.takeOutcomes()) {
    if (o.status == FrameStatus::kDelivered || o.status == FrameStatus::kSkippedUnchanged) continue;
    const int name = o.module >= 0 && o.module < static_cast<int>(names.size())
                         ? names[static_cast<size_t>(o.module)]
                         : o.module;
    failures.push_back(fmt::format("module {} did not show it ({}: {})", name,
                                   frameStatusName(o.status), o.reason));
  }
  return failures;
}

void LinkPatternScreen::show(const std::vector<std::shared_ptr<const Image>>& frames,
                             const std::string& what) {
  std::vector<int> names(frames.size());
  for (size_t m = 0; m < names.size(); ++m) names[m] = static_cast<int>(m);
  const std::vector<std::string> failures = showOnLink(link_, frames, names);
  if (!failures.empty()) throw std::runtime_error(fmt::format("{}: {}", what, failures.front()));
}

void LinkPatternScreen::end() noexcept {
  try {
    link_.flush();
    link_.takeOutcomes();
    link_.setMode(DisplayMode::kPlayback);
  } catch (...) {  // a dead link: nothing more can be done from here
  }
}

}  // namespace parallax::hw
