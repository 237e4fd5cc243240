#pragma once
// The "usb" transport: one USB device per optical module, found by VID/PID and mapped to
// module indices by serial number (the display config lists the serials in module order).
//
// Each device speaks the link protocol for itself alone (its DeviceInfo says module 0 of 1);
// this transport rewrites the module field both ways, so LinkClient sees one link with N
// modules exactly as with the simulator. Outgoing packets are copied into transport-owned
// buffers (USB is far slower than memcpy) and cut into bulk OUT transfers, several in flight.
//
// Transfer-level recovery lives here, above the UsbBackend seam: a timeout or a short write
// resubmits the bytes that did not go through; a stall clears the halt and resubmits; each
// transfer gets at most maxTransferRetries. LIBUSB_ERROR_NO_DEVICE marks the device gone and
// reports kDisconnected; LinkClient then reopens, which re-enumerates by serial (reconnect,
// also after a hotplug arrival). Whatever this layer cannot guarantee (bytes lost inside a
// cancelled transfer), the frame protocol's CRCs and acks catch one level up.

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "hw/link/link_transport.h"
#include "hw/link/usb_backend.h"

namespace parallax::hw {

struct UsbTransportOptions {
  uint16_t vendorId = 0x1209;  // pid.codes; configure for the real modules
  uint16_t productId = 0x7078;
  std::vector<std::string> serials;  // serials[i] is module i; empty: enumeration order
  uint8_t endpointOut = 0x01, endpointIn = 0x81;
  size_t transferSize = 256u << 10;
  int transfersInFlight = 4;
  unsigned transferTimeoutMs = 1000;
  int maxTransferRetries = 3;

  void validate() const;  // throws InputError naming the field
};

struct UsbTransportStats {
  uint64_t transfers = 0, timeouts = 0, stalls = 0, shortWrites = 0, noDevice = 0;
  uint64_t resubmits = 0, reopenedDevices = 0, hotplugArrivals = 0;
};

class UsbTransport : public LinkTransport {
 public:
  UsbTransport(UsbTransportOptions options, std::unique_ptr<UsbBackend> backend);
  ~UsbTransport() override;

  std::string name() const override;
  // kUnavailable with "no USB devices ..." (one line) when nothing matches or USB is absent.
  TransportStatus open(std::string* error) override;
  void close() override;
  bool isOpen() const override { return open_; }
  TransportStatus send(uint16_t module, std::span<const iovec> pieces, int timeoutMs) override;
  TransportStatus receive(std::vector<ReceivedPacket>* packets, int timeoutMs) override;
  ProtocolError lastProtocolError() const override { return lastError_; }
  uint16_t lastPeerVersion() const override { return lastPeerVersion_; }

  const UsbTransportStats& stats() const { return stats_; }
  int connectedModules() const;

 private:
  struct Device {
    std::string serial;
    int handle = 0;  // 0: not connected
    PacketReader reader;
    std::vector<uint8_t> inBuffer;
    bool inFlight = false;
    uint64_t inTransferId = 0;
  };

  // timeoutMs: the caller's (send's) limit on a device that takes no byte.
  TransportStatus sendTo(Device& device, std::vector<uint8_t>& bytes, int timeoutMs);
  void markGone(Device& device);
  void rescan();
  void pumpEvents(int timeoutMs);
  void onInCompletion(Device& device, const UsbCompletion& c, std::vector<ReceivedPacket>* out);

  UsbTransportOptions options_;
  std::unique_ptr<UsbBackend> backend_;
  std::vector<Device> devices_;  // index = module
  bool open_ = false;
  uint64_t nextTransferId_ = 0;
  std::map<uint64_t, UsbCompletion> outCompletions_;  // finished OUT transfers by id
  std::vector<ReceivedPacket> received_;
  ProtocolError lastError_ = ProtocolError::kOk;
  uint16_t lastPeerVersion_ = 0;
  bool protocolErrorPending_ = false;  // reported once by receive()
  bool lost_ = false;                  // a device went away since open()
  UsbTransportStats stats_;
};

}  // namespace parallax::hw
