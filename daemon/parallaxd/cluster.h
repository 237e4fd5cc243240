#pragma once
// The processes that drive one display together (issue 23): `mpirun -np N parallaxd`. Rank 0
// is the conductor (control socket, config, script time, requests); every rank renders and
// pushes its own modules (module_ownership.h). The conductor speaks to the others through this
// small interface only, so that a daemon started without an MPI launcher is one rank of a
// one-rank cluster (SingleProcess) and runs the code it always ran.
//
// Every exchange is a star around rank 0 (rank 0 sends to each rank, each rank answers rank 0),
// not a tree: a rank that died or hangs holds up nobody's messages but its own, and rank 0
// knows which ranks did not answer (RanksSilent) and can name them and their modules.

#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace parallax::daemon {

// Ranks that did not answer rank 0 within the deadline, or before the job was stopped.
class RanksSilent : public std::runtime_error {
 public:
  RanksSilent(std::vector<int> ranks, const std::string& what)
      : std::runtime_error(what), ranks_(std::move(ranks)) {}
  const std::vector<int>& ranks() const { return ranks_; }

 private:
  std::vector<int> ranks_;
};

class Cluster {
 public:
  virtual ~Cluster() = default;
  virtual int rank() const = 0;
  virtual int size() const = 0;
  bool isConductor() const { return rank() == 0; }
  // The machine this rank runs on (`status`).
  virtual std::string host() const;

  // Rank 0: sends `message` to every other rank. Other ranks: waits for rank 0's next message
  // and puts it in `message`. Throws RanksSilent (rank 0) when a rank did not take it in time.
  virtual void broadcast(std::string& message) = 0;
  // Every rank's `mine`, in rank order, on rank 0 (the other ranks get an empty vector).
  // Rank 0 waits at most `timeoutMs` for the others (after its own part is done); throws
  // RanksSilent naming those that did not answer.
  virtual std::vector<std::string> gather(const std::string& mine, int timeoutMs) = 0;
  // True on every rank when `mine` is true on every rank (gather, then broadcast).
  bool all(bool mine, int timeoutMs);

  // A waiting rank gives up when this says so (the process was asked to stop): rank 0 then
  // throws RanksSilent naming the ranks it was still waiting for.
  void setInterrupt(std::function<bool()> interrupted) { interrupted_ = std::move(interrupted); }
  // Ends every rank of the job at once (after the caller logged why).
  [[noreturn]] virtual void abort(int code) = 0;

 protected:
  bool interrupted() const { return interrupted_ && interrupted_(); }

 private:
  std::function<bool()> interrupted_;
};

// A daemon started without an MPI launcher: one rank, nothing to exchange.
class SingleProcess final : public Cluster {
 public:
  int rank() const override { return 0; }
  int size() const override { return 1; }
  void broadcast(std::string&) override {}
  std::vector<std::string> gather(const std::string& mine, int) override { return {mine}; }
  [[noreturn]] void abort(int code) override;
};

// True when this process was started by an MPI launcher (mpirun sets OMPI_COMM_WORLD_SIZE;
// PMIx launchers set PMIX_RANK).
bool startedByMpiLauncher();
// The cluster this process belongs to: Open MPI's when started by a launcher (and the build has
// MPI), else SingleProcess. Call once, on the thread that will do every exchange, before any
// other thread starts.
std::unique_ptr<Cluster> joinCluster(int& argc, char**& argv);

}  // namespace parallax::daemon
