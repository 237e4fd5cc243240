#include "common/atomic_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

#include "common/input_error.h"

namespace parallax {
namespace {

class TemporaryFile {
 public:
  explicit TemporaryFile(std::string path) : path_(std::move(path)) {}
  ~TemporaryFile() {
    if (fd_ >= 0) ::close(fd_);
    if (!kept_) ::unlink(path_.c_str());
  }
  int open(mode_t mode) {
    fd_ = ::open(path_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, mode);
    return fd_;
  }
  int fd() const { return fd_; }
  // close(2) reports delayed write errors (NFS, quota); its result counts.
  bool close() {
    const int rc = ::close(fd_);
    fd_ = -1;
    return rc == 0;
  }
  void keep() { kept_ = true; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  int fd_ = -1;
  bool kept_ = false;
};

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  throw InputError({path, "", 0}, what + ": " + std::strerror(errno));
}

bool writeAll(int fd, const std::string& bytes) {
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return false;
    if (n == 0) {
      errno = ENOSPC;
      return false;
    }
    done += static_cast<size_t>(n);
  }
  return true;
}

}  // namespace

void writeFileAtomically(const std::string& path, const std::string& bytes, mode_t mode) {
  TemporaryFile temporary(path + ".tmp." + std::to_string(::getpid()));
  ::unlink(temporary.path().c_str());  // a leftover of a crashed run with our pid
  if (temporary.open(mode) < 0) fail(path, "cannot write the file");
  if (!writeAll(temporary.fd(), bytes)) fail(path, "writing the file failed");
  if (::fsync(temporary.fd()) != 0) fail(path, "flushing the file to disk failed");
  if (!temporary.close()) fail(path, "writing the file failed");
  if (::rename(temporary.path().c_str(), path.c_str()) != 0)
    fail(path, "cannot move the file into place");
  temporary.keep();
  // The rename itself is durable only once the folder is flushed.
  std::string folder = std::filesystem::path(path).parent_path().string();
  if (folder.empty()) folder = ".";
  const int dir = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir < 0) fail(path, "cannot open its folder to flush it");
  const int rc = ::fsync(dir);
  const int e = errno;
  ::close(dir);
  errno = e;
  if (rc != 0) fail(path, "flushing the folder to disk failed");
}

}  // namespace parallax
