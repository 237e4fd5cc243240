#pragma once
// The Parallax link protocol, version 3 (hw/link/PROTOCOL.md is the normative description; this
// header is its executable form). Every packet is a 32-byte little-endian header followed by
// `payloadSize` bytes whose CRC-32C the header carries; the header has its own CRC so that a
// corrupted length can never desynchronise a stream silently.
//
// Packets arrive from untrusted peers: every decode function checks sizes, magic, version,
// reserved fields and CRCs, and reports the first problem as a specific ProtocolError.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace parallax::hw {

constexpr uint32_t kLinkMagic = 0x4C584C50u;  // bytes "PLXL" on the wire
// Version 2 separates upload from presentation (swap lock): a frame for display frame N is
// acknowledged when complete and shown only on Present(N). Version 3 adds patch frames: only
// the bytes that changed since the frame the module shows. Other versions are refused.
constexpr uint16_t kLinkVersion = 3;
constexpr size_t kHeaderSize = 32;
constexpr uint32_t kMaxPayloadSize = 16u << 20;  // larger packets are hostile
constexpr uint16_t kAllModules = 0xFFFF;         // module field of broadcast requests
constexpr uint16_t kCameraModule = 0xFFFE;       // module field of camera traffic

enum class PacketType : uint8_t {
  kHello = 1,           // host -> device: open a session, ask for DeviceInfo
  kDeviceInfo = 2,      // device -> host: one per module
  kSetMode = 3,         // host -> device: pattern or playback mode
  kFrameBegin = 4,      // host -> device: a frame follows in chunks
  kFrameChunk = 5,      // host -> device: offset + bytes
  kFrameEnd = 6,        // host -> device: all chunks sent, verify and acknowledge
  kAck = 7,             // device -> host: result of a frame or command
  kKeepAlive = 8,       // both ways: liveness; the device echoes the sequence
  kCaptureRequest = 9,  // host -> camera
  kCaptureReply = 10,   // camera -> host: an image
  kFault = 11,          // host -> simulator only: inject a fault
  kError = 12,          // either way: the peer's last packet was rejected (then closes)
  kPresent = 13,        // host -> device: show the acknowledged frame N now (not answered)
};
constexpr uint8_t kMaxPacketType = 13;

// Why a packet or a stream was rejected. Stable numbers: they travel in kError packets.
enum class ProtocolError : uint8_t {
  kOk = 0,
  kTruncated = 1,  // fewer bytes than the header or the body needs
  kBadMagic = 2,
  kBadVersion = 3,
  kBadHeaderCrc = 4,
  kUnknownType = 5,
  kOversized = 6,  // payloadSize above kMaxPayloadSize or the body's limit
  kReservedNonZero = 7,
  kBadPayloadCrc = 8,
  kBadBody = 9,      // a body field out of range (size mismatch, bad format, ...)
  kUnexpected = 10,  // valid packet at the wrong time (chunk without a frame, ...)
};
std::string_view protocolErrorName(ProtocolError error);

enum class PixelFormat : uint8_t { kRgb8 = 1, kGray8 = 2 };
int bytesPerPixel(PixelFormat format);
bool isKnownPixelFormat(uint8_t value);

enum class DisplayMode : uint8_t { kPlayback = 0, kPattern = 1 };

// Byte layout (offsets): magic 0, version 4, type 6, flags 7, module 8, reserved 10,
// sequence 12, payloadSize 16, payloadCrc 20, reserved 24, headerCrc 28 (CRC-32C of 0..27).
struct PacketHeader {
  PacketType type = PacketType::kKeepAlive;
  uint8_t flags = 0;
  uint16_t module = 0;
  uint32_t sequence = 0;
  uint32_t payloadSize = 0;
  uint32_t payloadCrc = 0;
};

using HeaderBytes = std::array<uint8_t, kHeaderSize>;

// Fills in payloadSize and payloadCrc from the payload.
HeaderBytes encodeHeader(PacketHeader header, std::span<const uint8_t> payload);
// Uses the given payloadSize and payloadCrc (for payloads sent in pieces by writev).
HeaderBytes encodeHeaderRaw(const PacketHeader& header);
// Checks everything the header alone can tell: size, magic, version, header CRC, type,
// reserved fields, payloadSize limit.
ProtocolError decodeHeader(std::span<const uint8_t> bytes, PacketHeader* header);
// The version field of a header (for the message naming a peer of another version).
uint16_t headerVersion(std::span<const uint8_t> bytes);
ProtocolError verifyPayload(const PacketHeader& header, std::span<const uint8_t> payload);

