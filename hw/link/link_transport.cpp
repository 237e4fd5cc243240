#include "hw/link/link_transport.h"

#include <map>
#include <mutex>

#include "common/input_error.h"
#include "hw/link/socket_transport.h"
#include "hw/link/usb_transport.h"

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
    // usb:VID:PID[:SERIAL0,SERIAL1,...] (hex ids; serials in module order).
    reg->factories["usb"] = [](const std::string& endpoint) -> std::unique_ptr<LinkTransport> {
      UsbTransportOptions options;
      std::vector<std::string> parts;
      for (size_t start = 0;;) {
        const size_t colon = endpoint.find(':', start);
        parts.push_back(endpoint.substr(start, colon - start));
        if (colon == std::string::npos) break;
        start = colon + 1;
      }
      auto hex = [](const std::string& text, const char* field) {
        size_t used = 0;
        unsigned long value = 0;
        try {
          value = std::stoul(text, &used, 16);
        } catch (const std::exception&) {
          used = 0;
        }
        if (used == 0 || used != text.size() || value > 0xFFFF) {
          throw InputError({"", field, 0}, "expected a 16-bit hex id, got \"" + text + "\"");
        }
        return static_cast<uint16_t>(value);
      };
      if (!endpoint.empty()) {
        if (parts.size() < 2 || parts.size() > 3) {
          throw InputError({"", "link", 0},
                           "expected usb:VID:PID[:SERIAL,...], got usb:" + endpoint);
        }
        options.vendorId = hex(parts[0], "link.vid");
        options.productId = hex(parts[1], "link.pid");
        if (parts.size() == 3) {
          for (size_t start = 0;;) {
            const size_t comma = parts[2].find(',', start);
            options.serials.push_back(parts[2].substr(start, comma - start));
            if (comma == std::string::npos) break;
            start = comma + 1;
          }
        }
      }
      return std::make_unique<UsbTransport>(options, makeLibusbBackend());
    };
    return reg;
  }();
  return *r;
}

}  // namespace

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

}  // namespace parallax::hw
