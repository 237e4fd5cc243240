#pragma once
// The thin seam between UsbTransport's logic (queueing, retries, reconnects) and libusb. One
// method per libusb call the transport needs, results mapped to the few outcomes that matter.
// LibusbBackend is the real one; tests inject a backend that fails the way real devices do
// (timeouts with partial data, stalls, LIBUSB_ERROR_NO_DEVICE mid-transfer, short writes).

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace parallax::hw {

enum class UsbResult {
  kOk,        // completed; `transferred` may still be short of the request
  kTimeout,   // LIBUSB_TRANSFER_TIMED_OUT: `transferred` bytes went through
  kStall,     // LIBUSB_TRANSFER_STALL: the endpoint halted; clear it before retrying
  kNoDevice,  // LIBUSB_TRANSFER_NO_DEVICE / LIBUSB_ERROR_NO_DEVICE: unplugged
  kError,     // anything else (overflow, I/O error, cancelled)
};

struct UsbDeviceId {
  std::string serial;
  uint8_t bus = 0, address = 0;
};

struct UsbCompletion {
  uint64_t transferId = 0;
  UsbResult result = UsbResult::kOk;
  size_t transferred = 0;
};

struct UsbHotplugEvent {
  bool arrived = false;  // false: left
  std::string serial;
};

class UsbBackend {
 public:
  virtual ~UsbBackend() = default;
  // False with a one-line reason when there is no USB at all (container, no /dev/bus/usb).
  virtual bool init(std::string* error) = 0;
  virtual std::vector<UsbDeviceId> enumerate(uint16_t vendor, uint16_t product) = 0;
  // Opens the device with this serial and claims interface 0; handle > 0 on success.
  virtual UsbResult open(uint16_t vendor, uint16_t product, const std::string& serial,
                         int* handle) = 0;
  virtual void close(int handle) = 0;
  // Asynchronous bulk transfers; the buffer must stay valid until the completion arrives.
  virtual UsbResult submitBulkOut(int handle, uint8_t endpoint, const uint8_t* data, size_t size,
                                  unsigned timeoutMs, uint64_t transferId) = 0;
  virtual UsbResult submitBulkIn(int handle, uint8_t endpoint, uint8_t* buffer, size_t size,
                                 unsigned timeoutMs, uint64_t transferId) = 0;
  virtual UsbResult clearHalt(int handle, uint8_t endpoint) = 0;
  // Runs the event loop for up to timeoutMs and appends every transfer that finished.
  virtual void handleEvents(int timeoutMs, std::vector<UsbCompletion>* done) = 0;
  // Attach/detach events since the last call (empty where hotplug is unsupported).
  virtual bool hotplugSupported() const = 0;
  virtual void takeHotplugEvents(std::vector<UsbHotplugEvent>* events) = 0;
};

// The libusb-1.0 backend.
std::unique_ptr<UsbBackend> makeLibusbBackend();

}  // namespace parallax::hw
