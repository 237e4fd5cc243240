// The real UsbBackend over libusb-1.0: asynchronous bulk transfers completed from
// libusb_handle_events_timeout_completed, hotplug through libusb's callback where the
// platform has it (Linux with udev or netlink), everything else returned as UsbResult.

#include <fmt/format.h>
#include <libusb.h>

#include <map>

#include "hw/link/usb_backend.h"

namespace parallax::hw {
namespace {

UsbResult fromError(int error) {
  switch (error) {
    case LIBUSB_SUCCESS:
      return UsbResult::kOk;
    case LIBUSB_ERROR_TIMEOUT:
      return UsbResult::kTimeout;
    case LIBUSB_ERROR_PIPE:
      return UsbResult::kStall;
    case LIBUSB_ERROR_NO_DEVICE:
      return UsbResult::kNoDevice;
    default:
      return UsbResult::kError;
  }
}

UsbResult fromStatus(libusb_transfer_status status) {
  switch (status) {
    case LIBUSB_TRANSFER_COMPLETED:
      return UsbResult::kOk;
    case LIBUSB_TRANSFER_TIMED_OUT:
      return UsbResult::kTimeout;
    case LIBUSB_TRANSFER_STALL:
      return UsbResult::kStall;
    case LIBUSB_TRANSFER_NO_DEVICE:
      return UsbResult::kNoDevice;
    default:
      return UsbResult::kError;
  }
}

class LibusbBackend : public UsbBackend {
 public:
  ~LibusbBackend() override {
    while (!handles_.empty()) close(handles_.begin()->first);
    if (hotplug_) libusb_hotplug_deregister_callback(context_, hotplugHandle_);
    if (context_) libusb_exit(context_);
  }

  bool init(std::string* error) override {
    if (context_) return true;
    const int r = libusb_init(&context_);
    if (r != LIBUSB_SUCCESS) {
      context_ = nullptr;
      *error = fmt::format("USB is not available on this machine (libusb: {})",
                           libusb_strerror(static_cast<libusb_error>(r)));
      return false;
    }
    return true;
  }

  std::vector<UsbDeviceId> enumerate(uint16_t vendor, uint16_t product) override {
    std::vector<UsbDeviceId> found;
    if (!context_) return found;
    armHotplug(vendor, product);
    libusb_device** list = nullptr;
    const ssize_t n = libusb_get_device_list(context_, &list);
    for (ssize_t i = 0; i < n; ++i) {
      libusb_device_descriptor d{};
      if (libusb_get_device_descriptor(list[i], &d) != 0) continue;
      if (d.idVendor != vendor || d.idProduct != product) continue;
      UsbDeviceId id;
      id.bus = libusb_get_bus_number(list[i]);
      id.address = libusb_get_device_address(list[i]);
      id.serial = serialOf(list[i], d);
      found.push_back(id);
    }
    if (list) libusb_free_device_list(list, 1);
    return found;
  }

  UsbResult open(uint16_t vendor, uint16_t product, const std::string& serial,
                 int* handle) override {
    libusb_device** list = nullptr;
    const ssize_t n = libusb_get_device_list(context_, &list);
    UsbResult result = UsbResult::kNoDevice;
    for (ssize_t i = 0; i < n && result == UsbResult::kNoDevice; ++i) {
      libusb_device_descriptor d{};
      if (libusb_get_device_descriptor(list[i], &d) != 0) continue;
      if (d.idVendor != vendor || d.idProduct != product || serialOf(list[i], d) != serial) {
        continue;
      }
      libusb_device_handle* h = nullptr;
      int r = libusb_open(list[i], &h);
      if (r == 0) {
        libusb_set_auto_detach_kernel_driver(h, 1);
        r = libusb_claim_interface(h, 0);
        if (r != 0) libusb_close(h);
      }
      result = fromError(r);
      if (r == 0) {
        *handle = ++lastHandle_;
        handles_[*handle] = h;
      }
    }
    if (list) libusb_free_device_list(list, 1);
    return result;
  }

  void close(int handle) override {
    auto it = handles_.find(handle);
    if (it == handles_.end()) return;
    // Transfers still queued on this handle point into the caller's buffers: cancel them and
    // wait (bounded) for their callbacks before the handle and the buffers go away.
    for (auto& [id, live] : live_) {
      if (live.first == handle) libusb_cancel_transfer(live.second);
    }
    for (int i = 0; i < 100 && hasLive(handle); ++i) {
      timeval tv{0, 10000};
      libusb_handle_events_timeout_completed(context_, &tv, nullptr);
    }
    libusb_release_interface(it->second, 0);
    libusb_close(it->second);
    handles_.erase(it);
  }

  UsbResult submitBulkOut(int handle, uint8_t endpoint, const uint8_t* data, size_t size,
                          unsigned timeoutMs, uint64_t transferId) override {
    return submit(handle, endpoint, const_cast<uint8_t*>(data), size, timeoutMs, transferId);
  }
  UsbResult submitBulkIn(int handle, uint8_t endpoint, uint8_t* buffer, size_t size,
                         unsigned timeoutMs, uint64_t transferId) override {
    return submit(handle, endpoint, buffer, size, timeoutMs, transferId);
  }

