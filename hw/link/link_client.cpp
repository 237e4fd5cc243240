#include "hw/link/link_client.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <optional>
#include <stdexcept>
#include <thread>

#include "common/input_error.h"
#include "hw/link/content_hash.h"
#include "hw/link/crc32c.h"

namespace parallax::hw {

void LinkOptions::validate() const {
  auto require = [](bool ok, const char* field, const std::string& why) {
    if (!ok) throw InputError({"", field, 0}, why);
  };
  require(
      chunkSize >= 4096 && chunkSize <= kMaxPayloadSize - kChunkPrefixSize, "chunk_size",
      fmt::format("must be in 4096..{}, got {}", kMaxPayloadSize - kChunkPrefixSize, chunkSize));
  require(windowFrames >= 1 && windowFrames <= 1024, "window_frames", "must be in 1..1024");
  require(ackTimeoutMs >= 1, "ack_timeout_ms", "must be positive");
  require(maxRetries >= 0 && maxRetries <= 100, "max_retries", "must be in 0..100");
  require(keepAliveMs >= 1, "keep_alive_ms", "must be positive");
  require(reconnectAttempts >= 0 && reconnectAttempts <= 100, "reconnect_attempts",
          "must be in 0..100");
  require(reconnectDelayMs >= 0, "reconnect_delay_ms", "must not be negative");
  require(connectTimeoutMs >= 1 && connectTimeoutMs <= 600000, "connect_timeout_ms",
          "must be in 1..600000");
  require(stallLimitMs >= 1 && stallLimitMs <= 3600000, "stall_limit_ms", "must be in 1..3600000");
  require(linkDownRetryMs >= 0, "link_down_retry_ms", "must not be negative");
  require(linkDownRetryMaxMs >= linkDownRetryMs && linkDownRetryMaxMs <= 3600000,
          "link_down_retry_max_ms", "must be in link_down_retry_ms..3600000");
  require(downRetryBudgetMs >= 1 && downRetryBudgetMs <= 3600000, "down_retry_budget_ms",
          "must be in 1..3600000");
}

std::string_view frameStatusName(FrameStatus status) {
  switch (status) {
    case FrameStatus::kPending:
      return "pending";
    case FrameStatus::kDelivered:
      return "delivered";
    case FrameStatus::kSkippedUnchanged:
      return "skipped (unchanged)";
    case FrameStatus::kSuperseded:
      return "superseded";
    case FrameStatus::kFailed:
      return "failed";
  }
  return "unknown";
}

LinkClient::LinkClient(std::unique_ptr<LinkTransport> transport, LinkOptions options)
    : transport_(std::move(transport)), options_(options) {
  options_.validate();
  transport_->setConnectTimeoutMs(options_.connectTimeoutMs);
  std::string error;
  if (!transport_->isOpen() && transport_->open(&error) != TransportStatus::kOk) {
    throw std::runtime_error(error);
  }
  if (!helloOk(options_.ackTimeoutMs)) {
    if (transport_->lastProtocolError() == ProtocolError::kBadVersion) {
      throw std::runtime_error(fmt::format(
          "{}: the device speaks link protocol version {}, this host version {} (frames "
          "presented in lock-step, patch frames): update the device's firmware (or "
          "parallax-simhw)",
          transport_->name(), transport_->lastPeerVersion(), kLinkVersion));
    }
    throw std::runtime_error(
        fmt::format("{}: the device did not answer Hello", transport_->name()));
  }
}

LinkClient::~LinkClient() = default;

bool LinkClient::helloOk(int timeoutMs) {
  const uint32_t seq = nextSequence();
  const HeaderBytes h = encodeHeader({PacketType::kHello, 0, kAllModules, seq, 0, 0}, {});
  iovec piece{const_cast<uint8_t*>(h.data()), h.size()};
  if (transport_->send(kAllModules, {&piece, 1}, timeoutMs) != TransportStatus::kOk) return false;
  std::vector<ModuleLinkInfo> found;
  uint16_t expected = 0;
  const auto deadline = Clock::now() + std::chrono::milliseconds(timeoutMs);
  while (expected == 0 || found.size() < expected) {
    std::vector<ReceivedPacket> packets;
    const int left = static_cast<int>(
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count());
    if (left <= 0) return false;
    const TransportStatus status = transport_->receive(&packets, left);
    if (status == TransportStatus::kDisconnected || status == TransportStatus::kProtocolError)
      return false;
    for (const ReceivedPacket& p : packets) {
      if (p.header.type != PacketType::kDeviceInfo || p.header.sequence != seq) continue;
      DeviceInfo info;
      if (decodeDeviceInfo(p.payload, &info) != ProtocolError::kOk) return false;
      if (info.moduleCount == 0 || p.header.module >= info.moduleCount) return false;
      expected = info.moduleCount;
      found.push_back({p.header.module, info});
    }
  }
  std::sort(found.begin(), found.end(),
            [](const ModuleLinkInfo& a, const ModuleLinkInfo& b) { return a.module < b.module; });
  for (size_t i = 0; i < found.size(); ++i) {
    if (found[i].module != static_cast<int>(i)) return false;  // duplicates or gaps
  }
  modules_ = std::move(found);
  chunkSize_ = options_.chunkSize;
  for (const ModuleLinkInfo& m : modules_) chunkSize_ = std::min(chunkSize_, m.info.maxChunkSize);
  submittedHash_.resize(modules_.size());
  hashValid_.resize(modules_.size(), false);
  submittedFamily_.resize(modules_.size(), 0);
  latestTicket_.resize(modules_.size(), 0);
  readyFrame_.assign(modules_.size(), 0);
  submittedFrame_.resize(modules_.size(), 0);
  // A new session: what the modules show is unknown again (see sessions()).
  std::fill(hashValid_.begin(), hashValid_.end(), false);
  ++sessions_;
  lastHeard_ = Clock::now();
  silence_ = {};
  return true;
}

int LinkClient::stallLeftMs() const {
  const auto silentMs = std::chrono::duration_cast<std::chrono::milliseconds>(silence_).count();
  return static_cast<int>(std::max<int64_t>(0, options_.stallLimitMs - silentMs));
}

bool LinkClient::expectingAnswers() const {
  return awaitingReply_ ||
         std::any_of(pending_.begin(), pending_.end(), [](const Pending& p) { return !p.done; });
}

TransportStatus LinkClient::sendWithinStallLimit(uint16_t module, std::span<const iovec> pieces) {
  const auto started = Clock::now();
  const TransportStatus status = transport_->send(module, pieces, std::max(1, stallLeftMs()));
  if (status == TransportStatus::kTimeout) silence_ += Clock::now() - started;
  return status;
}

void LinkClient::afterFailedSend(TransportStatus status, const std::string& what) {
  if (status == TransportStatus::kTimeout) {
    declareHung(what);
  } else {
    reconnect(what + " failed");
  }
}

void LinkClient::declareHung(const std::string& doing) {
  ++stats_.hangs;
  const std::string what =
      fmt::format("the device answered nothing in {} ms of waiting on it ({}): it hangs",
                  options_.stallLimitMs, doing);
  spdlog::warn("link: {}: {}", transport_->name(), what);
  transport_->close();
  inbox_.clear();
  goDown(what);
}

void LinkClient::goDown(const std::string& what) {
  // Growing pauses: a device that stays hung costs a reconnect ever more rarely.
  quietMs_ = std::clamp(quietMs_, options_.linkDownRetryMs, options_.linkDownRetryMaxMs);
  downReason_ = fmt::format("link down ({}; next try in {} ms)", what, quietMs_);
  downUntil_ = Clock::now() + std::chrono::milliseconds(quietMs_);
  down_ = true;
  quietMs_ = std::min(quietMs_ * 2, options_.linkDownRetryMaxMs);
  silence_ = {};  // the next reconnect has the whole stall limit
  for (Pending& p : pending_) finish(p, FrameStatus::kFailed, downReason_);
}

uint64_t LinkClient::submit(int module, std::shared_ptr<const Image> frame, uint32_t displayFrame) {
  if (module < 0 || module >= static_cast<int>(modules_.size())) {
    throw InputError({"", "module", 0},
                     fmt::format("no module {} (the link has {})", module, modules_.size()));
  }
  const DeviceInfo& info = modules_[module].info;
  if (!frame || frame->width != static_cast<int>(info.width) ||
      frame->height != static_cast<int>(info.height) || frame->pixels.size() != frame->byteSize()) {
    throw InputError({"", "frame", 0},
                     fmt::format("module {} takes {}x{} frames, got {}x{} ({} bytes)", module,
                                 info.width, info.height, frame ? frame->width : 0,
                                 frame ? frame->height : 0, frame ? frame->pixels.size() : 0));
  }
  ++stats_.submitted;
  const uint64_t ticket = ++ticket_;
  // A patch's hash is worked out from its base's and the bytes it sends, not from every byte.
  std::optional<std::vector<std::pair<uint32_t, uint32_t>>> patch =
      patchFor(module, *frame, displayFrame);
  const bool patching = patch && !patch->empty();
  uint64_t hash = 0;
  if (patching) {
    hash = patchContentHash(submittedHash_[module], frame->pixels.data(), *patch);
  } else if (patch) {
    hash = submittedHash_[module];  // nothing can differ from what the module shows
  } else {
    hash = contentHash64(frame->pixels.data(), frame->pixels.size());
  }
  const bool unchanged =
      options_.skipUnchanged && hashValid_[module] && submittedHash_[module] == hash;
  if (unchanged && displayFrame == 0) {
    ++stats_.skipped;
    outcomes_.push_back({ticket, module, FrameStatus::kSkippedUnchanged, 0, ""});
    return ticket;
  }

  // Nothing was awaited: the stall limit counts from here.
  if (!expectingAnswers()) silence_ = {};
  // A link idle for a while may have died quietly: probe it before trusting it with a frame.
  if (Clock::now() - lastHeard_ > std::chrono::milliseconds(options_.keepAliveMs)) ping();
  while (static_cast<int>(pending_.size()) >= options_.windowFrames) waitForProgress();

  Pending p;
  p.ticket = ticket;
  p.module = module;
  p.frame = std::move(frame);
  p.hash = hash;
  p.displayFrame = displayFrame;
  p.reuse = unchanged;
  if (patching && !unchanged) {
    // The CRC of the bytes the patch sends, chained from chunk to chunk: a patch's chunks are
    // small (a few KiB), where another pass of the CRC instruction costs less than combining
    // CRCs (crc32cCombine: ~200 ns); each chunk's own is worked out as it is sent.
    p.baseHash = submittedHash_[module];
    for (const auto& [begin, end] : *patch)
      p.patchCrc = crc32c(p.frame->pixels.data() + begin, end - begin, p.patchCrc);
    p.patch = std::move(*patch);
  } else if (!unchanged) {
    wholeFrameCrcs(p);
  }
  submittedHash_[module] = hash;
  hashValid_[module] = true;
  submittedFamily_[module] = p.frame->regions ? p.frame->regions->family : 0;
  latestTicket_[module] = ticket;
  submittedFrame_[module] = displayFrame;
  pending_.push_back(std::move(p));
  if (!transport_->isOpen()) {
    reconnect("sending a frame failed");
  } else if (const TransportStatus sent = sendFrame(pending_.back());
             sent != TransportStatus::kOk) {
    afterFailedSend(sent, "sending a frame");
  }
  pump(0);
  return ticket;
}

std::optional<std::vector<std::pair<uint32_t, uint32_t>>> LinkClient::patchFor(
    int module, const Image& frame, uint32_t displayFrame) const {
  const ImageRegions* regions = frame.regions.get();
  if (!options_.patchFrames || displayFrame == 0 || !regions || regions->family == 0 ||
      !hashValid_[module] || submittedFamily_[module] != regions->family)
    return std::nullopt;
  std::vector<std::pair<uint32_t, uint32_t>> chunks;
  // Spans closer than this are sent as one chunk, the bytes between included: a chunk costs
  // 40 bytes of header and prefix and a packet's handling at both ends. bench daemon, orbit.lua
  // (rows of 1536 bytes on demo, 3072 on default; spans a fifth to a quarter of a row), CRCs
  // chained: 2048 sent 5.1 MiB a display frame on demo and 70.6 on default (rows merged), push
  // 2.2-2.4 and 40-43 ms; 768 sent 2.4 and 36.8 MiB, push 2.2 and 46-48 ms, the same fps and CPU
  // within the noise. Half the bytes for a few ms more on a simulated link: on a real one (USB,
  // ~400 MB/s) the bytes are what limits. (Before the CRCs were chained, 512 cost 3.7 ms on demo
  // against 2.7-4.0 for whole frames.)
  constexpr uint32_t kMergeGap = 768;
  const auto size = static_cast<uint32_t>(frame.pixels.size());
  uint64_t bytes = 0;
  uint32_t previousEnd = 0;
  for (const auto& [begin, end] : regions->spans) {
    if (begin >= end) continue;
    if (begin < previousEnd || end > size) return std::nullopt;  // not sorted, or past the end
    previousEnd = end;
    if (!chunks.empty() && begin - chunks.back().second < kMergeGap &&
        end - chunks.back().first <= chunkSize_) {
      bytes += end - chunks.back().second;
      chunks.back().second = end;
      continue;
    }
    for (uint32_t at = begin; at < end; at += chunkSize_) {
      chunks.push_back({at, std::min(end, at + chunkSize_)});
      bytes += chunks.back().second - at;
    }
  }
  if (bytes > size / 4 * 3) return std::nullopt;  // as good as whole: sent whole
  return chunks;
}

void LinkClient::wholeFrameCrcs(Pending& p) const {
  if (!p.chunkCrcs.empty()) return;
  // One CRC pass over the pixels: per-chunk CRCs, combined into the whole-frame CRC.
  const size_t size = p.frame->pixels.size();
  const uint8_t* data = p.frame->pixels.data();
  for (size_t offset = 0; offset < size; offset += chunkSize_) {
    const size_t n = std::min<size_t>(chunkSize_, size - offset);
    const uint32_t crc = crc32c(data + offset, n);
    p.chunkCrcs.push_back(crc);
    p.frameCrc = offset == 0 ? crc : crc32cCombine(p.frameCrc, crc, n);
  }
}

TransportStatus LinkClient::sendFrame(Pending& p) {
  p.sequence = nextSequence();
  ++p.attempts;
  ++stats_.attempts;
  if (p.attempts > 1) ++stats_.retries;
  p.deadline = Clock::now() + std::chrono::milliseconds(options_.ackTimeoutMs);

  const Image& f = *p.frame;
  const uint16_t module = static_cast<uint16_t>(p.module);
  const size_t size = f.pixels.size();
  // Only the first attempt reuses or patches: a module that answered "not what I show" gets
  // the pixels.
  const bool reuse = p.reuse && p.attempts == 1;
  const bool patch = !reuse && !p.patch.empty() && p.attempts == 1;
  if (!reuse && !patch) wholeFrameCrcs(p);
  const size_t chunks = reuse ? 0 : patch ? p.patch.size() : p.chunkCrcs.size();
  FrameBegin begin;
  begin.width = static_cast<uint32_t>(f.width);
  begin.height = static_cast<uint32_t>(f.height);
  begin.format = f.format;
  begin.mode = DisplayMode::kPlayback;
  begin.totalSize = static_cast<uint32_t>(size);
  begin.chunkCount = static_cast<uint32_t>(chunks);
  begin.frameCrc = patch ? p.patchCrc : p.frameCrc;
  begin.contentHash = p.hash;
  begin.displayFrame = p.displayFrame;
  begin.flags = reuse ? kFrameReuse : patch ? kFramePatch : 0;
  begin.baseHash = patch ? p.baseHash : 0;
  const std::vector<uint8_t> beginBody = encodeFrameBegin(begin);

  // Header storage must stay put while the iovecs point at it.
  scratchHeaders_.resize(chunks + 2);
  scratchPrefixes_.resize(chunks);
  std::vector<iovec>& iov = scratchIov_;
  iov.clear();
  scratchHeaders_[0] =
      encodeHeader({PacketType::kFrameBegin, 0, module, p.sequence, 0, 0}, beginBody);
  iov.push_back({scratchHeaders_[0].data(), kHeaderSize});
  iov.push_back({const_cast<uint8_t*>(beginBody.data()), beginBody.size()});
  size_t sentBytes = 0;
  for (size_t c = 0; c < chunks; ++c) {
    const size_t offset = patch ? p.patch[c].first : c * chunkSize_;
    const size_t n =
        patch ? p.patch[c].second - p.patch[c].first : std::min<size_t>(chunkSize_, size - offset);
    sentBytes += n;
    scratchPrefixes_[c] = encodeChunkPrefix(p.sequence, static_cast<uint32_t>(offset));
    PacketHeader h{PacketType::kFrameChunk,
                   0,
                   module,
                   p.sequence,
                   static_cast<uint32_t>(kChunkPrefixSize + n),
                   0};
    // A patch's chunk: its prefix and data in one chained pass; a whole frame's (a MiB): its
    // data's CRC, worked out at submit, combined with the prefix's.
    const uint32_t prefixCrc = crc32c(scratchPrefixes_[c].data(), kChunkPrefixSize);
    h.payloadCrc = patch ? crc32c(f.pixels.data() + offset, n, prefixCrc)
                         : crc32cCombine(prefixCrc, p.chunkCrcs[c], n);
    scratchHeaders_[c + 1] = encodeHeaderRaw(h);
    iov.push_back({scratchHeaders_[c + 1].data(), kHeaderSize});
    iov.push_back({scratchPrefixes_[c].data(), kChunkPrefixSize});
    iov.push_back({const_cast<uint8_t*>(f.pixels.data() + offset), n});
  }
  scratchHeaders_[chunks + 1] =
      encodeHeader({PacketType::kFrameEnd, 0, module, p.sequence, 0, 0}, {});
  iov.push_back({scratchHeaders_[chunks + 1].data(), kHeaderSize});
  const TransportStatus sent = sendWithinStallLimit(module, iov);
  if (sent == TransportStatus::kOk && !reuse) stats_.payloadBytesSent += sentBytes;
  if (sent == TransportStatus::kOk && patch) {
    ++stats_.patches;
    stats_.patchBytesSaved += size - sentBytes;
  }
  return sent;
}

bool LinkClient::supersede(Pending& p) {
  if (latestTicket_[p.module] == p.ticket) return false;
  p.history += fmt::format("; not resent: frame {} for module {} is newer", latestTicket_[p.module],
                           p.module);
  finish(p, FrameStatus::kSuperseded, p.history);
  return true;
}

void LinkClient::retryOrFail(Pending& p, const std::string& why) {
  p.history += fmt::format("{}attempt {}: {}", p.history.empty() ? "" : "; ", p.attempts, why);
  if (supersede(p)) return;
  if (p.attempts > options_.maxRetries) {
    finish(p, FrameStatus::kFailed, p.history);
    return;
  }
  if (!transport_->isOpen()) {
    reconnect("resending a frame failed");
  } else if (const TransportStatus sent = sendFrame(p); sent != TransportStatus::kOk) {
    afterFailedSend(sent, "resending a frame");
  }
}

void LinkClient::finish(Pending& p, FrameStatus status, const std::string& reason) {
  if (p.done) return;
  p.done = true;
  if (status == FrameStatus::kDelivered) {
    ++stats_.delivered;
  } else if (status == FrameStatus::kSkippedUnchanged) {
    ++stats_.skipped;
  } else if (status == FrameStatus::kSuperseded) {
    ++stats_.superseded;
  } else {
    ++stats_.failed;
    // The module may not show these bytes: never skip them as "unchanged" later.
    if (hashValid_[p.module] && submittedHash_[p.module] == p.hash) hashValid_[p.module] = false;
    spdlog::warn("link: frame {} for module {} failed: {}", p.ticket, p.module, reason);
  }
  outcomes_.push_back({p.ticket, p.module, status, p.attempts, reason});
}

void LinkClient::prune() {
  std::erase_if(pending_, [](const Pending& p) { return p.done; });
}

TransportStatus LinkClient::pump(int timeoutMs) {
  std::vector<ReceivedPacket> packets;
  const bool expecting = expectingAnswers();
  if (expecting) timeoutMs = std::min(timeoutMs, stallLeftMs());
  const auto started = Clock::now();
  const TransportStatus status = transport_->receive(&packets, timeoutMs);
  if (expecting && packets.empty()) silence_ += Clock::now() - started;
  for (const ReceivedPacket& packet : packets) handle(packet);
  if (status == TransportStatus::kDisconnected || status == TransportStatus::kProtocolError) {
    const std::string why = status == TransportStatus::kProtocolError
                                ? fmt::format("device sent a bad packet ({})",
                                              protocolErrorName(transport_->lastProtocolError()))
                                : "device closed the connection";
    if (!reconnecting_) reconnect(why);
  }
  checkDeadlines();
  if (!reconnecting_ && transport_->isOpen() && expectingAnswers() && stallLeftMs() == 0)
    declareHung(awaitingReply_ ? "a request unanswered" : "frames unacknowledged");
  prune();
  return status;
}

void LinkClient::handle(const ReceivedPacket& packet) {
  lastHeard_ = Clock::now();
  silence_ = {};
  if (packet.header.type == PacketType::kAck) {
    Ack ack;
    if (decodeAck(packet.payload, &ack) != ProtocolError::kOk ||
        ack.ackedSequence != packet.header.sequence) {
      ++stats_.staleAcks;  // malformed: the frame it meant will time out and be retried
      return;
    }
    for (Pending& p : pending_) {
      if (p.done || p.sequence != ack.ackedSequence) continue;
      if (ack.status == AckStatus::kOk) {
        readyFrame_[p.module] = std::max(readyFrame_[p.module], p.displayFrame);
        const bool reused = p.reuse && p.attempts == 1;
        finish(p, reused ? FrameStatus::kSkippedUnchanged : FrameStatus::kDelivered, p.history);
      } else {
        ++stats_.nacks;
        if (ack.status == AckStatus::kBaseMismatch) ++stats_.patchesRefused;
        retryOrFail(p, fmt::format("module answered {} ({} bytes verified)",
                                   ackStatusName(ack.status), ack.detail));
      }
      return;
    }
  }
  if (packet.header.type == PacketType::kError) {
    ErrorBody e;
    const bool ok = decodeError(packet.payload, &e) == ProtocolError::kOk;
    lastDeviceError_ = ok ? fmt::format("device rejected packet {}: {}", e.offendingSequence,
                                        protocolErrorName(e.error))
                          : "device sent a malformed error packet";
    spdlog::warn("link: {}", lastDeviceError_);
  }
  // Everything else answers a control request (or is stale): keep a bounded inbox.
  inbox_.push_back(packet);
  if (inbox_.size() > 64) {
    inbox_.erase(inbox_.begin());
    ++stats_.staleAcks;
  }
}

void LinkClient::checkDeadlines() {
  const auto now = Clock::now();
  for (Pending& p : pending_) {
    if (p.done || now < p.deadline) continue;
    ++stats_.timeouts;
    retryOrFail(p, fmt::format("no acknowledgement within {} ms", options_.ackTimeoutMs));
  }
}

void LinkClient::waitForProgress() {
  auto earliest = Clock::time_point::max();
  for (const Pending& p : pending_) {
    if (!p.done) earliest = std::min(earliest, p.deadline);
  }
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(earliest - Clock::now());
  pump(static_cast<int>(std::clamp<int64_t>(left.count() + 1, 0, options_.ackTimeoutMs)));
}

std::vector<int> LinkClient::awaitDisplayFrame(uint32_t displayFrame, Clock::time_point deadline) {
  auto waiting = [&] {
    return std::any_of(pending_.begin(), pending_.end(),
                       [&](const Pending& p) { return !p.done && p.displayFrame == displayFrame; });
  };
  while (waiting()) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (left <= 0) break;
    pump(static_cast<int>(std::min<int64_t>(left, options_.ackTimeoutMs)));
  }
  std::vector<int> late;
  for (size_t m = 0; m < readyFrame_.size(); ++m) {
    if (submittedFrame_[m] == displayFrame && readyFrame_[m] != displayFrame)
      late.push_back(static_cast<int>(m));
  }
  return late;
}

