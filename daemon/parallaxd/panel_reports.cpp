#include "daemon/parallaxd/panel_reports.h"

#include <dirent.h>
#include <fcntl.h>
#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include <ctime>

namespace parallax::daemon {
namespace {

// A file descriptor closed when it goes out of scope.
class Descriptor {
 public:
  explicit Descriptor(int fd) : fd_(fd) {}
  ~Descriptor() {
    if (fd_ >= 0) ::close(fd_);
  }
  Descriptor(const Descriptor&) = delete;
  Descriptor& operator=(const Descriptor&) = delete;
  int get() const { return fd_; }
  bool ok() const { return fd_ >= 0; }

 private:
  int fd_;
};

// The kinds of file `parallax report` writes; anything else is not served.
const char* contentTypeOf(const std::string& file) {
  const size_t dot = file.rfind('.');
  const std::string ext = dot == std::string::npos ? "" : file.substr(dot + 1);
  if (ext == "html") return "text/html; charset=utf-8";
  if (ext == "md") return "text/markdown; charset=utf-8";
  if (ext == "csv") return "text/csv; charset=utf-8";
  if (ext == "svg") return "image/svg+xml";
  if (ext == "png") return "image/png";
  return nullptr;
}

// Report `name`'s folder, opened below the reports folder without following a symlink.
Descriptor openReport(const std::string& folder, const std::string& name) {
  Descriptor root(::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  if (!root.ok()) return Descriptor(-1);
  return Descriptor(
      ::openat(root.get(), name.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC));
}

}  // namespace

bool PanelReports::isPlainName(const std::string& name) {
  if (name.empty() || name.size() > 255 || name[0] == '.') return false;
  for (char c : name) {
    const bool plain = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                       c == '_' || c == '-' || c == '.';
    if (!plain) return false;
  }
  return true;
}

std::optional<ReportFolder> PanelReports::latest() const {
  Descriptor root(::open(folder_.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  if (!root.ok()) return std::nullopt;
  // fdopendir owns the descriptor it is given: hand it a duplicate.
  DIR* listing = ::fdopendir(::dup(root.get()));
  if (listing == nullptr) return std::nullopt;
  std::optional<ReportFolder> best;
  while (const dirent* entry = ::readdir(listing)) {
    const std::string name = entry->d_name;
    if (!isPlainName(name)) continue;
    Descriptor report(
        ::openat(root.get(), name.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC));
    struct stat st {};
    if (!report.ok() || ::fstatat(report.get(), "report.html", &st, AT_SYMLINK_NOFOLLOW) != 0 ||
        !S_ISREG(st.st_mode))
      continue;
    const int64_t at = st.st_mtim.tv_sec;
    // Newest first; the name breaks ties so the choice does not depend on the listing's order.
    if (!best || at > best->writtenAt || (at == best->writtenAt && name > best->name))
      best = ReportFolder{name, at, ""};
  }
  ::closedir(listing);
  if (best) {
    const std::time_t t = static_cast<std::time_t>(best->writtenAt);
    std::tm utc{};
    ::gmtime_r(&t, &utc);
    char text[32];
    std::strftime(text, sizeof text, "%Y-%m-%d %H:%M UTC", &utc);
    best->date = text;
  }
  return best;
}

std::optional<ReportFile> PanelReports::read(const std::string& report, const std::string& file,
                                             std::string* problem) const {
  const char* type = contentTypeOf(file);
  if (!isPlainName(report) || !isPlainName(file) || type == nullptr) {
    *problem = "not a file of a report";
    return std::nullopt;
  }
  const Descriptor folder = openReport(folder_, report);
  if (!folder.ok()) {
    *problem = fmt::format("no report \"{}\"", report);
    return std::nullopt;
  }
  // O_NONBLOCK: a FIFO planted there must not hang the request; O_NOFOLLOW: nor lead elsewhere.
  const Descriptor fd(
      ::openat(folder.get(), file.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC));
  struct stat st {};
  if (!fd.ok() || ::fstat(fd.get(), &st) != 0 || !S_ISREG(st.st_mode) ||
      static_cast<size_t>(st.st_size) > kMaxFileBytes) {
    *problem = fmt::format("report \"{}\" has no file \"{}\"", report, file);
    return std::nullopt;
  }
  ReportFile out{std::string(static_cast<size_t>(st.st_size), '\0'), type};
  size_t done = 0;
  while (done < out.body.size()) {
    const ssize_t n = ::read(fd.get(), out.body.data() + done, out.body.size() - done);
    if (n <= 0) break;
    done += static_cast<size_t>(n);
  }
  out.body.resize(done);  // a file cut short while read: what there was
  return out;
}

}  // namespace parallax::daemon
