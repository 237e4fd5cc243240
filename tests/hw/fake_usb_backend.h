#pragma once
// A UsbBackend whose devices are single-module SimulatedHardware instances and whose transfers
// fail on script the way real ones do: a timeout after part of the data, a stall, a short
// write, LIBUSB_ERROR_NO_DEVICE in the middle of a frame. Only the bytes a transfer reports
// as transferred reach the device, so the transport's resubmission logic is what is tested.

#include <algorithm>
#include <cstring>
#include <deque>
#include <map>
#include <memory>
#include <thread>

#include "hw/link/usb_backend.h"
#include "hw/simulator/simulated_hardware.h"

namespace parallax::hw {

struct ScriptedTransfer {
  UsbResult result = UsbResult::kOk;
  size_t transferred = SIZE_MAX;  // bytes that go through (clamped to the transfer)
};

class FakeUsbBackend : public UsbBackend {
 public:
  struct FakeDevice {
    std::string serial;
    bool present = true;
    std::unique_ptr<SimulatedHardware> hardware;
    PacketReader reader;
    std::deque<uint8_t> toHost;
    std::deque<ScriptedTransfer> script;  // applied to the next OUT transfers, in order
    uint64_t bytesAccepted = 0;
  };

  FakeUsbBackend(std::vector<std::string> serials, int width, int height, bool usbPresent = true)
      : usbPresent_(usbPresent) {
    for (const std::string& s : serials) {
      auto d = std::make_unique<FakeDevice>();
      d->serial = s;
      SimulatedHardwareOptions o;
      o.modules = 1;
      o.width = width;
      o.height = height;
      o.maxChunkSize = 4096;
      o.serialPrefix = s;
      d->hardware = std::make_unique<SimulatedHardware>(o);
      devices_.push_back(std::move(d));
    }
  }

  FakeDevice& device(const std::string& serial) {
    for (auto& d : devices_) {
      if (d->serial == serial) return *d;
    }
    throw std::out_of_range(serial);
  }
  void replug(const std::string& serial) {
    FakeDevice& d = device(serial);
    d.present = true;
    d.reader = PacketReader();
    d.toHost.clear();
    d.hardware->resetSession();
    hotplug_.push_back({true, ""});
  }

  bool init(std::string* error) override {
    if (!usbPresent_) *error = "USB is not available on this machine (fake)";
    return usbPresent_;
  }
  std::vector<UsbDeviceId> enumerate(uint16_t, uint16_t) override {
    std::vector<UsbDeviceId> ids;
    for (auto& d : devices_) {
      if (d->present) ids.push_back({d->serial, 1, 0});
    }
    return ids;
  }
  UsbResult open(uint16_t, uint16_t, const std::string& serial, int* handle) override {
    for (size_t i = 0; i < devices_.size(); ++i) {
      if (devices_[i]->serial == serial && devices_[i]->present) {
        *handle = ++lastHandle_;
        handles_[*handle] = devices_[i].get();
        return UsbResult::kOk;
      }
    }
    return UsbResult::kNoDevice;
  }
  void close(int handle) override {
    handles_.erase(handle);
    std::erase_if(queue_, [&](const Transfer& t) { return t.handle == handle; });
  }
  UsbResult submitBulkOut(int handle, uint8_t, const uint8_t* data, size_t size, unsigned,
                          uint64_t id) override {
    return queue(handle, const_cast<uint8_t*>(data), size, id, true);
  }
  UsbResult submitBulkIn(int handle, uint8_t, uint8_t* buffer, size_t size, unsigned,
                         uint64_t id) override {
    return queue(handle, buffer, size, id, false);
  }
  UsbResult clearHalt(int handle, uint8_t) override {
    ++clearHalts;
    return handles_.count(handle) && handles_[handle]->present ? UsbResult::kOk
                                                               : UsbResult::kNoDevice;
  }