// ---- bodies (fixed little-endian layouts, see PROTOCOL.md) ----

struct DeviceInfo {          // 64 bytes
  uint16_t moduleCount = 0;  // modules behind this device (the simulator: all of them)
  uint32_t width = 0, height = 0;
  uint32_t pixelFormats = 0;     // bit (1 << PixelFormat)
  uint32_t firmwareVersion = 0;  // major << 16 | minor
  uint32_t maxChunkSize = 0;     // largest FrameChunk data the device accepts
  std::string serial;            // up to 40 bytes, NUL-padded
};
constexpr size_t kDeviceInfoSize = 64;
constexpr size_t kSerialBytes = 40;

// FrameBegin flag: no chunks follow; the frame is the one the module shows (same content hash),
// acknowledged for `displayFrame` without its bytes crossing the link again.
constexpr uint16_t kFrameReuse = 1;
// FrameBegin flag: the frame is the one the module shows (content hash `baseHash`) with the
// chunks' bytes written over it; the chunks come in order without overlap, gaps between them
// keep the shown bytes, and frameCrc covers the chunks' data only.
constexpr uint16_t kFramePatch = 2;

struct FrameBegin {  // 48 bytes
  uint32_t width = 0, height = 0;
  PixelFormat format = PixelFormat::kRgb8;
  DisplayMode mode = DisplayMode::kPlayback;
  uint16_t flags = 0;      // kFrameReuse, kFramePatch or 0
  uint32_t totalSize = 0;  // width · height · bytesPerPixel
  uint32_t chunkCount = 0;
  uint32_t frameCrc = 0;     // CRC-32C of the whole frame (a patch: of its chunks' data)
  uint64_t contentHash = 0;  // the host's content hash (the device keeps it; kFrameReuse checks it)
  // The display frame this upload belongs to: held after its Ack until Present(displayFrame).
  // 0: shown as soon as it is complete (patterns, single frames, restoring a restarted module).
  uint32_t displayFrame = 0;
  uint64_t baseHash = 0;  // kFramePatch: the content hash of the frame patched; else 0
};
constexpr size_t kFrameBeginSize = 48;

struct Present {  // 8 bytes: u32 displayFrame, 4 reserved
  uint32_t displayFrame = 0;
};
constexpr size_t kPresentSize = 8;
constexpr size_t kChunkPrefixSize = 8;  // FrameChunk: u32 frameSequence, u32 offset, then data

enum class AckStatus : uint8_t {
  kOk = 0,
  kCrcMismatch = 1,    // a chunk or the whole frame failed its CRC
  kMissingChunks = 2,  // FrameEnd before every byte arrived
  kBadFrame = 3,       // FrameBegin rejected (size, format, resolution)
  kUnsupported = 4,    // request not supported by this device
  kBaseMismatch = 5,   // a patch whose base is not the frame the module shows
};
std::string_view ackStatusName(AckStatus status);

struct Ack {  // 12 bytes
  uint32_t ackedSequence = 0;
  AckStatus status = AckStatus::kOk;
  uint32_t detail = 0;  // e.g. bytes received
};
constexpr size_t kAckSize = 12;

struct CaptureRequest {     // 16 bytes
  uint16_t viewModule = 0;  // which module's light the simulated camera looks at
  uint32_t exposureUs = 0;  // 0 = keep the locked value
  uint16_t gainCenti = 0;   // gain × 100, 0 = keep
  uint16_t station = 0;     // where the camera stands (the simulator moves it; a rig may ignore it)
  uint16_t flags = 0;       // kCaptureColour or 0
  uint16_t whiteBalanceRedCenti = 0;   // red / green × 100, 0 = keep
  uint16_t whiteBalanceBlueCenti = 0;  // blue / green × 100, 0 = keep
};
constexpr size_t kCaptureRequestSize = 16;
// CaptureRequest flag: an RGB picture (photometric calibration); without it the camera may
// answer grey (the geometric patterns need no colour).
constexpr uint16_t kCaptureColour = 1;

