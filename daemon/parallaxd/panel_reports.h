#pragma once
// The `parallax report` folders the control panel serves (issue 25: "the control panel links the
// latest one"). Reports live one folder each in the panel's reports folder (`[panel] reports`,
// default `<state folder>/reports`): `parallax report --out <reports>/NAME`. The latest is the
// one whose report.html was written last.
//
// What may be read is decided here, not by the request: a report is a folder directly in the
// reports folder (a plain name, no symlink), a file is a plain name directly in it (no `/`, no
// leading dot, so no `..`) of the kinds a report writes (html, md, csv, svg, png), opened with
// O_NOFOLLOW below a descriptor of its folder and served only when it is a regular file under
// the size cap. Nothing outside the reports folder can be named.

#include <cstdint>
#include <optional>
#include <string>

namespace parallax::daemon {

struct ReportFolder {
  std::string name;      // the folder's name in the reports folder
  int64_t writtenAt{0};  // report.html's modification time, seconds since the epoch
  std::string date;      // the same, "2026-12-03 06:55 UTC"
};

struct ReportFile {
  std::string body;
  std::string contentType;
};

class PanelReports {
 public:
  static constexpr size_t kMaxFileBytes = size_t{64} << 20;

  explicit PanelReports(std::string folder) : folder_(std::move(folder)) {}
  const std::string& folder() const { return folder_; }

  // The report whose report.html is newest; nullopt when there is none (or no folder).
  std::optional<ReportFolder> latest() const;
  // File `file` of report `report`; nullopt with `problem` set (for a 404) when either name is
  // not one a report has, or the file is not a regular file of a served kind.
  std::optional<ReportFile> read(const std::string& report, const std::string& file,
                                 std::string* problem) const;

  // A name the reports folder may hold: letters, digits, `_`, `-`, `.`, not starting with `.`.
  static bool isPlainName(const std::string& name);

 private:
  std::string folder_;
};

}  // namespace parallax::daemon
