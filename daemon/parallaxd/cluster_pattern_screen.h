#pragma once
// Rank 0's screen for a calibration across the ranks of a cluster (issue 23): the capture
// session (hw/camera/calibration_capture.h) runs on rank 0 with its camera, and each of its
// requests — the modules, a mode, a pattern on every module — is a step that every rank takes
// for the modules its link reaches (Conductor::calibrationStep). The patterns travel once per
// distinct image (a group's pattern and the dark frame), with which module shows which.

#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "hw/camera/pattern_screen.h"

namespace parallax::daemon {

class ClusterPatternScreen final : public hw::PatternScreen {
 public:
  // Runs `op` (with `payload`) on every rank and returns each rank's answer in rank order;
  // throws std::runtime_error naming the first rank that failed.
  using Step = std::function<std::vector<nlohmann::json>(const nlohmann::json& op,
                                                         const std::string& payload)>;
  explicit ClusterPatternScreen(Step step) : step_(std::move(step)) {}

  std::vector<hw::ModuleLinkInfo> modules() override;
  bool setMode(hw::DisplayMode mode) override;
  void show(const std::vector<std::shared_ptr<const hw::Image>>& frames,
            const std::string& what) override;
  void end() noexcept override;

 private:
  Step step_;
};

// A rank's side of the steps above, on its own link (`owned[i]`: the display index of the
// link's module i). Each returns the rank's answer: {"ok": true, ...} or {"ok": false, "error"}.
nlohmann::json linkModulesAnswer(const hw::LinkClient& link, const std::vector<int>& owned);
nlohmann::json showPatternsAnswer(hw::LinkClient& link, const std::vector<int>& owned,
                                  const nlohmann::json& op, const std::string& payload);

}  // namespace parallax::daemon
