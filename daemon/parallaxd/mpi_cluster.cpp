#include <mpi.h>
#include <spdlog/spdlog.h>
#include <sys/prctl.h>

#include <algorithm>
#include <chrono>
#include <optional>
#include <stdexcept>
#include <thread>

#include "daemon/parallaxd/cluster.h"

// Open MPI behind the Cluster interface (cluster.h): point-to-point messages in a star around
// rank 0, each wait a poll (MPI_Iprobe / MPI_Testall) so that rank 0 can give up on a rank after
// a deadline, or when the process is asked to stop, and name the ranks it was waiting for.
// Only the conductor thread (the main thread) calls MPI: MPI_THREAD_FUNNELED.

namespace parallax::daemon {
namespace {

constexpr int kTagBroadcast = 1;
constexpr int kTagGather = 2;
// How long a rank waits before looking again: kPoll while the wait is young, since a display
// frame's exchanges are answered within a few hundred us and its sync overhead is a few of
// these; kPatientPoll once it is older than kEagerFor (the rank waits for a render, a push or
// the next frame, where 0.1 ms more is nothing, but 50,000 looks a second would take a fifth of
// a core from the renderers). Sleeps, not spins, because ranks share cores with the renderers.
constexpr auto kPoll = std::chrono::microseconds(20);
constexpr auto kPatientPoll = std::chrono::microseconds(100);
constexpr auto kEagerFor = std::chrono::milliseconds(2);
// Linux lets a sleep run over by the thread's timer slack (50 us by default): a 20 us poll took
// ~96 us, and a display frame's exchanges wait for several polls in a row. 1 us keeps the poll
// what it says (the value is in ns; 0 would mean the default again).
constexpr unsigned long kTimerSlackNs = 1000;
// A rank asked to stop (SIGTERM) waits this long for the others (rank 0: for their answers;
// the others: for rank 0's stop) before giving up on them.
constexpr auto kStopGrace = std::chrono::milliseconds(500);
constexpr auto kFollowerStopGrace = std::chrono::seconds(3);

void check(int rc, const char* call) {
  if (rc == MPI_SUCCESS) return;
  char text[MPI_MAX_ERROR_STRING] = {};
  int length = 0;
  MPI_Error_string(rc, text, &length);
  throw std::runtime_error(std::string(call) + ": " +
                           std::string(text, static_cast<size_t>(length)));
}

// A wait's end: its timeout, or soon after the process is asked to stop. Under systemd every
// rank gets SIGTERM at once and the others still answer (they wait for rank 0's stop); when
// mpirun ends the job because a rank died, the grace is what lets rank 0 name it.
class Deadline {
 public:
  explicit Deadline(int timeoutMs)
      : end_(std::chrono::steady_clock::now() + std::chrono::milliseconds(timeoutMs)) {}
  // True (and the end brought near) once `stopping` was.
  bool shortenIf(bool stopping) {
    if (stopping && !stopping_) {
      stopping_ = true;
      end_ = std::min(end_, std::chrono::steady_clock::now() + kStopGrace);
    }
    return stopping_;
  }
  bool passed() const { return std::chrono::steady_clock::now() > end_; }

 private:
  std::chrono::steady_clock::time_point end_;
  bool stopping_ = false;
};

// The sleeps of one wait for a message, each before looking again.
class PollWait {
 public:
  void sleep() const {
    const bool young = std::chrono::steady_clock::now() - started_ < kEagerFor;
    std::this_thread::sleep_for(young ? kPoll : kPatientPoll);
  }

 private:
  const std::chrono::steady_clock::time_point started_ = std::chrono::steady_clock::now();
};

class MpiCluster final : public Cluster {
 public:
  MpiCluster(int& argc, char**& argv) {
    int provided = 0;
    check(MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided), "MPI_Init_thread");
    // Errors are returned and reported by us (naming the rank), not a silent abort in MPI.
    MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
    // This thread does every exchange; the threads it starts later inherit the slack, which
    // costs them nothing: they wait on condition variables and sockets, rarely on timers.
    if (::prctl(PR_SET_TIMERSLACK, kTimerSlackNs, 0, 0, 0) != 0)
      spdlog::warn("cluster: cannot narrow the timer slack; each poll may wait ~0.1 ms");
  }
  ~MpiCluster() override { MPI_Finalize(); }

  int rank() const override { return rank_; }
  int size() const override { return size_; }