  void handleEvents(int timeoutMs, std::vector<UsbCompletion>* done) override {
    const size_t before = done->size();
    // OUT first, so that replies to what just arrived can complete an IN in the same call.
    std::map<FakeDevice*, bool> broken;  // a failed transfer cancels the ones queued behind
    for (auto it = queue_.begin(); it != queue_.end();) {
      if (!it->out) {
        ++it;
        continue;
      }
      FakeDevice* d = handles_.count(it->handle) ? handles_[it->handle] : nullptr;
      if (!d || !d->present) {
        done->push_back({it->id, UsbResult::kNoDevice, 0});
      } else if (broken[d]) {
        done->push_back({it->id, UsbResult::kError, 0});
      } else {
        ScriptedTransfer s;
        if (!d->script.empty()) {
          s = d->script.front();
          d->script.pop_front();
        }
        const size_t n = std::min(s.transferred, it->size);
        deliver(*d, it->data, n);
        if (s.result == UsbResult::kNoDevice) d->present = false;
        // A transfer that ended early (failed or short) takes the ones queued behind it down
        // with it, as the host cancels them; the transport must resend from the gap. (If a
        // real device kept them, the frame CRCs one level up would catch the gap.)
        if (s.result != UsbResult::kOk || n < it->size) broken[d] = true;
        done->push_back({it->id, s.result, n});
      }
      it = queue_.erase(it);
    }
    for (auto it = queue_.begin(); it != queue_.end();) {
      FakeDevice* d = handles_.count(it->handle) ? handles_[it->handle] : nullptr;
      if (!d || !d->present) {
        done->push_back({it->id, UsbResult::kNoDevice, 0});
        it = queue_.erase(it);
      } else if (!d->toHost.empty()) {
        const size_t n = std::min(it->size, d->toHost.size());
        std::copy_n(d->toHost.begin(), n, it->data);
        d->toHost.erase(d->toHost.begin(), d->toHost.begin() + static_cast<long>(n));
        done->push_back({it->id, UsbResult::kOk, n});
        it = queue_.erase(it);
      } else {
        ++it;  // an IN transfer waits for data
      }
    }
    if (done->size() == before) {
      std::this_thread::sleep_for(std::chrono::milliseconds(std::min(timeoutMs, 1)));
    }
  }
  bool hotplugSupported() const override { return true; }
  void takeHotplugEvents(std::vector<UsbHotplugEvent>* events) override {
    events->insert(events->end(), hotplug_.begin(), hotplug_.end());
    hotplug_.clear();
  }

  int clearHalts = 0;

 private:
  struct Transfer {
    int handle;
    uint8_t* data;
    size_t size;
    uint64_t id;
    bool out;
  };

  UsbResult queue(int handle, uint8_t* data, size_t size, uint64_t id, bool out) {
    auto it = handles_.find(handle);
    if (it == handles_.end() || !it->second->present) return UsbResult::kNoDevice;
    queue_.push_back({handle, data, size, id, out});
    return UsbResult::kOk;
  }

  // The device's side of the wire: its own packet parser and the simulated module.
  void deliver(FakeDevice& d, const uint8_t* data, size_t n) {
    d.bytesAccepted += n;
    std::span<const uint8_t> rest(data, n);
    while (!rest.empty()) {
      rest = rest.subspan(d.reader.feed(rest));
      if (d.reader.error() != ProtocolError::kOk) {
        d.reader = PacketReader();  // a real device would resynchronise; count it
        ++deviceParseErrors;
        return;
      }
      if (!d.reader.ready()) continue;
      std::vector<uint8_t> replies;
      d.hardware->handlePacket(d.reader.header(), d.reader.payload(), &replies);
      d.toHost.insert(d.toHost.end(), replies.begin(), replies.end());
      d.reader.next();
    }
  }

 public:
  int deviceParseErrors = 0;

 private:
  bool usbPresent_;
  std::vector<std::unique_ptr<FakeDevice>> devices_;
  std::map<int, FakeDevice*> handles_;
  int lastHandle_ = 0;
  std::deque<Transfer> queue_;
  std::vector<UsbHotplugEvent> hotplug_;
};

}  // namespace parallax::hw
