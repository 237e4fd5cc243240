#pragma once
// The host side of the link: pushes frames to modules and guarantees that every submitted
// frame ends in exactly one outcome the caller sees — delivered (the module verified its
// CRCs and shows it), skipped (the module already shows these bytes) or failed (with the
// reason) — whatever the transport does: lost chunks, flipped bytes, stalled devices, a
// disconnect, a crash. Retries, timeouts, keep-alive and reconnects live here, once, above
// any LinkTransport.
//
// "Skipped" means: the same bytes as the last frame accepted for that module; if that frame
// later fails, its own outcome says so and the next identical submit is sent again.
// Destroying a LinkClient abandons frames still pending: flush() first to hear about them.
// Not thread-safe: one thread (the render loop) owns a LinkClient.

#include <sys/uio.h>

#include <chrono>
#include <cstdint>
#include <deque>
#include <initializer_list>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hw/link/image.h"
#include "hw/link/link_protocol.h"
#include "hw/link/link_transport.h"

namespace parallax::hw {

struct LinkOptions {
  uint32_t chunkSize = 1u << 20;  // clamped to what the device accepts
  int windowFrames = 8;           // frames sent but not yet acknowledged
  int ackTimeoutMs = 2000;        // per attempt
  // A camera picture takes the camera's time (a DSLR exposes for seconds; the simulator first
  // builds its view from a new station): its reply is waited for this long.
  int captureTimeoutMs = 30000;
  int maxRetries = 3;      // attempts = 1 + maxRetries
  int keepAliveMs = 1000;  // idle time after which the link is probed before sending
  int reconnectAttempts = 5;
  int reconnectDelayMs = 50;  // doubled after each failed attempt
  // How long opening the transport waits for a device that does not take the connection (a
  // hung simulator stops accepting); a remote or slow peer may need more than a local one.
  int connectTimeoutMs = 1000;
  // The most the caller's thread (the render loop; in a cluster every rank waits for it) spends
  // blocked on a device that gives no sign of life: ack waits, resends, sends the device does
  // not take a byte of, and reconnects (attempts, pauses, Hello waits) together, counted from
  // the last packet heard. Then the link is down (see linkDownRetryMs). Time the caller spends
  // elsewhere (rendering) does not count: only waiting on the device. 3 s: one lost ack (an
  // ackTimeoutMs, 2 s) is retried first; a live device, even on a loaded machine, answers a
  // frame or a keep-alive within a fraction of that.
  int stallLimitMs = 3000;
  // After reconnecting failed, frames fail at once ("link down") for this long before the
  // next reconnect: a dead link must not cost every frame of the render loop a full back-off.
  // Doubled after each reconnect that failed in a row, up to linkDownRetryMaxMs.
  int linkDownRetryMs = 1000;
  int linkDownRetryMaxMs = 16000;
  // A reconnect try after that pause, the link being down, waits on the device at most this
  // long (its connects, Hello waits and pauses together; never more than stallLimitMs): it only
  // asks whether the device is back, which a live one answers within milliseconds. A device
  // that still hangs then holds the caller (in a cluster, the display) this long a try, not a
  // whole stall limit.
  int downRetryBudgetMs = 500;
  bool skipUnchanged = true;  // content hash: unchanged frames are not re-sent
  // A display frame whose image says which bytes can differ from the one the module shows
  // (Image::regions, same family) is sent as a patch of those bytes only (PROTOCOL.md).
  bool patchFrames = true;

  // Throws InputError naming the field (the [link] key of parallax.toml).
  void validate() const;
  bool operator==(const LinkOptions&) const = default;
};

// kSuperseded: the frame needed a resend, but a newer frame for the same module had been
// submitted meanwhile; resending the old one would show stale content after the new one, so
// it is dropped and reported instead. Frames of one module are therefore shown in order.
enum class FrameStatus { kPending, kDelivered, kSkippedUnchanged, kFailed, kSuperseded };
std::string_view frameStatusName(FrameStatus status);

struct FrameOutcome {
  uint64_t ticket = 0;
  int module = 0;
  FrameStatus status = FrameStatus::kPending;
  int attempts = 0;
  std::string reason;  // why it failed, or what the retries were for
};

struct LinkStats {
  uint64_t submitted = 0, delivered = 0, skipped = 0, failed = 0, superseded = 0;
  uint64_t attempts = 0, retries = 0, nacks = 0, timeouts = 0, reconnects = 0;
  uint64_t payloadBytesSent = 0, staleAcks = 0, keepAlives = 0;
  uint64_t hangs = 0;            // times the device answered nothing within stallLimitMs
  uint64_t patches = 0;          // frames first sent as patches (the bytes that could change)
  uint64_t patchesRefused = 0;   // of those, answered "not showing the patch's base": sent whole
  uint64_t patchBytesSaved = 0;  // bytes of frames the patches did not send
};

struct ModuleLinkInfo {
  int module = 0;
  DeviceInfo info;
};

class LinkClient {
 public:
  // Opens the transport and says hello; throws std::runtime_error with the transport's one-line
  // reason when the link cannot be brought up.
  LinkClient(std::unique_ptr<LinkTransport> transport, LinkOptions options = {});
  ~LinkClient();

