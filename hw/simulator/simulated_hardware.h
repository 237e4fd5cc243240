#pragma once
// The simulated hardware: N optical modules and one calibration camera that speak the link
// protocol exactly like real devices (a first-class backend, not a mock). Transport-free: the
// socket server (simhw_server.h) and the fuzz target feed it packets; it answers with packets.
//
// Each module double-buffers: chunks land in a receive buffer and only a frame whose every
// chunk CRC and whole-frame CRC verified replaces the shown frame, so a damaged upload never
// shows and never goes unreported. A frame of a display frame (FrameBegin.displayFrame > 0) is
// held, complete and acknowledged, until Present(displayFrame) swaps it in (the swap lock;
// PROTOCOL.md, "Presentation"). Every present is recorded (presents()).

#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "hw/link/image.h"
#include "hw/link/link_protocol.h"
#include "hw/simulator/camera_physics.h"

namespace parallax::hw {

struct SimulatedHardwareOptions {
  int modules = 16;
  int width = 512, height = 384;
  std::string serialPrefix = "SIM";
  uint32_t maxChunkSize = 4u << 20;
  uint32_t firmwareVersion = (1u << 16) | 0u;

  // Throws InputError naming the option.
  void validate() const;
};

// Faults armed on one module; each counter decrements as the fault fires.
struct ArmedFaults {
  uint32_t dropChunks = 0;
  uint32_t flipChunks = 0;
  uint32_t stallFrames = 0;
  uint32_t stallAfter = 0;  // frames acknowledged normally before the stall starts
  uint32_t slowChunks = 0;
  uint32_t slowMicroseconds = 0;
  uint32_t disconnects = 0;  // fire at the module's next FrameBegin
  bool crash = false;        // fires at the module's next FrameBegin
};

struct ModuleCounters {
  uint64_t framesShown = 0;     // verified and swapped in
  uint64_t framesRejected = 0;  // negatively acknowledged
  uint64_t chunksDropped = 0, bytesFlipped = 0, acksStalled = 0;
  uint64_t bytesReceived = 0;
  uint64_t framesLate = 0;      // complete only after their Present: never shown
  uint64_t presentsMissed = 0;  // a Present came without this module's frame
  uint64_t blanked = 0;         // went dark rather than lag two display frames
  // Bytes of the shown frame copied under patches: only what changed since the frame the
  // upload buffer held, or the whole frame when that is not known.
  uint64_t patchBaseBytes = 0;
};

// What one module shows after one Present: the swap lock's record (the tests read it, and
// parallax-simhw --dump writes it as presents.tsv).
struct PresentRecord {
  uint32_t displayFrame = 0;  // the Present's
  int module = 0;
  uint32_t shows = 0;     // the display frame it shows after it (0: dark)
  bool switched = false;  // it swapped a new frame in (or went dark) at this Present
  int64_t atNs = 0;       // CLOCK_MONOTONIC (same clock in every process of the machine)
};

// What the connection must do after a packet.
struct SimAction {
  bool close = false;              // drop the connection (a disconnect fault or a protocol error)
  bool crash = false;              // abort the process (a crash fault)
  uint32_t sleepMicroseconds = 0;  // a slow link
};

class SimulatedHardware {
 public:
  using ByteSpan = std::pair<uint64_t, uint64_t>;  // offset, size (a patch's chunk)

  explicit SimulatedHardware(SimulatedHardwareOptions options,
                             std::unique_ptr<CameraPhysics> physics = nullptr);

  // A complete packet (header already decoded, payload CRC not yet checked). Replies are
  // appended to `replies` as encoded packets.
  SimAction handlePacket(const PacketHeader& header, std::span<const uint8_t> payload,
                         std::vector<uint8_t>* replies);

  // Zero-copy path for frame chunks: where `dataSize` bytes of chunk data for `header` should
  // be read to, or nullptr when they are to be discarded (no frame in progress, out of range).
  uint8_t* chunkDestination(const PacketHeader& header, uint32_t frameSequence, uint32_t offset,
                            size_t dataSize);
  // After the data arrived (at chunkDestination or elsewhere): verifies the packet CRC
  // (prefix + data), applies faults and records coverage.
  SimAction finishChunk(const PacketHeader& header, uint32_t frameSequence, uint32_t offset,
                        std::span<uint8_t> data, std::vector<uint8_t>* replies);

  // A protocol error on the connection: the kError reply to send before closing.
  static void appendError(ProtocolError error, uint32_t sequence, std::vector<uint8_t>* replies);

  void arm(int module, const Fault& fault);
  // Called (on the serving thread) each time a module shows a new frame.
  void setOnShown(std::function<void()> onShown) { onShown_ = std::move(onShown); }
  // Called (on the serving thread) after a SetMode, before it is acknowledged.
  void setOnModeChanged(std::function<void()> onModeChanged) {
    onModeChanged_ = std::move(onModeChanged);
  }
  // A new connection starts: partial uploads are abandoned (the host resends them).
  void resetSession();

