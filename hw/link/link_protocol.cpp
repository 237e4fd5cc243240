#include "hw/link/link_protocol.h"

#include <algorithm>
#include <cstring>

#include "hw/link/crc32c.h"

namespace parallax::hw {
namespace {

// Little-endian field access, independent of the host's byte order.
void put16(uint8_t* p, uint16_t v) {
  p[0] = static_cast<uint8_t>(v);
  p[1] = static_cast<uint8_t>(v >> 8);
}
void put32(uint8_t* p, uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<uint8_t>(v >> (8 * i));
}
void put64(uint8_t* p, uint64_t v) {
  for (int i = 0; i < 8; ++i) p[i] = static_cast<uint8_t>(v >> (8 * i));
}
uint16_t get16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | (p[1] << 8)); }
uint32_t get32(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) | static_cast<uint32_t>(p[1]) << 8 |
         static_cast<uint32_t>(p[2]) << 16 | static_cast<uint32_t>(p[3]) << 24;
}
uint64_t get64(const uint8_t* p) {
  return static_cast<uint64_t>(get32(p)) | static_cast<uint64_t>(get32(p + 4)) << 32;
}

bool allZero(const uint8_t* p, size_t n) {
  return std::all_of(p, p + n, [](uint8_t b) { return b == 0; });
}

}  // namespace

std::string_view protocolErrorName(ProtocolError error) {
  switch (error) {
    case ProtocolError::kOk:
      return "ok";
    case ProtocolError::kTruncated:
      return "truncated packet";
    case ProtocolError::kBadMagic:
      return "wrong magic";
    case ProtocolError::kBadVersion:
      return "unsupported protocol version";
    case ProtocolError::kBadHeaderCrc:
      return "header CRC mismatch";
    case ProtocolError::kUnknownType:
      return "unknown packet type";
    case ProtocolError::kOversized:
      return "oversized packet";
    case ProtocolError::kReservedNonZero:
      return "reserved field not zero";
    case ProtocolError::kBadPayloadCrc:
      return "payload CRC mismatch";
    case ProtocolError::kBadBody:
      return "malformed packet body";
    case ProtocolError::kUnexpected:
      return "unexpected packet";
  }
  return "unknown protocol error";
}

std::string_view ackStatusName(AckStatus status) {
  switch (status) {
    case AckStatus::kOk:
      return "ok";
    case AckStatus::kCrcMismatch:
      return "CRC mismatch";
    case AckStatus::kMissingChunks:
      return "missing chunks";
    case AckStatus::kBadFrame:
      return "bad frame";
    case AckStatus::kUnsupported:
      return "unsupported";
    case AckStatus::kBaseMismatch:
      return "not showing the patch's base";
  }
  return "unknown ack status";
}

std::string_view faultKindName(FaultKind kind) {
  switch (kind) {
    case FaultKind::kDropChunks:
      return "drop";
    case FaultKind::kFlipBytes:
      return "flip";
    case FaultKind::kStall:
      return "stall";
    case FaultKind::kSlowLink:
      return "slow";
    case FaultKind::kDisconnect:
      return "disconnect";
    case FaultKind::kCrash:
      return "crash";
  }
  return "unknown";
}

int bytesPerPixel(PixelFormat format) {
  switch (format) {
    case PixelFormat::kRgb8:
      return 3;
    case PixelFormat::kGray8:
      return 1;
  }
  return 0;
}

bool isKnownPixelFormat(uint8_t value) {
  return value == static_cast<uint8_t>(PixelFormat::kRgb8) ||
         value == static_cast<uint8_t>(PixelFormat::kGray8);
}

HeaderBytes encodeHeaderRaw(const PacketHeader& header) {
  HeaderBytes b{};
  put32(&b[0], kLinkMagic);
  put16(&b[4], kLinkVersion);
  b[6] = static_cast<uint8_t>(header.type);
  b[7] = header.flags;
  put16(&b[8], header.module);
  put32(&b[12], header.sequence);
  put32(&b[16], header.payloadSize);
  put32(&b[20], header.payloadCrc);
  put32(&b[28], crc32c(b.data(), 28));
  return b;
}

