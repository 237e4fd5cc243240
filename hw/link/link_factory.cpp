#include "hw/link/link_factory.h"

#include <fmt/format.h>

namespace parallax::hw {

SelectedLink selectLink(const LinkSelection& selection) {
  SelectedLink chosen;
  if (selection.spec != "auto") {
    chosen.transport = createLinkTransport(selection.spec);
    chosen.note = "link: " + chosen.transport->name();
    return chosen;
  }
  std::unique_ptr<LinkTransport> usb = createLinkTransport("usb");
  std::string why;
  if (usb->open(&why) == TransportStatus::kOk) {
    chosen.note = "link: " + usb->name();
    chosen.transport = std::move(usb);
    return chosen;
  }
  chosen.transport = createLinkTransport("simhw:" + selection.simhwSocket);
  chosen.note = fmt::format("link: {}; using the simulator at {}", why, selection.simhwSocket);
  return chosen;
}

}  // namespace parallax::hw