bool LinkClient::present(uint32_t displayFrame) {
  if (!transport_->isOpen()) return false;
  const std::vector<uint8_t> body = encodePresent({displayFrame});
  const HeaderBytes h =
      encodeHeader({PacketType::kPresent, 0, kAllModules, nextSequence(), 0, 0}, body);
  const iovec pieces[2] = {{const_cast<uint8_t*>(h.data()), h.size()},
                           {const_cast<uint8_t*>(body.data()), body.size()}};
  const TransportStatus sent = sendWithinStallLimit(kAllModules, pieces);
  if (sent == TransportStatus::kTimeout) declareHung("sending a Present");
  return sent == TransportStatus::kOk;
}

void LinkClient::flush() {
  while (!pending_.empty()) waitForProgress();
}

std::vector<FrameOutcome> LinkClient::takeOutcomes() {
  std::vector<FrameOutcome> out;
  out.swap(outcomes_);
  return out;
}

bool LinkClient::reconnect(const std::string& why) {
  if (reconnecting_) return false;
  if (Clock::now() < downUntil_) {  // still in the quiet period after a failed reconnect
    for (Pending& p : pending_) finish(p, FrameStatus::kFailed, downReason_);
    return false;
  }
  reconnecting_ = true;
  spdlog::warn("link: {}: {}; reconnecting", transport_->name(), why);
  transport_->close();
  inbox_.clear();
  int delay = options_.reconnectDelayMs;
  std::string error;
  bool up = false;
  // Within the stall limit: what the waits before it left of it (all of it after a pause);
  // a try on a link that is down only asks whether the device is back.
  const int budgetMs = down_ ? std::min(stallLeftMs(), options_.downRetryBudgetMs) : stallLeftMs();
  const auto giveUp = Clock::now() + std::chrono::milliseconds(budgetMs);
  const auto leftMs = [&] {
    return std::chrono::duration_cast<std::chrono::milliseconds>(giveUp - Clock::now()).count();
  };
  for (int attempt = 0; attempt <= options_.reconnectAttempts && !up; ++attempt) {
    if (attempt > 0) {
      if (leftMs() < delay) {
        error += fmt::format(" (gave up after {} attempts in {} ms)", attempt, budgetMs - leftMs());
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(delay));
      delay *= 2;
    }
    ++stats_.reconnects;
    // A peer that does not take the connection (a hung one's full listen queue) is waited for
    // within the budget too.
    transport_->setConnectTimeoutMs(
        static_cast<int>(std::clamp<int64_t>(leftMs(), 1, options_.connectTimeoutMs)));
    const TransportStatus opened = transport_->open(&error);
    transport_->setConnectTimeoutMs(options_.connectTimeoutMs);
    if (opened != TransportStatus::kOk) continue;
    if (!helloOk(static_cast<int>(std::clamp<int64_t>(leftMs(), 1, options_.ackTimeoutMs)))) {
      error = "the device did not answer Hello";
      transport_->close();
      continue;
    }
    // Everything in flight died with the old connection: send it again (each resend is an
    // attempt, so a frame that keeps killing the link fails after maxRetries).
    up = true;
    for (Pending& p : pending_) {
      if (p.done) continue;
      p.history += fmt::format("{}attempt {}: {}", p.history.empty() ? "" : "; ", p.attempts, why);
      if (supersede(p)) continue;
      if (p.attempts > options_.maxRetries) {
        finish(p, FrameStatus::kFailed, p.history);
      } else if (const TransportStatus sent = sendFrame(p); sent != TransportStatus::kOk) {
        error = sent == TransportStatus::kTimeout
                    ? "the device took no byte of a resent frame (it hangs)"
                    : "the link dropped again while resending";
        up = false;
        transport_->close();
        break;
      }
    }
  }
  if (up) {
    quietMs_ = options_.linkDownRetryMs;
    down_ = false;
  } else {
    goDown(fmt::format("{}; reconnecting failed: {}", why, error));
  }
  // No prune() here: callers may be iterating pending_.
  reconnecting_ = false;
  return up;
}