  const std::vector<ModuleLinkInfo>& modules() const { return modules_; }

  // Queues a frame for `module`; returns its ticket. The pixels are borrowed through the
  // shared_ptr (no copy) until the frame's outcome is final. May block while the window is
  // full. Throws InputError for a frame the module cannot take (size, format, module index).
  // displayFrame 0: the module shows the frame once it is complete ("delivered" = shown).
  // displayFrame N > 0 (the swap lock): "delivered" = complete and held; it shows on present(N).
  // An unchanged frame for N is then not "skipped" silently: the module is told (no pixels
  // sent) that N is what it shows, and the outcome is kSkippedUnchanged once it agreed.
  uint64_t submit(int module, std::shared_ptr<const Image> frame, uint32_t displayFrame = 0);

  // Waits until every module submitted a frame for `displayFrame` has acknowledged it, or
  // until `deadline`. Returns the modules whose frame is not complete (late, failed, stalled):
  // present() shows the others without them.
  std::vector<int> awaitDisplayFrame(uint32_t displayFrame,
                                     std::chrono::steady_clock::time_point deadline);
  // Tells every module to show its frame for `displayFrame` (one packet, not answered). A
  // module without it keeps its frame, or goes dark when that would lag two display frames.
  // False when the link is down.
  bool present(uint32_t displayFrame);

  // Waits until every submitted frame has an outcome.
  void flush();

  // Outcomes that became final since the last call, in completion order.
  std::vector<FrameOutcome> takeOutcomes();

  // Round trip of a keep-alive; false when the device does not answer (after reconnecting).
  bool ping();
  // Mode change for every module; false if not acknowledged.
  bool setMode(DisplayMode mode);
  // Arms a fault on the simulator (ignored by real devices: they answer kUnsupported).
  bool injectFault(int module, const Fault& fault);
  // Asks the calibration camera for an image of what `viewModule` shows, with the given
  // settings (zeros keep the camera's current ones). Empty when there is no answer.
  Image capture(int viewModule, const CaptureRequest& settings = {});

  const LinkStats& stats() const { return stats_; }
  const LinkOptions& options() const { return options_; }
  // Counts the link's sessions: 1 after construction, +1 for every reconnect that got a Hello
  // back. A device that answered Hello again may have restarted and lost what it showed, so a
  // new session also forgets which content each module holds (the next submit of the same
  // bytes is sent, not skipped); a caller that keeps frames up compares this number and
  // submits them again when it changes.
  uint64_t sessions() const { return sessions_; }
  std::string transportName() const { return transport_->name(); }

 private:
  struct Pending {
    uint64_t ticket = 0;
    int module = 0;
    uint32_t sequence = 0;  // of the current attempt
    std::shared_ptr<const Image> frame;
    uint64_t hash = 0;
    uint32_t frameCrc = 0;
    uint32_t displayFrame = 0;
    bool reuse = false;               // the first attempt tells the module to keep what it shows
    std::vector<uint32_t> chunkCrcs;  // of the data of each chunk (of the whole frame)
    // The first attempt as a patch of the frame of hash baseHash: these byte ranges (each one
    // chunk) and the CRC of their data together. Empty: sent whole.
    std::vector<std::pair<uint32_t, uint32_t>> patch;
    uint32_t patchCrc = 0;
    uint64_t baseHash = 0;
    int attempts = 0;
    bool done = false;
    std::chrono::steady_clock::time_point deadline;
    std::string history;  // what went wrong with earlier attempts
  };
  using Clock = std::chrono::steady_clock;

