#include "hw/link/usb_transport.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <deque>

#include "common/input_error.h"

namespace parallax::hw {

void UsbTransportOptions::validate() const {
  if (transferSize < 512 || transferSize > (16u << 20)) {
    throw InputError({"", "usb.transfer_size", 0}, "must be in 512..16777216 bytes");
  }
  if (transfersInFlight < 1 || transfersInFlight > 64) {
    throw InputError({"", "usb.transfers_in_flight", 0}, "must be in 1..64");
  }
  if (maxTransferRetries < 0 || maxTransferRetries > 100) {
    throw InputError({"", "usb.max_transfer_retries", 0}, "must be in 0..100");
  }
  if ((endpointOut & 0x80) != 0 || (endpointIn & 0x80) == 0) {
    throw InputError({"", "usb.endpoints", 0}, "OUT endpoint must have bit 7 clear, IN set");
  }
  for (size_t i = 0; i < serials.size(); ++i) {
    for (size_t j = 0; j < i; ++j) {
      if (serials[i] == serials[j]) {
        throw InputError({"", fmt::format("usb.serials[{}]", i), 0},
                         fmt::format("serial \"{}\" is already module {}", serials[i], j));
      }
    }
  }
}

UsbTransport::UsbTransport(UsbTransportOptions options, std::unique_ptr<UsbBackend> backend)
    : options_(std::move(options)), backend_(std::move(backend)) {
  options_.validate();
}

UsbTransport::~UsbTransport() { close(); }

std::string UsbTransport::name() const {
  return fmt::format("usb:{:04x}:{:04x}", options_.vendorId, options_.productId);
}

int UsbTransport::connectedModules() const {
  return static_cast<int>(std::count_if(devices_.begin(), devices_.end(),
                                        [](const Device& d) { return d.handle > 0; }));
}

TransportStatus UsbTransport::open(std::string* error) {
  close();
  lastError_ = ProtocolError::kOk;
  protocolErrorPending_ = false;
  lost_ = false;
  std::string why;
  if (!backend_->init(&why)) {
    *error = "no USB devices: " + why;
    return TransportStatus::kUnavailable;
  }
  const std::vector<UsbDeviceId> found = backend_->enumerate(options_.vendorId, options_.productId);
  if (found.empty()) {
    *error = fmt::format("no USB devices with VID:PID {:04x}:{:04x}", options_.vendorId,
                         options_.productId);
    return TransportStatus::kUnavailable;
  }
  std::vector<std::string> serials = options_.serials;
  if (serials.empty()) {  // no map configured: modules in serial order
    for (const UsbDeviceId& id : found) serials.push_back(id.serial);
    std::sort(serials.begin(), serials.end());
  }
  devices_.clear();
  devices_.resize(serials.size());
  for (size_t i = 0; i < serials.size(); ++i) devices_[i].serial = serials[i];
  rescan();
  if (connectedModules() == 0) {
    *error = fmt::format(
        "no USB devices could be opened ({} with VID:PID {:04x}:{:04x} found, "
        "none with a configured serial, or no permission)",
        found.size(), options_.vendorId, options_.productId);
    devices_.clear();
    return TransportStatus::kUnavailable;
  }
  open_ = true;
  return TransportStatus::kOk;
}

void UsbTransport::rescan() {
  const std::vector<UsbDeviceId> found = backend_->enumerate(options_.vendorId, options_.productId);
  for (Device& d : devices_) {
    if (d.handle > 0) continue;
    const bool present = std::any_of(found.begin(), found.end(),
                                     [&](const UsbDeviceId& id) { return id.serial == d.serial; });
    if (!present) continue;
    int handle = 0;
    if (backend_->open(options_.vendorId, options_.productId, d.serial, &handle) ==
        UsbResult::kOk) {
      d.handle = handle;
      d.reader = PacketReader();
      d.inFlight = false;
      d.inBuffer.resize(64 << 10);
      ++stats_.reopenedDevices;
    }
  }
}

void UsbTransport::markGone(Device& device) {
  if (device.handle > 0) {
    backend_->close(device.handle);  // cancels and reaps its transfers
    if (open_) lost_ = true;
  }
  device.handle = 0;
  device.inFlight = false;
}

void UsbTransport::close() {
  open_ = false;
  for (Device& d : devices_) markGone(d);
  outCompletions_.clear();
  received_.clear();
  open_ = false;
}

void UsbTransport::pumpEvents(int timeoutMs) {
  std::vector<UsbCompletion> done;
  backend_->handleEvents(timeoutMs, &done);
  for (const UsbCompletion& c : done) {
    bool isIn = false;
    for (Device& d : devices_) {
      if (d.inFlight && d.inTransferId == c.transferId) {
        onInCompletion(d, c, &received_);
        isIn = true;
        break;
      }
    }
    if (!isIn) outCompletions_[c.transferId] = c;
  }
  std::vector<UsbHotplugEvent> events;
  backend_->takeHotplugEvents(&events);
  for (const UsbHotplugEvent& e : events) {
    if (!e.arrived) continue;  // departures show up as kNoDevice on the next transfer
    ++stats_.hotplugArrivals;
    rescan();
  }
}

void UsbTransport::onInCompletion(Device& device, const UsbCompletion& c,
                                  std::vector<ReceivedPacket>* out) {
  device.inFlight = false;
  if (c.result == UsbResult::kNoDevice) {
    ++stats_.noDevice;
    markGone(device);
    return;
  }
  if (c.result == UsbResult::kStall) backend_->clearHalt(device.handle, options_.endpointIn);
  const int module = static_cast<int>(&device - devices_.data());
  std::span<const uint8_t> bytes(device.inBuffer.data(),
                                 std::min(c.transferred, device.inBuffer.size()));
  while (!bytes.empty()) {
    bytes = bytes.subspan(device.reader.feed(bytes));
    if (device.reader.error() != ProtocolError::kOk) {
      lastError_ = device.reader.error();
      lastPeerVersion_ = device.reader.peerVersion();
      protocolErrorPending_ = true;
      markGone(device);  // a device that sends garbage is reset by reopening it
      return;
    }
    if (!device.reader.ready()) continue;
    ReceivedPacket p{device.reader.header(),
                     {device.reader.payload().begin(), device.reader.payload().end()}};
    device.reader.next();
    // The device speaks as module 0 of 1; the link speaks of module `module` of N.
    if (p.header.module == 0) p.header.module = static_cast<uint16_t>(module);
    if (p.header.type == PacketType::kDeviceInfo) {
      DeviceInfo info;
      if (decodeDeviceInfo(p.payload, &info) == ProtocolError::kOk) {
        info.moduleCount = static_cast<uint16_t>(devices_.size());
        p.payload = encodeDeviceInfo(info);
      }
    }
    out->push_back(std::move(p));
  }
}

TransportStatus UsbTransport::send(uint16_t module, std::span<const iovec> pieces, int timeoutMs) {
  if (!open_) return TransportStatus::kDisconnected;
  // One copy into memory we own: the transfers outlive this call's view of the caller's data.
  size_t total = 0;
  for (const iovec& v : pieces) total += v.iov_len;
  std::vector<uint8_t> bytes(total);
  size_t at = 0;
  for (const iovec& v : pieces) {
    std::copy_n(static_cast<const uint8_t*>(v.iov_base), v.iov_len, bytes.data() + at);
    at += v.iov_len;
  }
  // Re-address each packet to the device's own module 0 (broadcasts stay broadcasts).
  for (size_t pos = 0; pos + kHeaderSize <= bytes.size();) {
    PacketHeader h;
    if (decodeHeader({bytes.data() + pos, kHeaderSize}, &h) != ProtocolError::kOk) {
      return TransportStatus::kProtocolError;  // not our packets: a caller bug
    }
    if (h.module != kAllModules && h.module != kCameraModule) {
      h.module = 0;
      const HeaderBytes rewritten = encodeHeaderRaw(h);
      std::copy(rewritten.begin(), rewritten.end(), bytes.begin() + pos);
    }
    pos += kHeaderSize + h.payloadSize;
  }
  if (module == kCameraModule) return TransportStatus::kOk;  // the camera is not on this bus
  if (module == kAllModules) {
    TransportStatus result = TransportStatus::kOk;
    for (Device& d : devices_) {
      if (d.handle == 0) continue;
      std::vector<uint8_t> copy = bytes;
      const TransportStatus s = sendTo(d, copy, timeoutMs);
      if (s != TransportStatus::kOk && result == TransportStatus::kOk) result = s;
    }
    return result;
  }
  if (module >= devices_.size() || devices_[module].handle == 0) {
    return TransportStatus::kDisconnected;
  }
  return sendTo(devices_[module], bytes, timeoutMs);
}

TransportStatus UsbTransport::sendTo(Device& device, std::vector<uint8_t>& bytes, int timeoutMs) {
  struct InFlight {
    uint64_t id;
    size_t offset, size;
  };
  std::deque<InFlight> inFlight;
  size_t next = 0;       // first byte not submitted
  size_t confirmed = 0;  // bytes the device has taken, contiguously from the start
  int failuresHere = 0;  // consecutive failures without progress at `confirmed`
  // The caller's limit: a device that takes no byte for this long hangs (no more resubmits).
  auto lastProgress = std::chrono::steady_clock::now();
  const auto deadlineFor = [&] {
    return std::chrono::steady_clock::now() +
           std::chrono::milliseconds(2 * options_.transferTimeoutMs + 100);
  };

  // Waits for every transfer still in flight (their buffers are ours) and forgets them.
  auto drain = [&] {
    const auto deadline = deadlineFor();
    while (!inFlight.empty() && std::chrono::steady_clock::now() < deadline) {
      if (auto it = outCompletions_.find(inFlight.front().id); it != outCompletions_.end()) {
        outCompletions_.erase(it);
        inFlight.pop_front();
        continue;
      }
      pumpEvents(10);
    }
    inFlight.clear();
  };
  auto gone = [&] {
    ++stats_.noDevice;
    drain();
    markGone(device);
    return TransportStatus::kDisconnected;
  };

  while (confirmed < bytes.size()) {
    while (static_cast<int>(inFlight.size()) < options_.transfersInFlight && next < bytes.size()) {
      const size_t n = std::min(options_.transferSize, bytes.size() - next);
      const uint64_t id = ++nextTransferId_;
      const UsbResult r =
          backend_->submitBulkOut(device.handle, options_.endpointOut, bytes.data() + next, n,
                                  options_.transferTimeoutMs, id);
      if (r == UsbResult::kNoDevice) return gone();
      if (r != UsbResult::kOk) {
        drain();
        markGone(device);
        return TransportStatus::kDisconnected;
      }
      ++stats_.transfers;
      inFlight.push_back({id, next, n});
      next += n;
    }
    const auto deadline = deadlineFor();
    while (!inFlight.empty() && !outCompletions_.count(inFlight.front().id)) {
      if (std::chrono::steady_clock::now() > deadline) {  // the backend lost a completion
        drain();
        markGone(device);
        return TransportStatus::kDisconnected;
      }
      pumpEvents(static_cast<int>(options_.transferTimeoutMs) + 100);
    }
    // Completions are handled in submission order: bytes only count once everything before
    // them went through.
    while (!inFlight.empty()) {
      auto it = outCompletions_.find(inFlight.front().id);
      if (it == outCompletions_.end()) break;
      const UsbCompletion c = it->second;
      outCompletions_.erase(it);
      const InFlight head = inFlight.front();
      inFlight.pop_front();
      if (c.result == UsbResult::kOk && c.transferred == head.size) {
        confirmed = head.offset + head.size;
        failuresHere = 0;
        lastProgress = std::chrono::steady_clock::now();
        continue;
      }
      if (c.result == UsbResult::kNoDevice) return gone();
      switch (c.result) {
        case UsbResult::kOk:
          ++stats_.shortWrites;
          break;
        case UsbResult::kTimeout:
          ++stats_.timeouts;
          break;
        case UsbResult::kStall:
          ++stats_.stalls;
          if (backend_->clearHalt(device.handle, options_.endpointOut) == UsbResult::kNoDevice) {
            return gone();
          }
          break;
        default:
          break;
      }
      const size_t through = std::min(c.transferred, head.size);
      failuresHere = through > 0 ? 0 : failuresHere + 1;
      if (through > 0) lastProgress = std::chrono::steady_clock::now();
      confirmed = head.offset + through;
      // Everything queued behind the failed transfer follows a gap: let it finish, then
      // resubmit from the first byte the device did not take.
      drain();
      next = confirmed;
      ++stats_.resubmits;
      if (failuresHere > 0 &&
          std::chrono::steady_clock::now() - lastProgress >= std::chrono::milliseconds(timeoutMs)) {
        spdlog::warn("usb: device {}: took no byte for {} ms at byte {}; it hangs", device.serial,
                     timeoutMs, confirmed);
        markGone(device);
        return TransportStatus::kTimeout;
      }
      if (failuresHere > options_.maxTransferRetries) {
        spdlog::warn("usb: device {}: {} failures in a row at byte {}; resetting it", device.serial,
                     failuresHere, confirmed);
        markGone(device);
        return TransportStatus::kDisconnected;
      }
      break;
    }
  }
  return TransportStatus::kOk;
}

TransportStatus UsbTransport::receive(std::vector<ReceivedPacket>* packets, int timeoutMs) {
  if (!open_) return TransportStatus::kDisconnected;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeoutMs);
  while (true) {
    if (!received_.empty()) {
      for (ReceivedPacket& p : received_) packets->push_back(std::move(p));
      received_.clear();
      return TransportStatus::kOk;
    }
    if (protocolErrorPending_) {
      protocolErrorPending_ = false;
      return TransportStatus::kProtocolError;
    }
    if (lost_) return TransportStatus::kDisconnected;
    bool any = false;
    for (Device& d : devices_) {
      if (d.handle == 0) continue;
      any = true;
      if (d.inFlight) continue;
      d.inTransferId = ++nextTransferId_;
      const UsbResult r =
          backend_->submitBulkIn(d.handle, options_.endpointIn, d.inBuffer.data(),
                                 d.inBuffer.size(), options_.transferTimeoutMs, d.inTransferId);
      if (r == UsbResult::kNoDevice) {
        ++stats_.noDevice;
        markGone(d);
        return TransportStatus::kDisconnected;
      }
      d.inFlight = r == UsbResult::kOk;
    }
    if (!any) return TransportStatus::kDisconnected;
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                          deadline - std::chrono::steady_clock::now())
                          .count();
    if (left <= 0) return TransportStatus::kTimeout;
    pumpEvents(static_cast<int>(std::min<int64_t>(left, 50)));
  }
}

}  // namespace parallax::hw
