#pragma once
// Choosing the link at startup. "auto" (the daemon's default) tries real modules over USB and,
// when there are none — a container, CI, a laptop — says so in one line and falls back to the
// simulator's socket, so the same configuration runs everywhere.

#include <memory>
#include <string>

#include "hw/link/link_transport.h"

namespace parallax::hw {

struct LinkSelection {
  // "auto", "usb[:VID:PID[:SERIALS]]" or "simhw:/path".
  std::string spec = "auto";
  std::string simhwSocket = "/tmp/parallax-simhw.sock";  // the fallback for "auto"
};

struct SelectedLink {
  std::unique_ptr<LinkTransport> transport;  // opened (a simhw one may still fail to connect)
  std::string note;  // one line: what was chosen and why (e.g. the "no USB devices" reason)
};

// Throws InputError for a malformed spec. For "auto", a USB link that cannot open is not an
// error: the note says why and the simulator's transport is returned unopened.
SelectedLink selectLink(const LinkSelection& selection);

}  // namespace parallax::hw
