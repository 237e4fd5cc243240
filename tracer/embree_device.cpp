#include "tracer/embree_device.h"

#include <spdlog/spdlog.h>

#include <mutex>

#include "common/check.h"

namespace parallax {
namespace {

std::mutex gErrorMutex;
std::string gLastError;  // guarded by gErrorMutex

const char* errorName(RTCError code) {
  switch (code) {
    case RTC_ERROR_NONE:
      return "none";
    case RTC_ERROR_UNKNOWN:
      return "unknown";
    case RTC_ERROR_INVALID_ARGUMENT:
      return "invalid argument";
    case RTC_ERROR_INVALID_OPERATION:
      return "invalid operation";
    case RTC_ERROR_OUT_OF_MEMORY:
      return "out of memory";
    case RTC_ERROR_UNSUPPORTED_CPU:
      return "unsupported CPU";
    case RTC_ERROR_CANCELLED:
      return "cancelled";
  }
  return "?";
}

// Embree calls this from whichever thread failed; it must not throw through Embree's frames,
// so it records the message for throwIfEmbreeFailed().
void onEmbreeError(void*, RTCError code, const char* message) {
  const std::string text = std::string(errorName(code)) + ": " + (message ? message : "");
  spdlog::error("embree: {}", text);
  std::lock_guard<std::mutex> lock(gErrorMutex);
  if (gLastError.empty()) gLastError = text;
}

}  // namespace

RTCDevice embreeDevice() {
  static RTCDevice device = [] {
    RTCDevice d = rtcNewDevice(nullptr);
    if (!d) {
      throw InternalError("embree: cannot create a device: " +
                          std::string(errorName(rtcGetDeviceError(nullptr))));
    }
    rtcSetDeviceErrorFunction(d, onEmbreeError, nullptr);
    return d;
  }();
  return device;
}

void throwIfEmbreeFailed(const std::string& during) {
  std::string message;
  {
    std::lock_guard<std::mutex> lock(gErrorMutex);
    message.swap(gLastError);
  }
  if (!message.empty()) throw InternalError("embree failed during " + during + ": " + message);
}

}  // namespace parallax
