#pragma once
// A transport carries link packets between the host and the devices behind it. It is the
// backend seam of the link (libcamera's pipeline handler habit): the reliability logic
// (acks, timeouts, retries, reconnects) lives once, in LinkClient, and each transport only
// moves bytes. Backends are registered by name: "simhw" (Unix socket to parallax-simhw) and
// "usb" (libusb, one device per module).

#include <sys/uio.h>

#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "hw/link/link_protocol.h"

namespace parallax::hw {

// Expected runtime events are returned, not thrown (STYLE.md habit 4).
enum class TransportStatus {
  kOk,
  kTimeout,        // nothing happened within the time given
  kDisconnected,   // the peer went away; open() again to reconnect
  kProtocolError,  // the peer sent bytes that are not our protocol (see lastProtocolError)
  kUnavailable,    // cannot open at all (no socket, no USB devices)
};

struct ReceivedPacket {
  PacketHeader header;
  std::vector<uint8_t> payload;  // CRC already verified
};

class LinkTransport {
 public:
  virtual ~LinkTransport() = default;
  virtual std::string name() const = 0;
  // (Re)opens the link; a failure explains itself in `error`.
  virtual TransportStatus open(std::string* error) = 0;
  virtual void close() = 0;
  virtual bool isOpen() const = 0;
  // How long open() waits for a peer that does not take the connection; a transport that
  // cannot wait there ignores it.
  virtual void setConnectTimeoutMs(int) {}
  // Sends whole packets (header + payload pieces) addressed to `module`; all or nothing from
  // the caller's view: anything short of complete is kDisconnected, or kTimeout when the
  // device took no byte for `timeoutMs` (it stopped reading: hung). Either way the link is
  // closed (a packet may be cut), and open() starts afresh.
  virtual TransportStatus send(uint16_t module, std::span<const iovec> pieces, int timeoutMs) = 0;
  // Waits up to timeoutMs for at least one packet; appends what has arrived.
  virtual TransportStatus receive(std::vector<ReceivedPacket>* packets, int timeoutMs) = 0;
  // The decode error behind the last kProtocolError.
  virtual ProtocolError lastProtocolError() const = 0;
  // When that error was kBadVersion: the version the peer speaks (0: unknown).
  virtual uint16_t lastPeerVersion() const { return 0; }
};

using LinkTransportFactory =
    std::function<std::unique_ptr<LinkTransport>(const std::string& endpoint)>;

// Registers a backend under a name (done once per backend at startup, see link_transport.cpp).
void registerLinkTransport(const std::string& name, LinkTransportFactory factory);
// "simhw:/path/to.sock" or "usb:" + options; throws InputError for an unknown backend name.
std::unique_ptr<LinkTransport> createLinkTransport(const std::string& spec);

}  // namespace parallax::hw