HeaderBytes encodeHeader(PacketHeader header, std::span<const uint8_t> payload) {
  header.payloadSize = static_cast<uint32_t>(payload.size());
  header.payloadCrc = crc32c(payload.data(), payload.size());
  return encodeHeaderRaw(header);
}

ProtocolError decodeHeader(std::span<const uint8_t> bytes, PacketHeader* header) {
  if (bytes.size() < kHeaderSize) return ProtocolError::kTruncated;
  const uint8_t* b = bytes.data();
  // Magic and version before the CRC: a peer speaking another protocol (or another version
  // of ours) deserves that diagnosis rather than "CRC mismatch".
  if (get32(b) != kLinkMagic) return ProtocolError::kBadMagic;
  if (get16(b + 4) != kLinkVersion) return ProtocolError::kBadVersion;
  if (get32(b + 28) != crc32c(b, 28)) return ProtocolError::kBadHeaderCrc;
  if (b[6] == 0 || b[6] > kMaxPacketType) return ProtocolError::kUnknownType;
  if (!allZero(b + 10, 2) || !allZero(b + 24, 4) || b[7] != 0) {
    return ProtocolError::kReservedNonZero;
  }
  const uint32_t size = get32(b + 16);
  if (size > kMaxPayloadSize) return ProtocolError::kOversized;
  header->type = static_cast<PacketType>(b[6]);
  header->flags = b[7];
  header->module = get16(b + 8);
  header->sequence = get32(b + 12);
  header->payloadSize = size;
  header->payloadCrc = get32(b + 20);
  return ProtocolError::kOk;
}

uint16_t headerVersion(std::span<const uint8_t> bytes) {
  return bytes.size() >= 6 ? get16(bytes.data() + 4) : 0;
}

ProtocolError verifyPayload(const PacketHeader& header, std::span<const uint8_t> payload) {
  if (payload.size() < header.payloadSize) return ProtocolError::kTruncated;
  if (payload.size() > header.payloadSize) return ProtocolError::kOversized;
  if (crc32c(payload.data(), payload.size()) != header.payloadCrc) {
    return ProtocolError::kBadPayloadCrc;
  }
  return ProtocolError::kOk;
}

std::vector<uint8_t> encodePacket(PacketHeader header, std::span<const uint8_t> payload) {
  const HeaderBytes h = encodeHeader(header, payload);
  std::vector<uint8_t> packet(kHeaderSize + payload.size());
  std::memcpy(packet.data(), h.data(), kHeaderSize);
  if (!payload.empty()) std::memcpy(packet.data() + kHeaderSize, payload.data(), payload.size());
  return packet;
}

// ---- bodies ----

// A fixed-size body: exactly `size` bytes, no more, no less.
static ProtocolError checkSize(std::span<const uint8_t> body, size_t size) {
  if (body.size() < size) return ProtocolError::kTruncated;
  if (body.size() > size) return ProtocolError::kOversized;
  return ProtocolError::kOk;
}

std::vector<uint8_t> encodeDeviceInfo(const DeviceInfo& info) {
  std::vector<uint8_t> b(kDeviceInfoSize, 0);
  put16(&b[0], info.moduleCount);
  put32(&b[4], info.width);
  put32(&b[8], info.height);
  put32(&b[12], info.pixelFormats);
  put32(&b[16], info.firmwareVersion);
  put32(&b[20], info.maxChunkSize);
  std::memcpy(&b[24], info.serial.data(), std::min(info.serial.size(), kSerialBytes));
  return b;
}