bool LinkClient::request(PacketType type, uint16_t module, std::span<const uint8_t> body,
                         std::initializer_list<PacketType> answers, ReceivedPacket* reply,
                         int timeoutMs) {
  // Waiting for the answer counts toward the stall limit, but for a capture's (an explicit
  // timeoutMs): a camera takes its time, and says nothing meanwhile.
  if (!expectingAnswers()) silence_ = {};
  struct Awaiting {
    bool& flag;
    ~Awaiting() { flag = false; }
  } awaiting{awaitingReply_};
  // A link that drops under a request (a disconnect fault firing, a device replugged) gets one
  // reconnect and one more try; a request that simply goes unanswered does not.
  for (int attempt = 0; attempt < 2; ++attempt) {
    if (!transport_->isOpen() && !reconnect("link closed")) return false;
    const uint32_t seq = nextSequence();
    const HeaderBytes h = encodeHeader({type, 0, module, seq, 0, 0}, body);
    iovec pieces[2] = {{const_cast<uint8_t*>(h.data()), h.size()},
                       {const_cast<uint8_t*>(body.data()), body.size()}};
    const TransportStatus sent = sendWithinStallLimit(module, {pieces, body.empty() ? 1u : 2u});
    if (sent == TransportStatus::kTimeout) {
      declareHung("sending a request");
      return false;
    }
    if (sent != TransportStatus::kOk) {
      if (!reconnect("sending a request failed")) return false;
      continue;
    }
    const auto deadline =
        Clock::now() + std::chrono::milliseconds(timeoutMs > 0 ? timeoutMs : options_.ackTimeoutMs);
    awaitingReply_ = timeoutMs <= 0;
    bool dropped = false;
    while (!dropped) {
      for (auto it = inbox_.begin(); it != inbox_.end(); ++it) {
        if (it->header.sequence != seq) continue;
        if (std::find(answers.begin(), answers.end(), it->header.type) == answers.end()) continue;
        *reply = std::move(*it);
        inbox_.erase(it);
        return true;
      }
      const auto left =
          std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      if (left <= 0) return false;
      // pump() reconnects by itself when the link drops; then the request is sent again.
      const TransportStatus s = pump(static_cast<int>(left));
      dropped = s == TransportStatus::kDisconnected || s == TransportStatus::kProtocolError ||
                !transport_->isOpen();
    }
  }
  return false;
}

