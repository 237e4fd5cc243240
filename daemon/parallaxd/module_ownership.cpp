#include "daemon/parallaxd/module_ownership.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>

#include "common/check.h"
#include "common/input_error.h"

namespace parallax::daemon {

ModuleOwnership ModuleOwnership::of(const ClusterConfig& config, int modules, int ranks) {
  PARALLAX_CHECK_OP(ranks, >=, 1);
  ModuleOwnership o;
  o.owner_.assign(static_cast<size_t>(modules), -1);
  if (config.modules.empty() || ranks == 1) {
    // One rank (no launcher, or -np 1) always holds the whole display, whatever the map says.
    for (int r = 0; r < ranks; ++r) {
      std::vector<int>& block = o.byRank_.emplace_back();
      const long long first = static_cast<long long>(r) * modules / ranks;
      const long long last = static_cast<long long>(r + 1) * modules / ranks;
      for (long long m = first; m < last; ++m) block.push_back(static_cast<int>(m));
    }
  } else {
    const InputLocation where{config.file, "cluster.modules", config.line};
    if (static_cast<int>(config.modules.size()) != ranks) {
      throw InputError(where, fmt::format("gives the modules of {} ranks, but the job has {} "
                                          "(mpirun -np {})",
                                          config.modules.size(), ranks, ranks));
    }
    o.byRank_ = config.modules;
    for (int r = 0; r < ranks; ++r) {
      for (int m : o.byRank_[static_cast<size_t>(r)]) {
        if (m >= modules)
          throw InputError(where, fmt::format("rank {}: module {} does not exist: the display "
                                              "has {} (0..{})",
                                              r, m, modules, modules - 1));
        if (o.owner_[static_cast<size_t>(m)] >= 0)
          throw InputError(where, fmt::format("module {} is given to rank {} and to rank {}", m,
                                              o.owner_[static_cast<size_t>(m)], r));
        o.owner_[static_cast<size_t>(m)] = r;
      }
      std::sort(o.byRank_[static_cast<size_t>(r)].begin(), o.byRank_[static_cast<size_t>(r)].end());
    }
    for (int m = 0; m < modules; ++m) {
      if (o.owner_[static_cast<size_t>(m)] < 0)
        throw InputError(where, fmt::format("module {} is given to no rank", m));
    }
    return o;
  }
  for (int r = 0; r < ranks; ++r) {
    for (int m : o.byRank_[static_cast<size_t>(r)]) o.owner_[static_cast<size_t>(m)] = r;
  }
  return o;
}

const std::vector<int>& ModuleOwnership::modulesOf(int rank) const {
  PARALLAX_CHECK(rank >= 0 && rank < ranks());
  return byRank_[static_cast<size_t>(rank)];
}

int ModuleOwnership::ownerOf(int module) const {
  PARALLAX_CHECK(module >= 0 && module < modules());
  return owner_[static_cast<size_t>(module)];
}

std::string ModuleOwnership::describe(int rank) const {
  if (rank < 0 || rank >= ranks()) return fmt::format("rank {}", rank);
  const std::vector<int>& m = modulesOf(rank);
  if (m.empty()) return fmt::format("rank {} (no modules)", rank);
  if (m.size() == 1) return fmt::format("rank {} (module {})", rank, m.front());
  if (m.back() - m.front() + 1 == static_cast<int>(m.size()))
    return fmt::format("rank {} (modules {}-{})", rank, m.front(), m.back());
  return fmt::format("rank {} (modules {})", rank, fmt::join(m, ", "));
}

std::string linkSpecOfRank(const HardwareConfig& hardware, const ModuleOwnership& ownership,
                           int rank) {
  const std::string whole = linkSpecOf(hardware, ownership.modules());
  if (ownership.ranks() == 1) return whole;
  if (hardware.kind == "sim") {
    if (!hardware.socket.empty())
      throw InputError({hardware.file, "hardware.socket", 0},
                       "one simulator socket cannot serve several ranks: each rank needs the "
                       "link that reaches its own modules (leave socket out: each rank starts "
                       "a simulator of its modules)");
    return "";
  }
  if (hardware.serialToModule.empty())
    throw InputError({hardware.file, "hardware.modules", 0},
                     "several ranks need the serial of every module, to know which devices "
                     "each rank's link reaches");
  std::vector<std::string> serials(static_cast<size_t>(ownership.modules()));
  for (const auto& [serial, module] : hardware.serialToModule)
    serials[static_cast<size_t>(module)] = serial;
  std::string spec = fmt::format("usb:{:04x}:{:04x}", hardware.vid, hardware.pid);
  const std::vector<int>& mine = ownership.modulesOf(rank);
  for (size_t i = 0; i < mine.size(); ++i)
    spec += (i == 0 ? ":" : ",") + serials[static_cast<size_t>(mine[i])];
  return spec;
}

}  // namespace parallax::daemon
