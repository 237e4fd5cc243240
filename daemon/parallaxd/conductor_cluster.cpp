#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>

#include "common/check.h"
#include "common/process_cpu_time.h"
#include "daemon/parallaxd/conductor.h"  // IWYU pragma: associated
#include "daemon/parallaxd/image_message.h"

// The conductor in a cluster (cluster.h): rank 0 tells the other ranks every step it takes —
// a queued request, a turn of the render loop, a config reload, the stop — and they follow,
// each for its own modules. Replies, the verdict on a frame and each rank's state come back to
// rank 0. A rank that does not answer in time ends the job, named with its modules.

namespace parallax::daemon {
namespace {

// Rank 0 waits this long at the stop for the others to finish their frames in flight.
constexpr int kStopTimeoutMs = 5000;

}  // namespace

void Conductor::tellOthers(const nlohmann::json& step) {
  if (!clustered() || !cluster_->isConductor()) return;
  std::string message = step.dump();
  cluster_->broadcast(message);
}

void Conductor::follow() {
  spdlog::info("cluster: {} of {} on {} follows rank 0", ownership_.describe(cluster_->rank()),
               cluster_->size(), cluster_->host());
  while (true) {
    std::string message;
    cluster_->broadcast(message);
    const nlohmann::json step = nlohmann::json::parse(message);
    const std::string kind = step.at("step").get<std::string>();
    if (kind == "stop") {
      cluster_->gather("stopping", kStopTimeoutMs);
      return;
    }
    if (kind == "turn") {
      playTurn(step);
    } else if (kind == "request") {
      // The same request, through the same table and handler as on rank 0.
      nlohmann::json reply;
      try {
        const nlohmann::json& request = step.at("request");
        const RequestSpec* spec = findControlRequest(request.at("request").get<std::string>());
        PARALLAX_CHECK(spec != nullptr);
        const RequestArgs args =
            parseRequestArgs(*spec, request, static_cast<int>(nominal_.modules.size()));
        reply = (this->*handlers().at(spec->name))(args);
      } catch (const std::exception& e) {
        reply = {{"ok", false}, {"error", e.what()}};
      }
      agreeOnReply(std::move(reply));
    } else if (kind == "config") {
      try {
        reloadFromFile(step.at("path").get<std::string>());
      } catch (const std::exception& e) {
        state_.fail(kReloadingConfig, e.what(), state_.state());
      }
    }
    publish();
  }
}

nlohmann::json Conductor::agreeOnReply(nlohmann::json reply) {
  if (!clustered()) return reply;
  const std::vector<std::string> replies =
      cluster_->gather(reply.dump(), options_.config.cluster.timeoutMs);
  if (!cluster_->isConductor() || !reply.value("ok", false)) return reply;
  for (size_t r = 1; r < replies.size(); ++r) {
    const nlohmann::json theirs = nlohmann::json::parse(replies[r]);
    if (!theirs.value("ok", false)) {
      return {{"ok", false},
              {"error", fmt::format("{}: {}", ownership_.describe(static_cast<int>(r)),
                                    theirs.value("error", std::string("refused")))}};
    }
  }
  return reply;
}

nlohmann::json Conductor::rankReport() const {
  return {{"rank", cluster_->rank()},
          {"host", cluster_->host()},
          {"pid", ::getpid()},
          {"modules", owned_},
          {"state", daemonStateName(state_.snapshot().state)},
          {"link",
           {{"health", linkHealthName(link_ ? linkHealth_ : LinkHealth::kDown)},
            {"error", link_ || !linkError_.empty() ? linkError_ : "not connected"},
            {"lagging", lagging_}}},
          {"calibration", hashHex(texturesHash_)},
          {"scene_version", script_ ? script_->version() : 0},
          {"display_frames", stats_.displayFrames},
          {"module_frames_sent", stats_.moduleFramesSent},
          {"module_frames_failed", stats_.moduleFramesFailed},
          {"render_ms", stats_.render.lastMs},
          {"push_ms", stats_.push.lastMs},
          {"work_ms", work_.lastMs},
          {"cpu_ms", processCpuMs()},
          {"timings",
           {{"render", stats_.render.toJson()},
            {"push", stats_.push.toJson()},
            {"present", stats_.present.toJson()},
            {"work", work_.toJson()}}}};
}

void Conductor::gatherRankReports(int timeoutMs) {
  if (!clustered()) return;
  const std::vector<std::string> reports = cluster_->gather(rankReport().dump(), timeoutMs);
  if (!cluster_->isConductor()) return;
  const bool first = rankReports_.empty();
  rankReports_.clear();
  for (const std::string& r : reports) rankReports_.push_back(nlohmann::json::parse(r));
  for (const nlohmann::json& r : rankReports_) {
    const int rank = r.at("rank").get<int>();
    if (first)
      spdlog::info("cluster: {} on {}: link {}", ownership_.describe(rank),
                   r.at("host").get<std::string>(), r.at("link").at("health").get<std::string>());
    // Every rank must trace through the same calibration, or the display is not one picture.
    if (r.at("calibration") != rankReports_.front().at("calibration") && first) {
      state_.fail("starting the cluster",
                  fmt::format("{} plays calibration {} but rank 0 plays {}: install the same "
                              "calibration file on every node",
                              ownership_.describe(rank), r.at("calibration").get<std::string>(),
                              rankReports_.front().at("calibration").get<std::string>()),
                  state_.state());
    }
  }
}

std::vector<std::shared_ptr<const hw::Image>> Conductor::gatherImages(
    const std::vector<int>& modules) {
  std::vector<std::shared_ptr<const hw::Image>> all(nominal_.modules.size());
  std::vector<bool> wanted(nominal_.modules.size(), false);
  for (int m : modules) wanted[static_cast<size_t>(m)] = true;
  std::string mine;
  for (size_t i = 0; i < owned_.size() && i < currentImages_.size(); ++i) {
    const auto m = static_cast<size_t>(owned_[i]);
    if (!wanted[m] || !currentImages_[i]) continue;
    // Rank 0's own images are not copied; the others' travel as bytes.
    if (cluster_->isConductor()) {
      all[m] = currentImages_[i];
    } else {
      appendImageMessage(&mine, owned_[i], *currentImages_[i]);
    }
  }
  if (!clustered()) return all;
  const std::vector<std::string> parts = cluster_->gather(mine, options_.config.cluster.timeoutMs);
  if (!cluster_->isConductor()) return {};
  for (size_t r = 1; r < parts.size(); ++r) {
    for (auto& [module, image] : readImageMessage(parts[r])) {
      PARALLAX_CHECK_OP(ownership_.ownerOf(module), ==, static_cast<int>(r));
      all[static_cast<size_t>(module)] = std::move(image);
    }
  }
  return all;
}

void Conductor::stopOthers() {
  if (!clustered()) return;
  tellOthers({{"step", "stop"}});
  // Waited for even after a signal: the others finish their frames in flight and answer.
  cluster_->setInterrupt({});
  cluster_->gather("stopping", kStopTimeoutMs);
}

void Conductor::endJob(const RanksSilent& e) {
  std::vector<std::string> ranks;
  for (int r : e.ranks()) ranks.push_back(ownership_.describe(r));
  clusterFailure_ = fmt::format("cluster: {} did not answer ({}): it died or hangs; ending the job",
                                fmt::join(ranks, ", "), e.what());
  spdlog::critical("{}", clusterFailure_);
  state_.fail("running the cluster", clusterFailure_, DaemonState::kError);
  publish();
}

std::vector<int> Conductor::laggingModules() const {
  if (!clustered()) return lagging_;
  std::vector<int> all;
  for (const nlohmann::json& r : rankReports_) {
    for (int m : r.at("link").value("lagging", std::vector<int>{})) all.push_back(m);
  }
  std::sort(all.begin(), all.end());
  return all;
}

nlohmann::json Conductor::clusterJson() const {
  nlohmann::json ranks = nlohmann::json::array();
  for (const nlohmann::json& r : rankReports_) ranks.push_back(r);
  return {{"ranks", cluster_->size()},
          {"rank", ranks},
          {"sync_ms",
           {{"tell", tellTiming_.toJson()},
            {"agree", agreeTiming_.toJson()},
            {"report", reportTiming_.toJson()},
            {"overhead", overheadTiming_.toJson()},
            {"idle_turn", idleSyncTiming_.toJson()}}}};
}

}  // namespace parallax::daemon
