#pragma once
// What a calibration session shows its patterns on: every module of the display, by display
// index, shown outside the swap lock (at once). One link reaches every module (LinkPatternScreen);
// in a cluster (issue 23) each rank's link reaches some, and rank 0's screen asks the owners to
// show theirs (daemon/parallaxd/cluster_pattern_screen.h). The session (calibration_capture.h)
// does not know which.

#include <memory>
#include <string>
#include <vector>

#include "hw/link/image.h"
#include "hw/link/link_client.h"

namespace parallax::hw {

class PatternScreen {
 public:
  virtual ~PatternScreen() = default;
  // Every module of the display in display order: `module` is its display index, `info` its
  // size and pixel formats.
  virtual std::vector<ModuleLinkInfo> modules() = 0;
  // Every module in pattern (or playback) mode; false when one did not switch.
  virtual bool setMode(DisplayMode mode) = 0;
  // Module m shows frames[m] (one a module) once this returns; throws std::runtime_error naming
  // `what`, the module and why when one did not get it.
  virtual void show(const std::vector<std::shared_ptr<const Image>>& frames,
                    const std::string& what) = 0;
  // The session is over (completed, cancelled or failed): every module back in playback mode.
  // Never throws: a dead link can do nothing more.
  virtual void end() noexcept = 0;
};

// One link that reaches every module of the display.
class LinkPatternScreen final : public PatternScreen {
 public:
  explicit LinkPatternScreen(LinkClient& link) : link_(link) {}
  std::vector<ModuleLinkInfo> modules() override { return link_.modules(); }
  bool setMode(DisplayMode mode) override { return link_.setMode(mode); }
  void show(const std::vector<std::shared_ptr<const Image>>& frames,
            const std::string& what) override;
  void end() noexcept override;

 private:
  LinkClient& link_;
};

// Submits frames[i] to the link's module i, waits for every one and returns why those that
// failed did ("module 3 did not show it (rejected: ...)"), empty when every module shows its
// frame. `names[i]` is what module i is called in the message (its display index).
std::vector<std::string> showOnLink(LinkClient& link,
                                    const std::vector<std::shared_ptr<const Image>>& frames,
                                    const std::vector<int>& names);

}  // namespace parallax::hw