  UsbResult clearHalt(int handle, uint8_t endpoint) override {
    auto it = handles_.find(handle);
    if (it == handles_.end()) return UsbResult::kNoDevice;
    return fromError(libusb_clear_halt(it->second, endpoint));
  }

  void handleEvents(int timeoutMs, std::vector<UsbCompletion>* done) override {
    if (!context_) return;
    timeval tv{timeoutMs / 1000, (timeoutMs % 1000) * 1000};
    completed_ = done;
    libusb_handle_events_timeout_completed(context_, &tv, nullptr);
    completed_ = nullptr;
    done->insert(done->end(), early_.begin(), early_.end());
    early_.clear();
  }

  bool hotplugSupported() const override {
    return libusb_has_capability(LIBUSB_CAP_HAS_HOTPLUG) != 0;
  }
  void takeHotplugEvents(std::vector<UsbHotplugEvent>* events) override {
    if (context_ && hotplug_) {
      timeval zero{0, 0};
      libusb_handle_events_timeout_completed(context_, &zero, nullptr);
    }
    events->insert(events->end(), hotplugEvents_.begin(), hotplugEvents_.end());
    hotplugEvents_.clear();
  }

 private:
  struct Pending {
    LibusbBackend* self;
    uint64_t id;
  };

  static std::string serialOf(libusb_device* device, const libusb_device_descriptor& d) {
    if (d.iSerialNumber == 0) return "";
    libusb_device_handle* h = nullptr;
    if (libusb_open(device, &h) != 0) return "";
    unsigned char text[128] = {};
    const int n = libusb_get_string_descriptor_ascii(h, d.iSerialNumber, text, sizeof text - 1);
    libusb_close(h);
    return n > 0 ? std::string(reinterpret_cast<char*>(text), static_cast<size_t>(n)) : "";
  }

  UsbResult submit(int handle, uint8_t endpoint, uint8_t* buffer, size_t size, unsigned timeoutMs,
                   uint64_t transferId) {
    auto it = handles_.find(handle);
    if (it == handles_.end()) return UsbResult::kNoDevice;
    libusb_transfer* t = libusb_alloc_transfer(0);
    if (!t) return UsbResult::kError;
    auto* pending = new Pending{this, transferId};
    libusb_fill_bulk_transfer(t, it->second, endpoint, buffer, static_cast<int>(size), onDone,
                              pending, timeoutMs);
    t->flags = LIBUSB_TRANSFER_FREE_TRANSFER;
    const int r = libusb_submit_transfer(t);
    if (r != 0) {
      delete pending;
      libusb_free_transfer(t);
    } else {
      live_[transferId] = {handle, t};
    }
    return fromError(r);
  }

  static void LIBUSB_CALL onDone(libusb_transfer* t) {
    auto* pending = static_cast<Pending*>(t->user_data);
    pending->self->live_.erase(pending->id);
    const UsbCompletion c{pending->id, fromStatus(t->status),
                          static_cast<size_t>(t->actual_length)};
    if (pending->self->completed_) {
      pending->self->completed_->push_back(c);
    } else {
      pending->self->early_.push_back(c);  // completed while polling hotplug
    }
    delete pending;
  }

  void armHotplug(uint16_t vendor, uint16_t product) {
    if (hotplug_ || !hotplugSupported()) return;
    const int r = libusb_hotplug_register_callback(
        context_,
        static_cast<libusb_hotplug_event>(LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED |
                                          LIBUSB_HOTPLUG_EVENT_DEVICE_LEFT),
        LIBUSB_HOTPLUG_NO_FLAGS, vendor, product, LIBUSB_HOTPLUG_MATCH_ANY, onHotplug, this,
        &hotplugHandle_);
    hotplug_ = r == LIBUSB_SUCCESS;
  }

  static int LIBUSB_CALL onHotplug(libusb_context*, libusb_device*, libusb_hotplug_event event,
                                   void* user) {
    // No serial here: opening a device from inside the callback is not allowed, and one that
    // left cannot be asked. The transport re-enumerates on arrival and learns departures from
    // LIBUSB_ERROR_NO_DEVICE on its transfers.
    auto* self = static_cast<LibusbBackend*>(user);
    self->hotplugEvents_.push_back({event == LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED, ""});
    return 0;
  }

  bool hasLive(int handle) const {
    for (const auto& [id, live] : live_) {
      if (live.first == handle) return true;
    }
    return false;
  }

  libusb_context* context_ = nullptr;
  std::map<uint64_t, std::pair<int, libusb_transfer*>> live_;  // submitted, not completed
  std::map<int, libusb_device_handle*> handles_;
  int lastHandle_ = 0;
  std::vector<UsbCompletion>* completed_ = nullptr;
  std::vector<UsbCompletion> early_;
  bool hotplug_ = false;
  libusb_hotplug_callback_handle hotplugHandle_ = 0;
  std::vector<UsbHotplugEvent> hotplugEvents_;
};

}  // namespace

std::unique_ptr<UsbBackend> makeLibusbBackend() { return std::make_unique<LibusbBackend>(); }

}  // namespace parallax::hw