ProtocolError decodeDeviceInfo(std::span<const uint8_t> body, DeviceInfo* info) {
  if (auto e = checkSize(body, kDeviceInfoSize); e != ProtocolError::kOk) return e;
  const uint8_t* b = body.data();
  if (!allZero(b + 2, 2)) return ProtocolError::kReservedNonZero;
  info->moduleCount = get16(b);
  info->width = get32(b + 4);
  info->height = get32(b + 8);
  info->pixelFormats = get32(b + 12);
  info->firmwareVersion = get32(b + 16);
  info->maxChunkSize = get32(b + 20);
  const uint8_t* s = b + 24;
  const size_t length = std::find(s, s + kSerialBytes, uint8_t{0}) - s;
  // A serial is printable ASCII followed by NUL padding only.
  for (size_t i = 0; i < length; ++i) {
    if (s[i] < 0x20 || s[i] > 0x7E) return ProtocolError::kBadBody;
  }
  if (!allZero(s + length, kSerialBytes - length)) return ProtocolError::kBadBody;
  info->serial.assign(reinterpret_cast<const char*>(s), length);
  if (info->width == 0 || info->height == 0 || info->width > 65536 || info->height > 65536 ||
      info->maxChunkSize == 0 || info->maxChunkSize > kMaxPayloadSize - kChunkPrefixSize) {
    return ProtocolError::kBadBody;
  }
  return ProtocolError::kOk;
}

std::vector<uint8_t> encodeFrameBegin(const FrameBegin& f) {
  std::vector<uint8_t> b(kFrameBeginSize, 0);
  put32(&b[0], f.width);
  put32(&b[4], f.height);
  b[8] = static_cast<uint8_t>(f.format);
  b[9] = static_cast<uint8_t>(f.mode);
  put16(&b[10], f.flags);
  put32(&b[12], f.totalSize);
  put32(&b[16], f.chunkCount);
  put32(&b[20], f.frameCrc);
  put64(&b[24], f.contentHash);
  put32(&b[32], f.displayFrame);
  put64(&b[40], f.baseHash);
  return b;
}

ProtocolError decodeFrameBegin(std::span<const uint8_t> body, FrameBegin* f) {
  if (auto e = checkSize(body, kFrameBeginSize); e != ProtocolError::kOk) return e;
  const uint8_t* b = body.data();
  if (!allZero(b + 36, 4)) return ProtocolError::kReservedNonZero;
  if (!isKnownPixelFormat(b[8]) || b[9] > 1) return ProtocolError::kBadBody;
  f->flags = get16(b + 10);
  if ((f->flags & ~(kFrameReuse | kFramePatch)) != 0 || f->flags == (kFrameReuse | kFramePatch))
    return ProtocolError::kBadBody;
  f->width = get32(b);
  f->height = get32(b + 4);
  f->format = static_cast<PixelFormat>(b[8]);
  f->mode = static_cast<DisplayMode>(b[9]);
  f->totalSize = get32(b + 12);
  f->chunkCount = get32(b + 16);
  f->frameCrc = get32(b + 20);
  f->contentHash = get64(b + 24);
  f->displayFrame = get32(b + 32);
  f->baseHash = get64(b + 40);
  // The size must be exactly what the resolution says (computed in 64 bits: no overflow).
  const uint64_t expected = static_cast<uint64_t>(f->width) * f->height * bytesPerPixel(f->format);
  if (f->width == 0 || f->height == 0 || expected != f->totalSize) return ProtocolError::kBadBody;
  // A reused frame sends no chunks (and is only meaningful for a display frame); any other
  // sends at least one.
  if ((f->flags & kFrameReuse) != 0) {
    if (f->chunkCount != 0 || f->displayFrame == 0) return ProtocolError::kBadBody;
  } else if (f->chunkCount == 0 || f->chunkCount > f->totalSize) {
    return ProtocolError::kBadBody;
  }
  // A patch belongs to a display frame, like a reuse; only a patch names a base.
  if ((f->flags & kFramePatch) != 0 ? f->displayFrame == 0 : f->baseHash != 0)
    return ProtocolError::kBadBody;
  return ProtocolError::kOk;
}

std::vector<uint8_t> encodePresent(const Present& p) {
  std::vector<uint8_t> b(kPresentSize, 0);
  put32(&b[0], p.displayFrame);
  return b;
}

ProtocolError decodePresent(std::span<const uint8_t> body, Present* p) {
  if (auto e = checkSize(body, kPresentSize); e != ProtocolError::kOk) return e;
  if (!allZero(body.data() + 4, 4)) return ProtocolError::kReservedNonZero;
  p->displayFrame = get32(body.data());
  if (p->displayFrame == 0) return ProtocolError::kBadBody;
  return ProtocolError::kOk;
}

