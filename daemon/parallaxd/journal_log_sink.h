#pragma once
// parallaxd's logs under systemd: stderr is a journal stream ($JOURNAL_STREAM names its device
// and inode), so each line carries its syslog priority as a "<N>" prefix (sd-daemon(3)) and no
// timestamp of ours — the journal stamps every record itself, and `journalctl -p err` then
// finds the errors. Anywhere else: the usual coloured, timestamped stderr.

#include <spdlog/sinks/base_sink.h>

#include <cstdio>
#include <mutex>
#include <string>

namespace parallax::daemon {

// Writes "<N>message\n" for every line of a message (the journal reads each line as a record).
class JournalLogSink : public spdlog::sinks::base_sink<std::mutex> {
 public:
  explicit JournalLogSink(std::FILE* out) : out_(out) {}
  // debug and trace 7, info 6, warn 4, error 3, critical 2.
  static int syslogPriority(spdlog::level::level_enum level);

 protected:
  void sink_it_(const spdlog::details::log_msg& message) override;
  void flush_() override { std::fflush(out_); }

 private:
  std::FILE* out_;
};

// True when `fd` is the stream $JOURNAL_STREAM ("DEVICE:INODE") names.
bool isJournalStream(int fd);

// The default logger named `name`: JournalLogSink on stderr when stderr is a journal stream,
// else a coloured stderr sink with timestamps.
void setUpDaemonLogging(const std::string& name);

// The one line a start-up failure ends with, on stderr: "<3>" first when that is the journal
// (`journalctl -p err` shows why the service did not start).
void logFatal(const std::string& line);

}  // namespace parallax::daemon
