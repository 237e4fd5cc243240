#pragma once
// One parallaxd per runtime folder. The lock (flock on <folder>/parallaxd.lock, holding the
// owner's pid) is taken before the daemon touches anything there: a second daemon started
// with the same config exits naming the first one's pid, and deletes no socket and starts no
// simulator on its way out. The kernel drops the lock when the process dies, so a crash never
// leaves a stale lock behind.

#include <stdexcept>
#include <string>

namespace parallax::daemon {

class AlreadyRunning : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class InstanceLock {
 public:
  // Throws AlreadyRunning (naming the holder's pid) when another process holds the lock,
  // std::runtime_error when the lock file cannot be opened.
  explicit InstanceLock(const std::string& folder);
  ~InstanceLock();
  InstanceLock(const InstanceLock&) = delete;
  InstanceLock& operator=(const InstanceLock&) = delete;

  const std::string& path() const { return path_; }

 private:
  std::string path_;
  int fd_ = -1;
};

}  // namespace parallax::daemon