  int moduleCount() const { return static_cast<int>(modules_.size()); }
  const Image& shownFrame(int module) const;
  uint64_t shownContentHash(int module) const;
  const ModuleCounters& counters(int module) const;
  // The display frame `module` shows (0: none, dark, or a frame shown outside the swap lock
  // before any Present).
  uint32_t shownDisplayFrame(int module) const;
  // The latest presents, oldest first (bounded: the last kPresentRecords).
  const std::deque<PresentRecord>& presents() const { return presents_; }
  static constexpr size_t kPresentRecords = 1 << 16;
  // Writes presents() as a tab-separated table with a header line.
  void writePresents(const std::string& path) const;
  DisplayMode mode() const { return mode_; }
  const CameraSettings& cameraSettings() const { return camera_; }
  const SimulatedHardwareOptions& options() const { return options_; }

 private:
  struct Upload {
    bool active = false;
    bool damaged = false;  // a chunk failed its CRC
    uint32_t sequence = 0;
    FrameBegin begin;
    uint64_t covered = 0;      // bytes received in verified chunks
    bool hasRejected = false;  // the FrameBegin of `rejectedSequence` was refused
    uint32_t rejectedSequence = 0;
    bool outOfOrder = false;    // a verified chunk did not start where the previous one ended
                                // (a patch's: before it ended)
    uint64_t next = 0;          // where the previous verified chunk ended
    bool baseMismatch = false;  // a patch of a frame the module does not show
    uint32_t runningCrc = 0;    // CRC-32C of the verified chunks' data, in order
    uint32_t chunks = 0;
    std::vector<uint8_t> buffer;
    std::vector<ByteSpan> written;  // a patch's verified chunks, in order
    // A patch's: where the buffer may differ from its base (the frame shown), sorted; the
    // base's bytes are copied there at FrameEnd, except where a chunk wrote.
    std::vector<ByteSpan> stale;
  };
  // A patch frame completed: its content (the hash it declared) is its base's with `written`
  // replaced.
  struct PatchRecord {
    uint64_t hash = 0, base = 0;
    std::vector<ByteSpan> written;
  };
  static constexpr size_t kPatchRecords = 4;
  // A complete frame waiting for its Present.
  struct Ready {
    uint32_t displayFrame = 0;  // 0: none
    bool reuse = false;         // the frame shown now, acknowledged for another display frame
    FrameBegin begin;
    std::vector<uint8_t> pixels;
  };
  struct Module {
    std::string serial;
    Image shown;
    uint64_t shownHash = 0;
    uint32_t shownFrame = 0;  // display frame shown (0: none or dark)
    uint32_t presented = 0;   // the last Present this module saw
    Ready ready;
    Upload upload;
    // The content each pixel buffer holds, as the hash its frame declared (0: unknown, or an
    // upload that did not complete). A patch then brings the upload buffer to its base by
    // copying only what the patches since that buffer's frame wrote and its own chunks do not
    // (the buffers rotate: upload, ready, shown), not the whole frame shown.
    uint64_t readyHolds = 0, uploadHolds = 0;
    std::deque<PatchRecord> patches;  // the latest, newest last
    ArmedFaults faults;
    ModuleCounters counters;
  };

  void appendReply(PacketType type, uint16_t module, uint32_t sequence,
                   std::span<const uint8_t> body, std::vector<uint8_t>* replies);
  void ack(uint16_t module, uint32_t sequence, AckStatus status, uint32_t detail,
           std::vector<uint8_t>* replies);
  SimAction frameBegin(Module& m, const PacketHeader& header, std::span<const uint8_t> payload,
                       std::vector<uint8_t>* replies);
  void frameEnd(Module& m, const PacketHeader& header, std::vector<uint8_t>* replies);
  // Puts a verified upload on screen now (displayFrame 0) or holds it for its Present.
  void complete(Module& m, Upload& u);
  void present(Module& m, int index, uint32_t displayFrame, int64_t nowNs);
  // A patch starts: the upload buffer, which holds `holds`, is made the frame shown (its base)
  // at once when the patches between are not known, else where they wrote at FrameEnd
  // (finishPatchBase), outside this patch's chunks.
  void startPatchBase(Module& m, uint64_t holds);
  void finishPatchBase(Module& m);
  ProtocolError capture(const PacketHeader& header, std::span<const uint8_t> payload,
                        std::vector<uint8_t>* replies);

  SimulatedHardwareOptions options_;
  std::unique_ptr<CameraPhysics> physics_;
  std::vector<Module> modules_;
  CameraSettings camera_;
  DisplayMode mode_ = DisplayMode::kPlayback;
  std::function<void()> onShown_, onModeChanged_;
  std::deque<PresentRecord> presents_;
};

}  // namespace parallax::hw