struct CaptureReplyHeader {  // 16 bytes, then width · height · bpp pixel bytes
  uint32_t width = 0, height = 0;
  PixelFormat format = PixelFormat::kRgb8;
  uint32_t requestSequence = 0;
};
constexpr size_t kCaptureReplyHeaderSize = 16;

enum class FaultKind : uint8_t {
  kDropChunks = 1,  // the next `count` chunks to this module vanish
  kFlipBytes = 2,   // the next `count` chunks arrive with one byte flipped
  kStall = 3,       // the next `count` frames are never acknowledged (after `param` that are)
  kSlowLink = 4,    // each chunk costs `param` microseconds, for `count` chunks
  kDisconnect = 5,  // the device drops the connection (the host must reconnect)
  kCrash = 6,       // the simulator process aborts
};
constexpr uint8_t kMaxFaultKind = 6;
std::string_view faultKindName(FaultKind kind);

struct Fault {  // 12 bytes
  FaultKind kind = FaultKind::kDropChunks;
  uint32_t count = 1;
  uint32_t param = 0;
};
constexpr size_t kFaultSize = 12;

struct ErrorBody {  // 8 bytes
  ProtocolError error = ProtocolError::kOk;
  uint32_t offendingSequence = 0;
};
constexpr size_t kErrorBodySize = 8;

std::vector<uint8_t> encodeDeviceInfo(const DeviceInfo& info);
ProtocolError decodeDeviceInfo(std::span<const uint8_t> body, DeviceInfo* info);
std::vector<uint8_t> encodeFrameBegin(const FrameBegin& begin);
ProtocolError decodeFrameBegin(std::span<const uint8_t> body, FrameBegin* begin);
std::vector<uint8_t> encodePresent(const Present& present);
ProtocolError decodePresent(std::span<const uint8_t> body, Present* present);
std::vector<uint8_t> encodeAck(const Ack& ack);
ProtocolError decodeAck(std::span<const uint8_t> body, Ack* ack);
std::vector<uint8_t> encodeCaptureRequest(const CaptureRequest& request);
ProtocolError decodeCaptureRequest(std::span<const uint8_t> body, CaptureRequest* request);
std::vector<uint8_t> encodeCaptureReplyHeader(const CaptureReplyHeader& reply);
ProtocolError decodeCaptureReplyHeader(std::span<const uint8_t> body, CaptureReplyHeader* reply);
std::vector<uint8_t> encodeFault(const Fault& fault);
ProtocolError decodeFault(std::span<const uint8_t> body, Fault* fault);
std::vector<uint8_t> encodeError(const ErrorBody& error);
ProtocolError decodeError(std::span<const uint8_t> body, ErrorBody* error);
std::vector<uint8_t> encodeSetMode(DisplayMode mode);
ProtocolError decodeSetMode(std::span<const uint8_t> body, DisplayMode* mode);
std::array<uint8_t, kChunkPrefixSize> encodeChunkPrefix(uint32_t frameSequence, uint32_t offset);
ProtocolError decodeChunkPrefix(std::span<const uint8_t> body, uint32_t* frameSequence,
                                uint32_t* offset);

// A whole packet in one buffer (small control packets; frames use writev instead).
std::vector<uint8_t> encodePacket(PacketHeader header, std::span<const uint8_t> payload);

// Splits a byte stream into packets. Feed it what arrives; it never trusts a length before
// the header CRC has matched and never buffers more than one packet.
class PacketReader {
 public:
  // Appends bytes; returns the number consumed (all of them unless an error stopped it).
  size_t feed(std::span<const uint8_t> bytes);
  // True when a complete, verified packet is ready; take it with header()/payload(), then
  // call next().
  bool ready() const { return ready_; }
  const PacketHeader& header() const { return header_; }
  std::span<const uint8_t> payload() const { return payload_; }
  void next();
  // The first error seen; once set, the stream is unusable (no resynchronisation).
  ProtocolError error() const { return error_; }
  // With error() == kBadVersion: the version the peer speaks.
  uint16_t peerVersion() const { return peerVersion_; }

 private:
  std::array<uint8_t, kHeaderSize> headerBytes_{};
  size_t headerFill_ = 0;
  bool haveHeader_ = false;
  bool ready_ = false;
  PacketHeader header_;
  std::vector<uint8_t> payload_;
  size_t payloadFill_ = 0;
  ProtocolError error_ = ProtocolError::kOk;
  uint16_t peerVersion_ = 0;
};

}  // namespace parallax::hw