  void broadcast(std::string& message) override {
    if (size_ == 1) return;
    if (rank_ != 0) {
      message = receiveFromConductor();
      return;
    }
    std::vector<MPI_Request> sends(static_cast<size_t>(size_ - 1), MPI_REQUEST_NULL);
    for (int r = 1; r < size_; ++r) {
      check(MPI_Isend(message.data(), static_cast<int>(message.size()), MPI_CHAR, r, kTagBroadcast,
                      MPI_COMM_WORLD, &sends[static_cast<size_t>(r - 1)]),
            "MPI_Isend");
    }
    Deadline deadline(kSendMs);
    const PollWait poll;
    while (true) {
      int done = 0;
      check(MPI_Testall(static_cast<int>(sends.size()), sends.data(), &done, MPI_STATUSES_IGNORE),
            "MPI_Testall");
      if (done) return;
      const bool stopping = deadline.shortenIf(interrupted());
      if (deadline.passed()) {
        std::vector<int> silent;
        for (int r = 1; r < size_; ++r) {
          if (sends[static_cast<size_t>(r - 1)] != MPI_REQUEST_NULL) silent.push_back(r);
        }
        throw RanksSilent(silent, stopping ? "the job is stopping" : "a message was not taken");
      }
      poll.sleep();
    }
  }

  std::vector<std::string> gather(const std::string& mine, int timeoutMs) override {
    if (rank_ != 0) {
      if (size_ > 1) {
        check(MPI_Send(mine.data(), static_cast<int>(mine.size()), MPI_CHAR, 0, kTagGather,
                       MPI_COMM_WORLD),
              "MPI_Send");
      }
      return {};
    }
    std::vector<std::string> all(static_cast<size_t>(size_));
    all[0] = mine;
    std::vector<int> waiting;
    for (int r = 1; r < size_; ++r) waiting.push_back(r);
    Deadline deadline(timeoutMs);
    const PollWait poll;
    while (!waiting.empty()) {
      bool received = false;
      for (auto it = waiting.begin(); it != waiting.end();) {
        if (std::optional<std::string> m = tryReceive(*it, kTagGather)) {
          all[static_cast<size_t>(*it)] = std::move(*m);
          it = waiting.erase(it);
          received = true;
        } else {
          ++it;
        }
      }
      if (waiting.empty()) break;
      const bool stopping = deadline.shortenIf(interrupted());
      if (deadline.passed()) {
        throw RanksSilent(waiting, stopping
                                       ? "the job is stopping"
                                       : "no answer within " + std::to_string(timeoutMs) + " ms");
      }
      if (!received) poll.sleep();
    }
    return all;
  }

  void abort(int code) override {
    MPI_Abort(MPI_COMM_WORLD, code);
    std::_Exit(code);  // MPI_Abort does not return; this only tells the compiler so
  }

 private:
  // Rank 0 waits this long for a rank to take a message (they are small: the rank is blocked in
  // a long stage only if it is not waiting for us, which the gathers' deadlines catch).
  static constexpr int kSendMs = 60000;

  std::optional<std::string> tryReceive(int source, int tag) {
    int flag = 0;
    MPI_Status status;
    check(MPI_Iprobe(source, tag, MPI_COMM_WORLD, &flag, &status), "MPI_Iprobe");
    if (!flag) return std::nullopt;
    int count = 0;
    MPI_Get_count(&status, MPI_CHAR, &count);
    std::string message(static_cast<size_t>(count), '\0');
    check(MPI_Recv(message.data(), count, MPI_CHAR, source, tag, MPI_COMM_WORLD, MPI_STATUS_IGNORE),
          "MPI_Recv");
    return message;
  }

  std::string receiveFromConductor() {
    std::optional<std::chrono::steady_clock::time_point> giveUp;
    const PollWait poll;
    while (true) {
      if (std::optional<std::string> m = tryReceive(0, kTagBroadcast)) return std::move(*m);
      if (!giveUp && interrupted()) giveUp = std::chrono::steady_clock::now() + kFollowerStopGrace;
      if (giveUp && std::chrono::steady_clock::now() > *giveUp)
        throw RanksSilent({0}, "asked to stop, and rank 0 sent no stop within 3 s");
      poll.sleep();
    }
  }

  int rank_ = 0, size_ = 1;
};

}  // namespace

std::unique_ptr<Cluster> joinCluster(int& argc, char**& argv) {
  if (!startedByMpiLauncher()) return std::make_unique<SingleProcess>();
  return std::make_unique<MpiCluster>(argc, argv);
}

}  // namespace parallax::daemon
