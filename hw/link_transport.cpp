#include "hw/link_transport.h"

#include <map>
#include <mutex>

#include "common/input_error.h"
#include "hw/socket_transport.h"

namespace parallax::hw {
namespace {

struct Registry {
  std::mutex mutex;
  std::map<std::string, LinkTransportFactory> factories;
};

Registry& registry() {
  static Registry* r = [] {
    auto* reg = new Registry;
    reg->factories["simhw"] = [](const std::string& endpoint) -> std::unique_ptr<LinkTransport> {
      if (endpoint.empty()) {
        throw InputError({"", "link", 0}, "simhw needs a socket path: simhw:/path/to/socket");
      }
      return std::make_unique<SocketTransport>(endpoint);
    };
    return reg;
  }();
  return *r;
}

}  // namespace

std::string_view transportStatusName(TransportStatus status) {
  switch (status) {
    case TransportStatus::kOk: return "ok";
    case TransportStatus::kTimeout: return "timeout";
    case TransportStatus::kDisconnected: return "disconnected";
    case TransportStatus::kProtocolError: return "protocol error";
    case TransportStatus::kUnavailable: return "unavailable";
  }
  return "unknown";
}

void registerLinkTransport(const std::string& name, LinkTransportFactory factory) {
  Registry& r = registry();
  std::lock_guard lock(r.mutex);
  r.factories[name] = std::move(factory);
}

std::unique_ptr<LinkTransport> createLinkTransport(const std::string& spec) {
  const size_t colon = spec.find(':');
  const std::string name = spec.substr(0, colon);
  const std::string endpoint = colon == std::string::npos ? "" : spec.substr(colon + 1);
  Registry& r = registry();
  LinkTransportFactory factory;
  {
    std::lock_guard lock(r.mutex);
    auto it = r.factories.find(name);
    if (it == r.factories.end()) {
      std::string known;
      for (const auto& [n, f] : r.factories) known += (known.empty() ? "" : ", ") + n;
      throw InputError({"", "link", 0},
                       "unknown transport \"" + name + "\" (known: " + known + ")");
    }
    factory = it->second;
  }
  return factory(endpoint);
}

std::vector<std::string> linkTransportNames() {
  Registry& r = registry();
  std::lock_guard lock(r.mutex);
  std::vector<std::string> names;
  for (const auto& [n, f] : r.factories) names.push_back(n);
  return names;
}

}  // namespace parallax::hw