std::vector<uint8_t> encodeAck(const Ack& a) {
  std::vector<uint8_t> b(kAckSize, 0);
  put32(&b[0], a.ackedSequence);
  b[4] = static_cast<uint8_t>(a.status);
  put32(&b[8], a.detail);
  return b;
}

ProtocolError decodeAck(std::span<const uint8_t> body, Ack* a) {
  if (auto e = checkSize(body, kAckSize); e != ProtocolError::kOk) return e;
  const uint8_t* b = body.data();
  if (!allZero(b + 5, 3)) return ProtocolError::kReservedNonZero;
  if (b[4] > static_cast<uint8_t>(AckStatus::kBaseMismatch)) return ProtocolError::kBadBody;
  a->ackedSequence = get32(b);
  a->status = static_cast<AckStatus>(b[4]);
  a->detail = get32(b + 8);
  return ProtocolError::kOk;
}

std::vector<uint8_t> encodeCaptureRequest(const CaptureRequest& r) {
  std::vector<uint8_t> b(kCaptureRequestSize, 0);
  put16(&b[0], r.viewModule);
  put16(&b[2], r.gainCenti);
  put32(&b[4], r.exposureUs);
  put16(&b[8], r.station);
  put16(&b[10], r.flags);
  put16(&b[12], r.whiteBalanceRedCenti);
  put16(&b[14], r.whiteBalanceBlueCenti);
  return b;
}

ProtocolError decodeCaptureRequest(std::span<const uint8_t> body, CaptureRequest* r) {
  if (auto e = checkSize(body, kCaptureRequestSize); e != ProtocolError::kOk) return e;
  const uint8_t* b = body.data();
  r->viewModule = get16(b);
  r->whiteBalanceRedCenti = get16(b + 12);
  r->whiteBalanceBlueCenti = get16(b + 14);
  r->gainCenti = get16(b + 2);
  r->exposureUs = get32(b + 4);
  r->station = get16(b + 8);
  r->flags = get16(b + 10);
  if ((r->flags & ~kCaptureColour) != 0) return ProtocolError::kBadBody;  // undefined flags
  return ProtocolError::kOk;
}

std::vector<uint8_t> encodeCaptureReplyHeader(const CaptureReplyHeader& r) {
  std::vector<uint8_t> b(kCaptureReplyHeaderSize, 0);
  put32(&b[0], r.width);
  put32(&b[4], r.height);
  b[8] = static_cast<uint8_t>(r.format);
  put32(&b[12], r.requestSequence);
  return b;
}

ProtocolError decodeCaptureReplyHeader(std::span<const uint8_t> body, CaptureReplyHeader* r) {
  if (body.size() < kCaptureReplyHeaderSize) return ProtocolError::kTruncated;
  const uint8_t* b = body.data();
  if (!allZero(b + 9, 3)) return ProtocolError::kReservedNonZero;
  if (!isKnownPixelFormat(b[8])) return ProtocolError::kBadBody;
  r->width = get32(b);
  r->height = get32(b + 4);
  r->format = static_cast<PixelFormat>(b[8]);
  r->requestSequence = get32(b + 12);
  const uint64_t pixels = static_cast<uint64_t>(r->width) * r->height * bytesPerPixel(r->format);
  if (r->width == 0 || r->height == 0) return ProtocolError::kBadBody;
  if (body.size() - kCaptureReplyHeaderSize < pixels) return ProtocolError::kTruncated;
  if (body.size() - kCaptureReplyHeaderSize > pixels) return ProtocolError::kOversized;
  return ProtocolError::kOk;
}

std::vector<uint8_t> encodeFault(const Fault& f) {
  std::vector<uint8_t> b(kFaultSize, 0);
  b[0] = static_cast<uint8_t>(f.kind);
  put32(&b[4], f.count);
  put32(&b[8], f.param);
  return b;
}

ProtocolError decodeFault(std::span<const uint8_t> body, Fault* f) {
  if (auto e = checkSize(body, kFaultSize); e != ProtocolError::kOk) return e;
  const uint8_t* b = body.data();
  if (!allZero(b + 1, 3)) return ProtocolError::kReservedNonZero;
  if (b[0] == 0 || b[0] > kMaxFaultKind) return ProtocolError::kBadBody;
  f->kind = static_cast<FaultKind>(b[0]);
  f->count = get32(b + 4);
  f->param = get32(b + 8);
  return ProtocolError::kOk;
}

