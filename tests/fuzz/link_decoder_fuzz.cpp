// libFuzzer target for the link decoder: arbitrary bytes as a stream into PacketReader and the
// body decoders, and (second mode) arbitrary packet sequences with valid CRCs into the
// simulated hardware, so the module state machine behind the CRC check is reached too.
// Nothing may crash, hang, leak or read out of bounds; every rejection is a ProtocolError.

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include "hw/link/link_protocol.h"
#include "hw/simulator/simulated_hardware.h"

namespace {

using namespace parallax::hw;

void decodeBody(PacketType type, std::span<const uint8_t> body) {
  DeviceInfo info;
  FrameBegin begin;
  Ack ack;
  CaptureRequest request;
  CaptureReplyHeader reply;
  Fault fault;
  ErrorBody error;
  DisplayMode mode;
  Present present;
  uint32_t sequence, offset;
  switch (type) {
    case PacketType::kDeviceInfo:
      decodeDeviceInfo(body, &info);
      break;
    case PacketType::kFrameBegin:
      decodeFrameBegin(body, &begin);
      break;
    case PacketType::kAck:
      decodeAck(body, &ack);
      break;
    case PacketType::kCaptureRequest:
      decodeCaptureRequest(body, &request);
      break;
    case PacketType::kCaptureReply:
      decodeCaptureReplyHeader(body, &reply);
      break;
    case PacketType::kFault:
      decodeFault(body, &fault);
      break;
    case PacketType::kError:
      decodeError(body, &error);
      break;
    case PacketType::kSetMode:
      decodeSetMode(body, &mode);
      break;
    case PacketType::kFrameChunk:
      decodeChunkPrefix(body, &sequence, &offset);
      break;
    case PacketType::kPresent:
      decodePresent(body, &present);
      break;
    default:
      break;
  }
}

SimulatedHardware makeSimulator() {
  SimulatedHardwareOptions o;
  o.modules = 2;
  o.width = 8;
  o.height = 4;
  o.maxChunkSize = 4096;
  return SimulatedHardware(o);
}

void feedSimulator(SimulatedHardware& sim, const PacketHeader& header,
                   std::span<const uint8_t> payload) {
  // Crash and disconnect faults are actions for the server loop; here they just return.
  std::vector<uint8_t> replies;
  sim.handlePacket(header, payload, &replies);
  // Whatever the simulator answers must itself decode cleanly.
  PacketReader reader;
  std::span<const uint8_t> rest(replies);
  while (!rest.empty()) {
    rest = rest.subspan(reader.feed(rest));
    if (reader.error() != ProtocolError::kOk) __builtin_trap();
    if (reader.ready()) {
      decodeBody(reader.header().type, reader.payload());
      reader.next();
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::span<const uint8_t> input(data + 1, size - 1);
  if (data[0] & 1) {
    // Mode 1: a raw byte stream, fed in pieces whose sizes come from the data itself.
    PacketHeader header;
    decodeHeader(input, &header);
    PacketReader reader;
    SimulatedHardware sim = makeSimulator();
    std::span<const uint8_t> rest = input;
    size_t step = 1 + (data[0] >> 1);
    while (!rest.empty() && reader.error() == ProtocolError::kOk) {
      const size_t n = std::min(step, rest.size());
      const size_t used = reader.feed(rest.first(n));
      rest = rest.subspan(used);
      if (reader.ready()) {
        decodeBody(reader.header().type, reader.payload());
        feedSimulator(sim, reader.header(), reader.payload());
        reader.next();
      }
      step = step * 3 % 97 + 1;
    }
    return 0;
  }
  // Mode 2: records of [type, module, flags, length lo, length hi, payload...], sealed with
  // correct CRCs so that they pass the framing and exercise the simulator.
  SimulatedHardware sim = makeSimulator();
  std::span<const uint8_t> rest = input;
  uint32_t sequence = 0;
  while (rest.size() >= 5) {
    PacketHeader header;
    header.type = static_cast<PacketType>(1 + rest[0] % kMaxPacketType);
    header.module = rest[1] < 0xF0 ? rest[1] % 4 : static_cast<uint16_t>(0xFF00 | rest[1]);
    header.sequence = (rest[2] & 0x80) ? sequence : ++sequence;
    const size_t length = std::min<size_t>(rest[3] | (rest[4] << 8), rest.size() - 5);
    const std::span<const uint8_t> payload = rest.subspan(5, length);
    const HeaderBytes bytes = encodeHeader(header, payload);
    PacketHeader decoded;
    if (decodeHeader(bytes, &decoded) != ProtocolError::kOk) __builtin_trap();  // own encoding
    decodeBody(decoded.type, payload);
    feedSimulator(sim, decoded, payload);
    rest = rest.subspan(5 + length);
  }
  return 0;
}
