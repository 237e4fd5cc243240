#pragma once
// The control socket's requests, declared once (control_request_table.cpp): name, arguments
// with their types and ranges, where each is served, and one help line. Dispatch, the "unknown
// request" error and the help listing (`parallax ctl --help`) are generated from that table.
//
// Requests are untrusted input: every key must be one the request declares (a typo is refused,
// naming the key), and every value is checked against its declared type and range before a
// handler sees it (integers without wrap-around: module 4294967299 is refused, not module 3).

#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace parallax::daemon {

enum class ArgKind {
  kModule,     // an integer module index, 0..(the display's modules - 1)
  kInteger,    // an integer in [min, max]
  kNumber,     // a finite number in [min, max]
  kString,     // a non-empty string
  kPath,       // an absolute path of a file to write (output_file.h checks the rest)
  kNumberMap,  // an object of finite numbers (scene parameters)
};

struct ArgSpec {
  std::string_view name;
  ArgKind kind;
  bool required = false;
  double min = 0.0, max = 0.0;  // kInteger, kNumber
  std::string_view help;
};

// The checked arguments of one request, by the names its spec declares.
class RequestArgs {
 public:
  RequestArgs() = default;
  explicit RequestArgs(nlohmann::json checked) : values_(std::move(checked)) {}

  bool has(std::string_view name) const;
  std::optional<int> module(std::string_view name) const;
  int integer(std::string_view name, int fallback) const;
  double number(std::string_view name) const;
  std::string string(std::string_view name) const;  // "" when absent
  std::map<std::string, double> numberMap(std::string_view name) const;

 private:
  nlohmann::json values_ = nlohmann::json::object();
};

// Where a request is answered: at once on the socket's thread (from the published snapshot,
// or a flag the conductor thread polls), or queued to the conductor thread between frames.
enum class Served { kAtOnce, kOnConductorThread };

struct RequestSpec {
  std::string_view name;
  std::vector<ArgSpec> args;
  std::string_view help;
  Served served = Served::kOnConductorThread;
};

// The table (control_request_table.cpp), in the order the help lists it. The conductor's
// handlers are found by name (conductor_requests.cpp), so a client links the table alone.
const std::vector<RequestSpec>& controlRequests();
// nullptr when there is no such request.
const RequestSpec* findControlRequest(std::string_view name);
// "unknown request \"dance\" (status, stats, ...)": the list comes from the table.
std::string unknownRequestMessage(std::string_view name);
// One line a request: `calibrate [module=M]  recalibrate ...`, for `parallax ctl --help`.
std::string controlRequestHelp();

// Checks `request` (a JSON object with "request") against `spec`; throws InputError naming the
// key for an unknown key, a missing required one, a wrong type or a value out of range.
// `modules` is the display's module count (kModule's range).
RequestArgs parseRequestArgs(const RequestSpec& spec, const nlohmann::json& request, int modules);

}  // namespace parallax::daemon