std::vector<uint8_t> encodeError(const ErrorBody& e) {
  std::vector<uint8_t> b(kErrorBodySize, 0);
  b[0] = static_cast<uint8_t>(e.error);
  put32(&b[4], e.offendingSequence);
  return b;
}

ProtocolError decodeError(std::span<const uint8_t> body, ErrorBody* e) {
  if (auto err = checkSize(body, kErrorBodySize); err != ProtocolError::kOk) return err;
  const uint8_t* b = body.data();
  if (!allZero(b + 1, 3)) return ProtocolError::kReservedNonZero;
  if (b[0] == 0 || b[0] > static_cast<uint8_t>(ProtocolError::kUnexpected)) {
    return ProtocolError::kBadBody;
  }
  e->error = static_cast<ProtocolError>(b[0]);
  e->offendingSequence = get32(b + 4);
  return ProtocolError::kOk;
}

std::vector<uint8_t> encodeSetMode(DisplayMode mode) {
  return {static_cast<uint8_t>(mode), 0, 0, 0};
}

ProtocolError decodeSetMode(std::span<const uint8_t> body, DisplayMode* mode) {
  if (auto e = checkSize(body, 4); e != ProtocolError::kOk) return e;
  if (!allZero(body.data() + 1, 3)) return ProtocolError::kReservedNonZero;
  if (body[0] > 1) return ProtocolError::kBadBody;
  *mode = static_cast<DisplayMode>(body[0]);
  return ProtocolError::kOk;
}

std::array<uint8_t, kChunkPrefixSize> encodeChunkPrefix(uint32_t frameSequence, uint32_t offset) {
  std::array<uint8_t, kChunkPrefixSize> b{};
  put32(&b[0], frameSequence);
  put32(&b[4], offset);
  return b;
}

ProtocolError decodeChunkPrefix(std::span<const uint8_t> body, uint32_t* frameSequence,
                                uint32_t* offset) {
  if (body.size() < kChunkPrefixSize) return ProtocolError::kTruncated;
  *frameSequence = get32(body.data());
  *offset = get32(body.data() + 4);
  return ProtocolError::kOk;
}

// ---- PacketReader ----

size_t PacketReader::feed(std::span<const uint8_t> bytes) {
  size_t used = 0;
  while (used < bytes.size() && !ready_ && error_ == ProtocolError::kOk) {
    if (!haveHeader_) {
      const size_t take = std::min(kHeaderSize - headerFill_, bytes.size() - used);
      if (take) std::memcpy(headerBytes_.data() + headerFill_, bytes.data() + used, take);
      headerFill_ += take;
      used += take;
      if (headerFill_ < kHeaderSize) break;
      error_ = decodeHeader(headerBytes_, &header_);
      if (error_ == ProtocolError::kBadVersion) peerVersion_ = headerVersion(headerBytes_);
      if (error_ != ProtocolError::kOk) break;
      haveHeader_ = true;
      payload_.resize(header_.payloadSize);
      payloadFill_ = 0;
    }
    const size_t take = std::min(payload_.size() - payloadFill_, bytes.size() - used);
    if (take) std::memcpy(payload_.data() + payloadFill_, bytes.data() + used, take);
    payloadFill_ += take;
    used += take;
    if (payloadFill_ == payload_.size()) {
      error_ = verifyPayload(header_, payload_);
      if (error_ == ProtocolError::kOk) ready_ = true;
    }
  }
  // A header that needs zero payload bytes completes without more input.
  if (haveHeader_ && !ready_ && error_ == ProtocolError::kOk && payload_.empty()) {
    error_ = verifyPayload(header_, payload_);
    if (error_ == ProtocolError::kOk) ready_ = true;
  }
  return used;
}

void PacketReader::next() {
  ready_ = false;
  haveHeader_ = false;
  headerFill_ = 0;
  payloadFill_ = 0;
  payload_.clear();
}

}  // namespace parallax::hw
