#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "calibration/display/display_model_json.h"
#include "common/check.h"
#include "daemon/parallaxd/cluster_pattern_screen.h"
#include "daemon/parallaxd/conductor.h"  // IWYU pragma: associated

// `calibrate` and `rollback` across the ranks of a cluster (issue 23). Rank 0 drives; every
// rank takes each step for its own modules, link and files, and answers:
//   modules, mode, show, end   the capture session's patterns (cluster_pattern_screen.h)
//   begin     the calibration to install, as its file's bytes and its content hash (checked)
//   files     one rank at a time: install it (rollback: roll its files back, to the same hash
//             as rank 0's); ranks of one machine may share one file, which the later ones then
//             find written and leave alone
//   textures  the ray textures of the rank's modules for it; the old ones are kept aside
//   undo      a step failed somewhere: files put back byte for byte where they were written
//             (.previous too: a later rollback goes where it would have), old textures back, so
//             every rank stays on the last good calibration
//   commit    every step succeeded on every rank: it is the one in use everywhere
//   done      the other ranks go back to following rank 0
// A rank that dies or hangs meanwhile ends the job (as at any moment): nothing half done plays.

namespace parallax::daemon {

std::vector<nlohmann::json> Conductor::calibrationStep(const nlohmann::json& op,
                                                       const std::string& payload, int timeoutMs) {
  std::string message = op.dump() + '\n' + payload;
  cluster_->broadcast(message);
  if (op.at("op") == "done") return {};
  // Rank 0's own part while the others do theirs.
  const nlohmann::json mine = takeCalibrationStep(op, payload);
  const std::vector<std::string> replies =
      cluster_->gather(mine.dump(), timeoutMs > 0 ? timeoutMs : options_.config.cluster.timeoutMs);
  std::vector<nlohmann::json> answers;
  for (size_t r = 0; r < replies.size(); ++r) {
    answers.push_back(nlohmann::json::parse(replies[r]));
    if (!answers.back().value("ok", false)) {
      throw std::runtime_error(fmt::format("{}: {}", ownership_.describe(static_cast<int>(r)),
                                           answers.back().value("error", std::string("refused"))));
    }
  }
  return answers;
}

void Conductor::calibrateCluster() {
  spdlog::info("cluster: no installed calibration: calibrating across the ranks");
  const nlohmann::json request = {{"request", "calibrate"}};
  tellOthers({{"step", "request"}, {"request", request}});
  nlohmann::json reply;
  try {
    reply = answerCalibrate(parseRequestArgs(*findControlRequest("calibrate"), request,
                                             static_cast<int>(nominal_.modules.size())));
  } catch (const RanksSilent&) {
    throw;
  } catch (const std::exception& e) {
    reply = {{"ok", false}, {"error", e.what()}};
  }
  reply = agreeOnReply(std::move(reply));
  // A failure is in `status` already (the calibrating stage); the nominal display plays on.
  if (!reply.value("ok", false))
    spdlog::error("cluster: calibrating at start failed: {}",
                  reply.value("error", std::string("refused")));
  publish();
}

nlohmann::json Conductor::followCalibration() {
  while (true) {
    std::string message;
    cluster_->broadcast(message);
    const size_t newline = message.find('\n');
    const nlohmann::json op = nlohmann::json::parse(message.substr(0, newline));
    if (op.at("op") == "done") return {{"ok", true}, {"hash", hashHex(texturesHash_)}};
    const std::string payload = newline == std::string::npos ? "" : message.substr(newline + 1);
    cluster_->gather(takeCalibrationStep(op, payload).dump(), options_.config.cluster.timeoutMs);
  }
}

void Conductor::finishCalibrationSteps() {
  if (!clustered() || !cluster_->isConductor()) return;
  try {
    calibrationStep({{"op", "done"}});
  } catch (const std::exception& e) {  // a rank gone: the reply's gather names it
    spdlog::warn("cluster: ending the calibration steps: {}", e.what());
  }
}

nlohmann::json Conductor::takeCalibrationStep(const nlohmann::json& op,
                                              const std::string& payload) {
  const std::string kind = op.at("op").get<std::string>();
  const auto failed = [](const std::string& why) {
    return nlohmann::json{{"ok", false}, {"error", why}};
  };
  try {
    if (kind == "modules" || kind == "mode" || kind == "show") {
      if (!link_) return failed("no link to its modules: " + linkError_);
      if (kind == "modules") return linkModulesAnswer(*link_, owned_);
      if (kind == "show") return showPatternsAnswer(*link_, owned_, op, payload);
      const bool pattern = op.at("pattern").get<bool>();
      if (!link_->setMode(pattern ? hw::DisplayMode::kPattern : hw::DisplayMode::kPlayback))
        return failed(
            fmt::format("its modules did not switch to {} mode", pattern ? "pattern" : "playback"));
      return {{"ok", true}};
    }
    if (kind == "end") {
      if (link_) hw::LinkPatternScreen(*link_).end();
      return {{"ok", true}};
    }
    if (kind == "begin") {
      pending_ = PendingCalibration{};  // (emplace() needs a complete Conductor for clang)
      if (op.at("action") == "install") {
        // The file rank 0 fitted, byte for byte, and checked against its hash.
        DisplayModel model = displayModelFromJson(nlohmann::json::parse(payload));
        const std::string hash = hashHex(displayContentHash(model));
        if (hash != op.at("hash"))
          return failed(fmt::format("the calibration it received hashes to {}, rank 0 sent {}",
                                    hash, op.at("hash").get<std::string>()));
        CalibrationStore::requireSameDisplay(nominal_, model, "the calibration from rank 0");
        pending_->model = std::move(model);
      }
      return {{"ok", true}};
    }
    PARALLAX_CHECK(pending_.has_value());
    if (kind == "files") {
      if (op.at("rank").get<int>() != cluster_->rank()) return {{"ok", true}};
      return takeFilesStep(op);
    }
    if (kind == "textures") {
      pending_->oldTextures = std::move(textures_);
      pending_->oldTexturesHash = texturesHash_;
      pending_->texturesMade = true;
      const StageResult made = regenerate(pending_->model);
      if (!made.done()) return failed("its ray textures: " + made.error);
      return {{"ok", true}};
    }
    if (kind == "undo") {
      std::vector<std::string> problems;
      if (pending_->filesBefore) {
        try {
          // Not a rollback: that would keep the undone calibration as .previous.
          store_.restore(*pending_->filesBefore);
          spdlog::warn("cluster calibration undone: {} and its .previous are as before",
                       store_.path());
        } catch (const std::exception& e) {
          problems.push_back(e.what());
        }
      }
      if (pending_->texturesMade) {
        textures_ = std::move(pending_->oldTextures);
        texturesHash_ = pending_->oldTexturesHash;
        ++texturesVersion_;
      }
      pending_.reset();
      if (!problems.empty()) return failed("undoing: " + problems.front());
      return {{"ok", true}};
    }
    if (kind == "commit") {
      PARALLAX_CHECK(pending_->stored.has_value());
      calibration_ = pending_->model;
      calibrationSource_ = op.at("source").get<std::string>();
      applyPhotometry(pending_->stored->photometry, pending_->stored->photometrySource);
      photometryRefused_.clear();
      pending_.reset();
      // Whatever the modules showed during the patterns is gone: show the scene again.
      needsPush_ = true;
      renderedTexturesVersion_ = 0;
      return {{"ok", true}, {"hash", hashHex(texturesHash_)}};
    }
    return failed("unknown calibration step " + kind);
  } catch (const RanksSilent&) {
    throw;
  } catch (const std::exception& e) {
    return failed(e.what());
  }
}

nlohmann::json Conductor::takeFilesStep(const nlohmann::json& op) {
  const auto holds = [this](const std::string& hash) {
    const std::optional<StoredCalibration> current = store_.loadFor(nominal_);
    return current && current->source == store_.path() &&
                   hashHex(displayContentHash(current->model)) == hash
               ? current
               : std::nullopt;
  };
  if (op.at("action") == "install") {
    const std::string hash = hashHex(displayContentHash(pending_->model));
    if (std::optional<StoredCalibration> shared = holds(hash)) {
      pending_->stored = std::move(shared);  // a file an earlier rank of this machine wrote
    } else {
      pending_->filesBefore = store_.files();
      pending_->stored = store_.install(pending_->model);
    }
    return {{"ok", true}, {"hash", hash}};
  }
  // rollback: rank 0's previous calibration is the target; the others' must be the same one.
  if (cluster_->isConductor()) {
    pending_->filesBefore = store_.files();
    pending_->stored = store_.rollback(nominal_);
    pending_->model = pending_->stored->model;
    return {{"ok", true}, {"hash", hashHex(displayContentHash(pending_->model))}};
  }
  const std::string target = op.at("hash").get<std::string>();
  if (std::optional<StoredCalibration> shared = holds(target)) {
    pending_->stored = std::move(shared);
  } else {
    pending_->filesBefore = store_.files();
    StoredCalibration previous = store_.rollback(nominal_);
    const std::string hash = hashHex(displayContentHash(previous.model));
    if (hash != target) {
      store_.restore(*pending_->filesBefore);  // this rank stays where it was
      pending_->filesBefore.reset();
      return {{"ok", false},
              {"error", fmt::format("its previous calibration is {}, rank 0's is {}: the nodes' "
                                    "calibration files have different histories",
                                    hash, target)}};
    }
    pending_->stored = std::move(previous);
  }
  pending_->model = pending_->stored->model;
  return {{"ok", true}, {"hash", target}};
}

std::string Conductor::installOnEveryRank(const DisplayModel* model) {
  const bool rollback = model == nullptr;
  std::string payload, hash;
  if (!rollback) {
    payload = displayModelToJson(*model).dump();
    hash = hashHex(displayContentHash(*model));
  }
  const nlohmann::json action = rollback ? "rollback" : "install";
  calibrationStep({{"op", "begin"}, {"action", action}, {"hash", hash}}, payload);
  try {
    // One rank after the other: ranks of one machine may share the file.
    for (int r = 0; r < cluster_->size(); ++r) {
      const std::vector<nlohmann::json> answers =
          calibrationStep({{"op", "files"}, {"action", action}, {"rank", r}, {"hash", hash}});
      if (rollback && r == 0) hash = answers[0].at("hash").get<std::string>();
    }
    // The ray textures can take minutes on a large display.
    calibrationStep({{"op", "textures"}}, "", kStartUpTimeoutMs);
  } catch (const RanksSilent&) {
    throw;
  } catch (const std::exception& e) {
    try {
      calibrationStep({{"op", "undo"}});
    } catch (const std::exception& undo) {
      throw std::runtime_error(fmt::format("{}; and undoing it: {}", e.what(), undo.what()));
    }
    throw std::runtime_error(fmt::format("{}; every rank is back on its calibration of before ({})",
                                         e.what(), calibrationSource_));
  }
  const std::string source = rollback ? store_.path() + " (rolled back)" : store_.path();
  calibrationStep({{"op", "commit"}, {"source", source}});
  spdlog::info("cluster: calibration {} in use on every rank ({})", hash, source);
  return hash;
}

}  // namespace parallax::daemon
