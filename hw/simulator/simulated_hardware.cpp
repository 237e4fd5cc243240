#include "hw/simulator/simulated_hardware.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <utility>

#include "common/check.h"
#include "common/input_error.h"
#include "hw/link/crc32c.h"

namespace parallax::hw {

void SimulatedHardwareOptions::validate() const {
  if (modules < 1 || modules > 4096) {
    throw InputError({"", "modules", 0}, fmt::format("must be in 1..4096, got {}", modules));
  }
  if (width < 1 || height < 1 || width > 16384 || height > 16384) {
    throw InputError({"", "resolution", 0},
                     fmt::format("must be in 1..16384 per side, got {}x{}", width, height));
  }
  if (static_cast<uint64_t>(width) * height * 3 > 0xFFFFFFFFull) {
    throw InputError({"", "resolution", 0}, "a frame must fit in 4 GiB");
  }
  if (maxChunkSize < 4096 || maxChunkSize > kMaxPayloadSize - kChunkPrefixSize) {
    throw InputError({"", "max_chunk", 0},
                     fmt::format("must be in 4096..{}, got {}", kMaxPayloadSize - kChunkPrefixSize,
                                 maxChunkSize));
  }
  if (serialPrefix.size() > 24) throw InputError({"", "serial_prefix", 0}, "at most 24 characters");
}

Image RawPatternPhysics::render(std::span<const Image* const> frames, int viewModule,
                                int /*station*/, const CameraSettings& settings) const {
  // The raw pattern: what the module shows, as it shows it (no optics, no exposure model).
  if (viewModule < 0 || viewModule >= static_cast<int>(frames.size()) || !frames[viewModule]) {
    return {};
  }
  return *frames[viewModule];
}

SimulatedHardware::SimulatedHardware(SimulatedHardwareOptions options,
                                     std::unique_ptr<CameraPhysics> physics)
    : options_(std::move(options)), physics_(std::move(physics)) {
  options_.validate();
  if (!physics_) physics_ = std::make_unique<RawPatternPhysics>();
  modules_.resize(options_.modules);
  for (int i = 0; i < options_.modules; ++i) {
    modules_[i].serial = fmt::format("{}{:04d}", options_.serialPrefix, i);
  }
}

const Image& SimulatedHardware::shownFrame(int module) const { return modules_.at(module).shown; }
uint64_t SimulatedHardware::shownContentHash(int module) const {
  return modules_.at(module).shownHash;
}
const ModuleCounters& SimulatedHardware::counters(int module) const {
  return modules_.at(module).counters;
}
uint32_t SimulatedHardware::shownDisplayFrame(int module) const {
  return modules_.at(module).shownFrame;
}

void SimulatedHardware::resetSession() {
  for (Module& m : modules_) {
    m.upload.active = false;
    m.ready.displayFrame = 0;  // held frames die with the session; the host sends them again
  }
}

void SimulatedHardware::writePresents(const std::string& path) const {
  std::ofstream out(path);
  out << "display_frame\tmodule\tshows\tswitched\tat_ns\n";
  for (const PresentRecord& r : presents_) {
    out << r.displayFrame << '\t' << r.module << '\t' << r.shows << '\t' << (r.switched ? 1 : 0)
        << '\t' << r.atNs << '\n';
  }
  if (!out) throw std::runtime_error(fmt::format("cannot write {}", path));
}

void SimulatedHardware::arm(int module, const Fault& fault) {
  ArmedFaults& f = modules_.at(module).faults;
  switch (fault.kind) {
    case FaultKind::kDropChunks:
      f.dropChunks += fault.count;
      break;
    case FaultKind::kFlipBytes:
      f.flipChunks += fault.count;
      break;
    case FaultKind::kStall:
      f.stallFrames += fault.count;
      f.stallAfter = fault.param;
      break;
    case FaultKind::kSlowLink:
      f.slowChunks += fault.count;
      f.slowMicroseconds = fault.param;
      break;
    case FaultKind::kDisconnect:
      f.disconnects += fault.count;
      break;
    case FaultKind::kCrash:
      f.crash = true;
      break;
  }
}

void SimulatedHardware::appendReply(PacketType type, uint16_t module, uint32_t sequence,
                                    std::span<const uint8_t> body, std::vector<uint8_t>* replies) {
  PacketHeader h;
  h.type = type;
  h.module = module;
  h.sequence = sequence;
  const HeaderBytes bytes = encodeHeader(h, body);
  replies->insert(replies->end(), bytes.begin(), bytes.end());
  replies->insert(replies->end(), body.begin(), body.end());
}

void SimulatedHardware::ack(uint16_t module, uint32_t sequence, AckStatus status, uint32_t detail,
                            std::vector<uint8_t>* replies) {
  appendReply(PacketType::kAck, module, sequence, encodeAck({sequence, status, detail}), replies);
}

void SimulatedHardware::appendError(ProtocolError error, uint32_t sequence,
                                    std::vector<uint8_t>* replies) {
  PacketHeader h;
  h.type = PacketType::kError;
  h.module = kAllModules;
  h.sequence = sequence;
  const std::vector<uint8_t> body = encodeError({error, sequence});
  const HeaderBytes bytes = encodeHeader(h, body);
  replies->insert(replies->end(), bytes.begin(), bytes.end());
  replies->insert(replies->end(), body.begin(), body.end());
}

SimAction SimulatedHardware::handlePacket(const PacketHeader& header,
                                          std::span<const uint8_t> payload,
                                          std::vector<uint8_t>* replies) {
  SimAction action;
  // Chunks check their CRC in finishChunk (after fault injection, as a real receiver would);
  // a damaged chunk fails its frame, not the connection.
  if (header.type != PacketType::kFrameChunk) {
    if (const ProtocolError e = verifyPayload(header, payload); e != ProtocolError::kOk) {
      appendError(e, header.sequence, replies);
      action.close = true;
      return action;
    }
  }
  const bool moduleAddressed = header.module < modules_.size();
  // A protocol error closes the connection: the peer is broken or hostile, and a stream
  // cannot be trusted after it.
  auto reject = [&](ProtocolError e) {
    appendError(e, header.sequence, replies);
    action.close = true;
    return action;
  };

  switch (header.type) {
    case PacketType::kHello: {
      if (!payload.empty()) return reject(ProtocolError::kOversized);
      for (size_t i = 0; i < modules_.size(); ++i) {
        DeviceInfo info;
        info.moduleCount = static_cast<uint16_t>(modules_.size());
        info.width = options_.width;
        info.height = options_.height;
        info.pixelFormats = (1u << static_cast<int>(PixelFormat::kRgb8)) |
                            (1u << static_cast<int>(PixelFormat::kGray8));
        info.firmwareVersion = options_.firmwareVersion;
        info.maxChunkSize = options_.maxChunkSize;
        info.serial = modules_[i].serial;
        appendReply(PacketType::kDeviceInfo, static_cast<uint16_t>(i), header.sequence,
                    encodeDeviceInfo(info), replies);
      }
      return action;
    }
    case PacketType::kSetMode: {
      DisplayMode mode;
      if (const ProtocolError e = decodeSetMode(payload, &mode); e != ProtocolError::kOk) {
        return reject(e);
      }
      mode_ = mode;
      if (onModeChanged_) onModeChanged_();
      ack(header.module, header.sequence, AckStatus::kOk, 0, replies);
      return action;
    }
    case PacketType::kKeepAlive:
      if (!payload.empty()) return reject(ProtocolError::kOversized);
      appendReply(PacketType::kKeepAlive, header.module, header.sequence, {}, replies);
      return action;
    case PacketType::kFrameBegin:
      if (!moduleAddressed) return reject(ProtocolError::kBadBody);
      return frameBegin(modules_[header.module], header, payload, replies);
    case PacketType::kFrameChunk: {
      uint32_t frameSequence, offset;
      if (const ProtocolError e = decodeChunkPrefix(payload, &frameSequence, &offset);
          e != ProtocolError::kOk) {
        return reject(e);
      }
      const size_t dataSize = payload.size() - kChunkPrefixSize;
      uint8_t* dst = chunkDestination(header, frameSequence, offset, dataSize);
      std::vector<uint8_t> scratch;
      std::span<uint8_t> data;
      if (dst) {
        std::copy(payload.begin() + kChunkPrefixSize, payload.end(), dst);
        data = {dst, dataSize};
      } else {
        scratch.assign(payload.begin() + kChunkPrefixSize, payload.end());
        data = scratch;
      }
      return finishChunk(header, frameSequence, offset, data, replies);
    }
    case PacketType::kFrameEnd:
      if (!moduleAddressed) return reject(ProtocolError::kBadBody);
      if (!payload.empty()) return reject(ProtocolError::kOversized);
      frameEnd(modules_[header.module], header, replies);
      return action;
    case PacketType::kCaptureRequest:
      if (header.module != kCameraModule) return reject(ProtocolError::kBadBody);
      if (const ProtocolError e = capture(header, payload, replies); e != ProtocolError::kOk) {
        return reject(e);
      }
      return action;
    case PacketType::kFault: {
      Fault fault;
      if (const ProtocolError e = decodeFault(payload, &fault); e != ProtocolError::kOk) {
        return reject(e);
      }
      if (!moduleAddressed) return reject(ProtocolError::kBadBody);
      arm(header.module, fault);
      ack(header.module, header.sequence, AckStatus::kOk, 0, replies);
      return action;
    }
    case PacketType::kPresent: {
      Present present;
      if (const ProtocolError e = decodePresent(payload, &present); e != ProtocolError::kOk) {
        return reject(e);
      }
      if (!moduleAddressed && header.module != kAllModules) return reject(ProtocolError::kBadBody);
      // One clock reading for every module of this Present: they switch together.
      const int64_t now = std::chrono::duration_cast<std::chrono::nanoseconds>(
                              std::chrono::steady_clock::now().time_since_epoch())
                              .count();
      for (size_t i = 0; i < modules_.size(); ++i) {
        if (header.module == kAllModules || header.module == i)
          this->present(modules_[i], static_cast<int>(i), present.displayFrame, now);
      }
      if (onShown_) onShown_();
      return action;  // not answered: a Present costs the link one small packet
    }
    case PacketType::kDeviceInfo:
    case PacketType::kAck:
    case PacketType::kCaptureReply:
      return reject(ProtocolError::kUnexpected);  // device-to-host packets
    case PacketType::kError:
      action.close = true;  // the host gave up on us; nothing to answer
      return action;
  }
  return reject(ProtocolError::kUnknownType);
}

SimAction SimulatedHardware::frameBegin(Module& m, const PacketHeader& header,
                                        std::span<const uint8_t> payload,
                                        std::vector<uint8_t>* replies) {
  SimAction action;
  FrameBegin begin;
  if (const ProtocolError e = decodeFrameBegin(payload, &begin); e != ProtocolError::kOk) {
    appendError(e, header.sequence, replies);
    action.close = true;
    return action;
  }
  // Faults that act on the whole link fire as the frame starts, before anything is acked.
  if (m.faults.crash) {
    m.faults.crash = false;  // a restarted simulator (in-process tests) does not crash again
    action.crash = true;
    return action;
  }
  if (m.faults.disconnects > 0) {
    --m.faults.disconnects;
    resetSession();
    action.close = true;
    return action;
  }
  Upload& u = m.upload;
  u.active = false;
  if (begin.width != static_cast<uint32_t>(options_.width) ||
      begin.height != static_cast<uint32_t>(options_.height)) {
    // Answered at its FrameEnd, like every frame: one ack per frame, never two.
    u.rejectedSequence = header.sequence;
    u.hasRejected = true;
    return action;
  }
  u.hasRejected = false;
  u.active = true;
  u.damaged = false;
  u.sequence = header.sequence;
  u.begin = begin;
  u.covered = 0;
  u.chunks = 0;
  u.outOfOrder = false;
  u.next = 0;
  u.runningCrc = 0;
  u.baseMismatch = false;
  u.written.clear();
  // Whatever this upload writes, the buffer no longer holds a known frame until it completes.
  const uint64_t holds = m.uploadHolds;
  m.uploadHolds = 0;
  if ((begin.flags & kFramePatch) != 0) {
    // The chunks are written over the frame shown, if it is the patch's base (else the frame
    // fails at its FrameEnd, and the host sends it whole).
    u.baseMismatch = m.shown.empty() || m.shownHash != begin.baseHash ||
                     m.shown.pixels.size() != begin.totalSize;
    if (!u.baseMismatch) {
      startPatchBase(m, holds);
      return action;
    }
  }
  if ((begin.flags & kFrameReuse) == 0) u.buffer.resize(begin.totalSize);
  return action;
}

namespace {

using ByteSpan = SimulatedHardware::ByteSpan;

// The union of two lists of sorted, disjoint spans, sorted and disjoint.
std::vector<ByteSpan> unite(const std::vector<ByteSpan>& a, const std::vector<ByteSpan>& b) {
  std::vector<ByteSpan> both(a.size() + b.size()), out;
  std::merge(a.begin(), a.end(), b.begin(), b.end(), both.begin());
  for (const auto& [offset, size] : both) {
    if (!out.empty() && offset <= out.back().first + out.back().second) {
      out.back().second =
          std::max(out.back().first + out.back().second, offset + size) - out.back().first;
    } else {
      out.emplace_back(offset, size);
    }
  }
  return out;
}

}  // namespace

void SimulatedHardware::startPatchBase(Module& m, uint64_t holds) {
  Upload& u = m.upload;
  const std::vector<uint8_t>& shown = m.shown.pixels;
  u.stale.clear();
  // The patches from the frame the buffer holds to the one shown: the buffer differs from the
  // frame shown only where they wrote.
  bool known = holds != 0 && u.buffer.size() == shown.size();
  int steps = 0;
  for (uint64_t at = m.shownHash; known && at != holds; ++steps) {
    const auto r = std::find_if(m.patches.begin(), m.patches.end(),
                                [&](const PatchRecord& p) { return p.hash == at; });
    if (r == m.patches.end() || steps == static_cast<int>(kPatchRecords)) {
      known = false;
    } else {
      u.stale = unite(u.stale, r->written);
      at = r->base;
    }
  }
  if (!known) {
    u.stale.clear();
    u.buffer.assign(shown.begin(), shown.end());
    m.counters.patchBaseBytes += shown.size();
  }
}

void SimulatedHardware::finishPatchBase(Module& m) {
  Upload& u = m.upload;
  const std::vector<uint8_t>& shown = m.shown.pixels;
  // Where the buffer is stale and no chunk wrote: the base's bytes (the chunks, in order, are
  // sorted and disjoint, as the stale spans are).
  auto chunk = u.written.begin();
  for (auto [offset, size] : u.stale) {
    uint64_t at = offset;
    const uint64_t end = offset + size;
    while (at < end) {
      while (chunk != u.written.end() && chunk->first + chunk->second <= at) ++chunk;
      const uint64_t until = chunk == u.written.end() ? end : std::min(end, chunk->first);
      if (until > at) {
        std::memcpy(u.buffer.data() + at, shown.data() + at, until - at);
        m.counters.patchBaseBytes += until - at;
        at = until;
      } else {
        at = std::min(end, chunk->first + chunk->second);
      }
    }
  }
  u.stale.clear();
}

uint8_t* SimulatedHardware::chunkDestination(const PacketHeader& header, uint32_t frameSequence,
                                             uint32_t offset, size_t dataSize) {
  if (header.module >= modules_.size()) return nullptr;
  Upload& u = modules_[header.module].upload;
  if (!u.active || frameSequence != u.sequence || header.sequence != u.sequence) return nullptr;
  if (static_cast<uint64_t>(offset) + dataSize > u.buffer.size()) return nullptr;
  return u.buffer.data() + offset;
}

namespace {
// Chunks below this size have their CRCs chained rather than combined.
constexpr size_t kChainBelow = 16 << 10;
}  // namespace

SimAction SimulatedHardware::finishChunk(const PacketHeader& header, uint32_t frameSequence,
                                         uint32_t offset, std::span<uint8_t> data,
                                         std::vector<uint8_t>* replies) {
  SimAction action;
  if (header.module >= modules_.size()) {
    appendError(ProtocolError::kBadBody, header.sequence, replies);
    action.close = true;
    return action;
  }
  Module& m = modules_[header.module];
  Upload& u = m.upload;
  m.counters.bytesReceived += data.size();

  if (m.faults.slowChunks > 0) {
    --m.faults.slowChunks;
    action.sleepMicroseconds = m.faults.slowMicroseconds;
  }
  if (m.faults.dropChunks > 0) {  // as if the chunk never crossed the wire
    --m.faults.dropChunks;
    ++m.counters.chunksDropped;
    return action;
  }
  if (m.faults.flipChunks > 0 && !data.empty()) {  // line corruption: after the sender's CRC
    --m.faults.flipChunks;
    ++m.counters.bytesFlipped;
    data[data.size() / 2] ^= 0x10;
  }
  // The packet CRC covers prefix + data; the data was read in place. A small chunk (a patch's)
  // is run through the CRC instruction twice, chained from the prefix and from the frame's
  // running CRC; a large one once, its CRC combined with both (crc32cCombine costs ~200 ns, a
  // pass over a few KiB less).
  const auto prefix = encodeChunkPrefix(frameSequence, offset);
  const bool small = data.size() < kChainBelow;
  const uint32_t prefixCrc = crc32c(prefix.data(), prefix.size());
  const uint32_t dataCrc = small ? 0 : crc32c(data.data(), data.size());
  const bool crcOk = (small ? crc32c(data.data(), data.size(), prefixCrc)
                            : crc32cCombine(prefixCrc, dataCrc, data.size())) == header.payloadCrc;
  if (!u.active || frameSequence != u.sequence || header.sequence != u.sequence ||
      static_cast<uint64_t>(offset) + data.size() > u.buffer.size()) {
    // A chunk for no frame in progress (its FrameBegin was rejected, or it is a stray from an
    // abandoned attempt): the frame it belonged to is answered by its FrameEnd.
    return action;
  }
  if (!crcOk) {
    u.damaged = true;
    return action;
  }
  // Chunks must arrive in order, each where the previous one ended (PROTOCOL.md): coverage is
  // then exact — no overlap can pass stale buffer bytes off as received — and the whole-frame
  // CRC builds up as chunks come, without a second pass over the frame at FrameEnd.
  // A patch's chunks may leave gaps (the base's bytes stay there), never go back.
  const bool patch = (u.begin.flags & kFramePatch) != 0;
  if (patch ? offset < u.next : offset != u.covered) {
    u.outOfOrder = true;
    return action;
  }
  if (small) {
    u.runningCrc = crc32c(data.data(), data.size(), u.runningCrc);  // 0 at FrameBegin
  } else {
    u.runningCrc = u.chunks == 0 ? dataCrc : crc32cCombine(u.runningCrc, dataCrc, data.size());
  }
  u.covered += data.size();
  u.next = static_cast<uint64_t>(offset) + data.size();
  ++u.chunks;
  if (patch) u.written.emplace_back(offset, data.size());
  return action;
}

void SimulatedHardware::frameEnd(Module& m, const PacketHeader& header,
                                 std::vector<uint8_t>* replies) {
  Upload& u = m.upload;
  if (!u.active || header.sequence != u.sequence) {
    ++m.counters.framesRejected;
    const bool badFrame = u.hasRejected && u.rejectedSequence == header.sequence;
    u.hasRejected = false;
    ack(header.module, header.sequence, badFrame ? AckStatus::kBadFrame : AckStatus::kMissingChunks,
        0, replies);
    return;
  }
  u.active = false;
  AckStatus status = AckStatus::kOk;
  if ((u.begin.flags & kFrameReuse) != 0) {
    // No bytes came: the frame is the one shown, if the module still shows that content.
    if (m.shown.empty() || m.shownHash != u.begin.contentHash) status = AckStatus::kMissingChunks;
  } else if (u.baseMismatch ||
             ((u.begin.flags & kFramePatch) != 0 &&
              (m.shownHash != u.begin.baseHash || m.shown.pixels.size() != u.buffer.size()))) {
    // (The frame shown may have changed under the upload: a Present, or the module going dark.)
    status = AckStatus::kBaseMismatch;
  } else if (u.damaged) {
    // Every byte came exactly once, in order, in a verified chunk; the end-to-end CRC then
    // checks the frame against what the host declared.
    status = AckStatus::kCrcMismatch;
  } else if (u.outOfOrder || u.chunks != u.begin.chunkCount ||
             ((u.begin.flags & kFramePatch) == 0 && u.covered != u.begin.totalSize)) {
    status = AckStatus::kMissingChunks;
  } else if (u.runningCrc != u.begin.frameCrc) {
    status = AckStatus::kCrcMismatch;
  }
  const uint32_t detail = static_cast<uint32_t>(std::min<uint64_t>(u.covered, 0xFFFFFFFFu));
  const bool stalls = m.faults.stallFrames > 0 && m.faults.stallAfter == 0;
  if (m.faults.stallFrames > 0 && m.faults.stallAfter > 0) --m.faults.stallAfter;
  if (stalls) {  // the device hangs: no ack ever comes for this frame
    --m.faults.stallFrames;
    ++m.counters.acksStalled;
  }
  if (status != AckStatus::kOk) {
    ++m.counters.framesRejected;
  } else if (!(stalls && u.begin.displayFrame != 0)) {  // a hung module holds nothing either
    if ((u.begin.flags & kFramePatch) != 0) {
      finishPatchBase(m);
      m.patches.push_back({u.begin.contentHash, u.begin.baseHash, std::move(u.written)});
      if (m.patches.size() > kPatchRecords) m.patches.pop_front();
    }
    complete(m, u);
  }
  if (!stalls) ack(header.module, header.sequence, status, detail, replies);
}

void SimulatedHardware::complete(Module& m, Upload& u) {
  const bool reuse = (u.begin.flags & kFrameReuse) != 0;
  if (u.begin.displayFrame == 0) {
    // Outside the swap lock: shown at once, as the display frame this module last presented.
    m.shown.width = static_cast<int>(u.begin.width);
    m.shown.height = static_cast<int>(u.begin.height);
    m.shown.format = u.begin.format;
    std::swap(m.shown.pixels, u.buffer);
    m.uploadHolds = m.shownHash;
    m.shownHash = u.begin.contentHash;
    m.shownFrame = m.presented;
    ++m.counters.framesShown;
    if (onShown_) onShown_();
    return;
  }
  if (u.begin.displayFrame <= m.presented) {  // its Present has passed: never shown
    ++m.counters.framesLate;
    if (!reuse) m.uploadHolds = u.begin.contentHash;
    return;
  }
  m.ready.displayFrame = u.begin.displayFrame;
  m.ready.reuse = reuse;
  m.ready.begin = u.begin;
  if (!reuse) {
    std::swap(m.ready.pixels, u.buffer);
    m.uploadHolds = m.readyHolds;
    m.readyHolds = u.begin.contentHash;
  }
}

void SimulatedHardware::present(Module& m, int index, uint32_t displayFrame, int64_t nowNs) {
  if (displayFrame <= m.presented) return;  // a repeated or older Present changes nothing
  m.presented = displayFrame;
  bool switched = false;
  if (m.ready.displayFrame == displayFrame) {
    if (!m.ready.reuse) {
      m.shown.width = static_cast<int>(m.ready.begin.width);
      m.shown.height = static_cast<int>(m.ready.begin.height);
      m.shown.format = m.ready.begin.format;
      std::swap(m.shown.pixels, m.ready.pixels);
      m.readyHolds = m.shownHash;
      m.shownHash = m.ready.begin.contentHash;
      ++m.counters.framesShown;  // new content (a reused frame is the one already counted)
    }
    m.shownFrame = displayFrame;
    switched = true;
  } else {
    ++m.counters.presentsMissed;
    // Lagging one display frame is allowed; two would show the viewer moments further apart
    // than a frame, so the module goes dark until its next frame is presented.
    if (m.shownFrame != 0 && m.shownFrame + 1 < displayFrame) {
      std::fill(m.shown.pixels.begin(), m.shown.pixels.end(), uint8_t{0});
      m.shownHash = 0;
      m.shownFrame = 0;
      ++m.counters.blanked;
      switched = true;
    }
  }
  m.ready.displayFrame = 0;  // a held frame older than this Present is never shown
  presents_.push_back({displayFrame, index, m.shownFrame, switched, nowNs});
  if (presents_.size() > kPresentRecords) presents_.pop_front();
}

ProtocolError SimulatedHardware::capture(const PacketHeader& header,
                                         std::span<const uint8_t> payload,
                                         std::vector<uint8_t>* replies) {
  CaptureRequest request;
  if (const ProtocolError e = decodeCaptureRequest(payload, &request); e != ProtocolError::kOk) {
    return e;
  }
  if (request.exposureUs != 0) camera_.exposureUs = request.exposureUs;
  camera_.colour = (request.flags & kCaptureColour) != 0;
  if (request.gainCenti != 0) camera_.gain = request.gainCenti / 100.0;
  if (request.whiteBalanceRedCenti != 0)
    camera_.whiteBalanceRed = request.whiteBalanceRedCenti / 100.0;
  if (request.whiteBalanceBlueCenti != 0) {
    camera_.whiteBalanceBlue = request.whiteBalanceBlueCenti / 100.0;
  }
  std::vector<const Image*> frames(modules_.size());
  for (size_t i = 0; i < modules_.size(); ++i) {
    frames[i] = modules_[i].shown.empty() ? nullptr : &modules_[i].shown;
  }
  const Image image = physics_->render(frames, request.viewModule, request.station, camera_);
  if (image.empty()) {
    ack(kCameraModule, header.sequence, AckStatus::kUnsupported, 0, replies);
    return ProtocolError::kOk;
  }
  PARALLAX_CHECK_OP(image.pixels.size(), ==, image.byteSize());
  if (image.byteSize() + kCaptureReplyHeaderSize > kMaxPayloadSize) {
    ack(kCameraModule, header.sequence, AckStatus::kUnsupported, 0, replies);
    return ProtocolError::kOk;
  }
  std::vector<uint8_t> body = encodeCaptureReplyHeader({static_cast<uint32_t>(image.width),
                                                        static_cast<uint32_t>(image.height),
                                                        image.format, header.sequence});
  body.insert(body.end(), image.pixels.begin(), image.pixels.end());
  appendReply(PacketType::kCaptureReply, kCameraModule, header.sequence, body, replies);
  return ProtocolError::kOk;
}

}  // namespace parallax::hw