  bool helloOk(int timeoutMs);
  // What is left of stallLimitMs (0: the device counts as hung).
  int stallLeftMs() const;
  // Frames await their acks, or a request its answer: the device's silence counts.
  bool expectingAnswers() const;
  // Sends within what is left of the stall limit (kTimeout: the device took no byte that long).
  TransportStatus sendWithinStallLimit(uint16_t module, std::span<const iovec> pieces);
  // A frame's send failed: a device that took no byte hangs (the link goes down; no reconnect
  // now: a hung device would not answer its Hello either); a dropped link reconnects.
  void afterFailedSend(TransportStatus status, const std::string& what);
  void declareHung(const std::string& doing);
  // The link is down for `what`: every pending frame fails, and the next reconnect waits the
  // growing pause (linkDownRetryMs).
  void goDown(const std::string& what);
  // Closes, reopens (bounded attempts with back-off), says hello and resends what was in
  // flight; when it cannot, fails every pending frame with the reason. False if still down.
  bool reconnect(const std::string& why);
  TransportStatus sendFrame(Pending& p);
  // The chunks of a patch of `frame` for `module`, when the module was last given an image of
  // the same family, accepted so far, and the bytes that can differ are fewer than three
  // quarters of the frame; none: nothing can differ. nullopt: send it whole.
  std::optional<std::vector<std::pair<uint32_t, uint32_t>>> patchFor(int module, const Image& frame,
                                                                     uint32_t displayFrame) const;
  // The CRCs of the whole frame's chunks (a patch sent whole works them out when it must).
  void wholeFrameCrcs(Pending& p) const;
  // Receives for up to timeoutMs, applies acks, handles deadlines and a lost link.
  TransportStatus pump(int timeoutMs);
  void waitForProgress();
  void handle(const ReceivedPacket& packet);
  void retryOrFail(Pending& p, const std::string& why);
  // True (and the frame finished as superseded) when a newer frame for its module exists.
  bool supersede(Pending& p);
  void finish(Pending& p, FrameStatus status, const std::string& reason);
  void checkDeadlines();
  void prune();
  // Sends a small control packet and waits for a packet of one of `answers` types with the
  // same sequence number.
  // Waits `timeoutMs` for the answer (0: ackTimeoutMs).
  bool request(PacketType type, uint16_t module, std::span<const uint8_t> body,
               std::initializer_list<PacketType> answers, ReceivedPacket* reply, int timeoutMs = 0);
  uint32_t nextSequence() { return ++sequence_; }

  std::unique_ptr<LinkTransport> transport_;
  LinkOptions options_;
  std::vector<ModuleLinkInfo> modules_;
  uint32_t chunkSize_ = 0;
  std::deque<Pending> pending_;          // sent, awaiting ack
  std::vector<uint64_t> submittedHash_;  // per module: content of the last accepted submit
  std::vector<bool> hashValid_;
  std::vector<uint64_t> submittedFamily_;  // per module: ImageRegions::family of it (0: none)
  std::vector<uint64_t> latestTicket_;     // per module: the newest submitted frame
  std::vector<uint32_t> readyFrame_;       // per module: the display frame it acknowledged last
  std::vector<uint32_t> submittedFrame_;   // per module: the display frame of the newest submit
  std::vector<FrameOutcome> outcomes_;
  std::vector<ReceivedPacket> inbox_;  // control replies that arrived while pumping
  std::vector<HeaderBytes> scratchHeaders_;
  std::vector<std::array<uint8_t, kChunkPrefixSize>> scratchPrefixes_;
  std::vector<iovec> scratchIov_;
  std::string lastDeviceError_;
  LinkStats stats_;
  uint32_t sequence_ = 0;
  uint64_t ticket_ = 0;
  uint64_t sessions_ = 0;
  bool reconnecting_ = false;
  bool awaitingReply_ = false;   // a request waits for its answer (stall limit)
  Clock::time_point downUntil_;  // no reconnect attempts before this
  bool down_ = false;            // reconnecting failed, or the device hung; not back since
  int quietMs_ = 0;              // the pause after the next failed reconnect
  std::string downReason_;
  Clock::time_point lastHeard_;
  Clock::duration silence_{};  // waited on the device since it was last heard (stallLimitMs)
};

}  // namespace parallax::hw