bool LinkClient::ping() {
  ++stats_.keepAlives;
  ReceivedPacket reply;
  if (request(PacketType::kKeepAlive, kAllModules, {}, {PacketType::kKeepAlive}, &reply)) {
    return true;
  }
  // No echo: the link is dead even if the socket looks open. One reconnect, then ask again.
  if (!reconnect("keep-alive not answered")) return false;
  return request(PacketType::kKeepAlive, kAllModules, {}, {PacketType::kKeepAlive}, &reply);
}

bool LinkClient::setMode(DisplayMode mode) {
  ReceivedPacket reply;
  const std::vector<uint8_t> body = encodeSetMode(mode);
  if (!request(PacketType::kSetMode, kAllModules, body, {PacketType::kAck}, &reply)) return false;
  Ack ack;
  return decodeAck(reply.payload, &ack) == ProtocolError::kOk && ack.status == AckStatus::kOk;
}

bool LinkClient::injectFault(int module, const Fault& fault) {
  ReceivedPacket reply;
  const std::vector<uint8_t> body = encodeFault(fault);
  if (!request(PacketType::kFault, static_cast<uint16_t>(module), body, {PacketType::kAck},
               &reply)) {
    return false;
  }
  Ack ack;
  return decodeAck(reply.payload, &ack) == ProtocolError::kOk && ack.status == AckStatus::kOk;
}

Image LinkClient::capture(int viewModule, const CaptureRequest& settings) {
  CaptureRequest r = settings;
  r.viewModule = static_cast<uint16_t>(viewModule);
  const std::vector<uint8_t> body = encodeCaptureRequest(r);
  ReceivedPacket reply;
  if (!request(PacketType::kCaptureRequest, kCameraModule, body,
               {PacketType::kCaptureReply, PacketType::kAck}, &reply, options_.captureTimeoutMs) ||
      reply.header.type != PacketType::kCaptureReply) {
    return {};
  }
  CaptureReplyHeader h;
  if (decodeCaptureReplyHeader(reply.payload, &h) != ProtocolError::kOk) return {};
  Image image;
  image.width = static_cast<int>(h.width);
  image.height = static_cast<int>(h.height);
  image.format = h.format;
  image.pixels.assign(reply.payload.begin() + kCaptureReplyHeaderSize, reply.payload.end());
  return image;
}

}  // namespace parallax::hw
