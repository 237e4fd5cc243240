#include "daemon/parallaxd/journal_log_sink.h"

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <memory>
#include <string_view>

namespace parallax::daemon {

int JournalLogSink::syslogPriority(spdlog::level::level_enum level) {
  switch (level) {
    case spdlog::level::critical:
      return 2;  // LOG_CRIT
    case spdlog::level::err:
      return 3;  // LOG_ERR
    case spdlog::level::warn:
      return 4;  // LOG_WARNING
    case spdlog::level::info:
      return 6;  // LOG_INFO
    default:
      return 7;  // LOG_DEBUG (debug, trace)
  }
}

void JournalLogSink::sink_it_(const spdlog::details::log_msg& message) {
  const int priority = syslogPriority(message.level);
  std::string_view text(message.payload.data(), message.payload.size());
  // A line without its own prefix would be logged at the unit's default priority.
  std::string out;
  while (true) {
    const size_t end = text.find('\n');
    out += '<';
    out += static_cast<char>('0' + priority);
    out += '>';
    out.append(text.substr(0, end));
    out += '\n';
    if (end == std::string_view::npos || end + 1 == text.size()) break;
    text.remove_prefix(end + 1);
  }
  std::fwrite(out.data(), 1, out.size(), out_);
  // Unbuffered in effect: a crash must not swallow the lines before it.
  std::fflush(out_);
}

bool isJournalStream(int fd) {
  const char* stream = std::getenv("JOURNAL_STREAM");
  if (!stream) return false;
  char* end = nullptr;
  const unsigned long long device = std::strtoull(stream, &end, 10);
  if (end == stream || *end != ':') return false;
  const char* inodeText = end + 1;
  const unsigned long long inode = std::strtoull(inodeText, &end, 10);
  if (end == inodeText || *end != '\0') return false;
  struct stat st {};
  if (::fstat(fd, &st) != 0) return false;
  return static_cast<unsigned long long>(st.st_dev) == device &&
         static_cast<unsigned long long>(st.st_ino) == inode;
}

void setUpDaemonLogging(const std::string& name) {
  std::shared_ptr<spdlog::logger> logger;
  if (isJournalStream(STDERR_FILENO)) {
    logger = std::make_shared<spdlog::logger>(name, std::make_shared<JournalLogSink>(stderr));
  } else {
    logger = spdlog::stderr_color_mt(name);
  }
  spdlog::set_default_logger(logger);
}

void logFatal(const std::string& line) {
  std::fprintf(stderr, "%s%s\n", isJournalStream(STDERR_FILENO) ? "<3>" : "", line.c_str());
}

}  // namespace parallax::daemon
