#include "hw/link/link_protocol.h"

#include <gtest/gtest.h>

#include <cstring>

#include "common/input_error.h"
#include "hw/link/crc32c.h"
#include "hw/simulator/fault_spec.h"

namespace parallax::hw {
namespace {

std::vector<uint8_t> ackPacket() {
  return encodePacket({PacketType::kAck, 0, 3, 42, 0, 0}, encodeAck({42, AckStatus::kOk, 7}));
}

// Rewrites the header CRC after a deliberate edit, so only the edited field is wrong.
void resealHeader(std::vector<uint8_t>& packet) {
  const uint32_t crc = crc32c(packet.data(), 28);
  for (int i = 0; i < 4; ++i) packet[28 + i] = static_cast<uint8_t>(crc >> (8 * i));
}

TEST(LinkProtocol, HeaderRoundTrips) {
  const std::vector<uint8_t> packet = ackPacket();
  ASSERT_EQ(packet.size(), kHeaderSize + kAckSize);
  EXPECT_EQ(std::memcmp(packet.data(), "PLXL", 4), 0);  // readable in a hex dump
  PacketHeader h;
  ASSERT_EQ(decodeHeader(packet, &h), ProtocolError::kOk);
  EXPECT_EQ(h.type, PacketType::kAck);
  EXPECT_EQ(h.module, 3);
  EXPECT_EQ(h.sequence, 42u);
  EXPECT_EQ(h.payloadSize, kAckSize);
  const std::span<const uint8_t> payload(packet.data() + kHeaderSize, kAckSize);
  EXPECT_EQ(verifyPayload(h, payload), ProtocolError::kOk);
  Ack ack;
  ASSERT_EQ(decodeAck(payload, &ack), ProtocolError::kOk);
  EXPECT_EQ(ack.ackedSequence, 42u);
  EXPECT_EQ(ack.detail, 7u);
}

TEST(LinkProtocol, EachDamageHasItsOwnError) {
  PacketHeader h;
  std::vector<uint8_t> p = ackPacket();
  EXPECT_EQ(decodeHeader({p.data(), kHeaderSize - 1}, &h), ProtocolError::kTruncated);

  p = ackPacket();
  p[0] ^= 0xFF;
  EXPECT_EQ(decodeHeader(p, &h), ProtocolError::kBadMagic);

  p = ackPacket();
  p[4] = 1;  // version 1: no swap lock
  resealHeader(p);
  EXPECT_EQ(decodeHeader(p, &h), ProtocolError::kBadVersion);

  p = ackPacket();
  p[13] ^= 1;  // sequence changed, CRC not resealed
  EXPECT_EQ(decodeHeader(p, &h), ProtocolError::kBadHeaderCrc);

  p = ackPacket();
  p[6] = 200;
  resealHeader(p);
  EXPECT_EQ(decodeHeader(p, &h), ProtocolError::kUnknownType);

  p = ackPacket();
  p[25] = 1;
  resealHeader(p);
  EXPECT_EQ(decodeHeader(p, &h), ProtocolError::kReservedNonZero);

  p = ackPacket();
  const uint32_t huge = kMaxPayloadSize + 1;
  std::memcpy(&p[16], &huge, 4);  // little-endian host assumed by this test only
  resealHeader(p);
  EXPECT_EQ(decodeHeader(p, &h), ProtocolError::kOversized);

  p = ackPacket();
  ASSERT_EQ(decodeHeader(p, &h), ProtocolError::kOk);
  p[kHeaderSize + 1] ^= 4;
  EXPECT_EQ(verifyPayload(h, {p.data() + kHeaderSize, kAckSize}), ProtocolError::kBadPayloadCrc);
  EXPECT_EQ(verifyPayload(h, {p.data() + kHeaderSize, kAckSize - 1}), ProtocolError::kTruncated);
}

TEST(LinkProtocol, BodiesRejectOutOfRangeFields) {
  FrameBegin f;
  f.width = 4;
  f.height = 2;
  f.totalSize = 4 * 2 * 3;
  f.chunkCount = 1;
  std::vector<uint8_t> body = encodeFrameBegin(f);
  FrameBegin out;
  ASSERT_EQ(decodeFrameBegin(body, &out), ProtocolError::kOk);
  EXPECT_EQ(out.totalSize, 24u);
  body[12] = 25;  // size that does not match 4x2 RGB8
  EXPECT_EQ(decodeFrameBegin(body, &out), ProtocolError::kBadBody);
  body = encodeFrameBegin(f);
  body[8] = 9;  // unknown pixel format
  EXPECT_EQ(decodeFrameBegin(body, &out), ProtocolError::kBadBody);
  body = encodeFrameBegin(f);
  body.pop_back();
  EXPECT_EQ(decodeFrameBegin(body, &out), ProtocolError::kTruncated);
  body = encodeFrameBegin(f);
  body.push_back(0);
  EXPECT_EQ(decodeFrameBegin(body, &out), ProtocolError::kOversized);

  // A patch names its base and belongs to a display frame; nothing else names a base.
  FrameBegin patch = f;
  patch.flags = kFramePatch;
  patch.baseHash = 0x0123456789ABCDEFull;
  patch.displayFrame = 3;
  ASSERT_EQ(decodeFrameBegin(encodeFrameBegin(patch), &out), ProtocolError::kOk);
  EXPECT_EQ(out.baseHash, 0x0123456789ABCDEFull);
  EXPECT_EQ(out.flags, kFramePatch);
  patch.displayFrame = 0;
  EXPECT_EQ(decodeFrameBegin(encodeFrameBegin(patch), &out), ProtocolError::kBadBody);
  patch.displayFrame = 3;
  patch.flags = kFramePatch | kFrameReuse;
  EXPECT_EQ(decodeFrameBegin(encodeFrameBegin(patch), &out), ProtocolError::kBadBody);
  FrameBegin named = f;
  named.baseHash = 1;
  EXPECT_EQ(decodeFrameBegin(encodeFrameBegin(named), &out), ProtocolError::kBadBody);

  // Width x height x 3 must not overflow into a small accepted size.
  f.width = 0x10000;
  f.height = 0x10000;
  f.totalSize = 0;
  EXPECT_EQ(decodeFrameBegin(encodeFrameBegin(f), &out), ProtocolError::kBadBody);

  DeviceInfo info;
  info.moduleCount = 2;
  info.width = 1024;
  info.height = 768;
  info.maxChunkSize = 1 << 20;
  info.serial = "SIM0001";
  DeviceInfo back;
  ASSERT_EQ(decodeDeviceInfo(encodeDeviceInfo(info), &back), ProtocolError::kOk);
  EXPECT_EQ(back.serial, "SIM0001");
  std::vector<uint8_t> bad = encodeDeviceInfo(info);
  bad[24 + 2] = 0x07;  // a control character in the serial
  EXPECT_EQ(decodeDeviceInfo(bad, &back), ProtocolError::kBadBody);

  Fault fault;
  std::vector<uint8_t> fb = encodeFault({FaultKind::kStall, 2, 0});
  ASSERT_EQ(decodeFault(fb, &fault), ProtocolError::kOk);
  EXPECT_EQ(fault.kind, FaultKind::kStall);
  fb[0] = 99;
  EXPECT_EQ(decodeFault(fb, &fault), ProtocolError::kBadBody);
}

TEST(LinkProtocol, CaptureRequestCarriesTheStation) {
  CaptureRequest r;
  r.viewModule = 2;
  r.station = 4;
  r.exposureUs = 12000;
  r.gainCenti = 150;
  std::vector<uint8_t> body = encodeCaptureRequest(r);
  ASSERT_EQ(body.size(), kCaptureRequestSize);
  CaptureRequest back;
  ASSERT_EQ(decodeCaptureRequest(body, &back), ProtocolError::kOk);
  EXPECT_EQ(back.station, 4);
  EXPECT_EQ(back.viewModule, 2);
  EXPECT_EQ(back.exposureUs, 12000u);
  EXPECT_EQ(back.gainCenti, 150);
  body[10] = 1;  // kCaptureColour: an RGB picture
  ASSERT_EQ(decodeCaptureRequest(body, &back), ProtocolError::kOk);
  EXPECT_EQ(back.flags, kCaptureColour);
  body[10] = 2;  // a flag version 1 does not define
  EXPECT_EQ(decodeCaptureRequest(body, &back), ProtocolError::kBadBody);
}

TEST(PacketReader, ReassemblesPacketsFedOneByteAtATime) {
  std::vector<uint8_t> stream = ackPacket();
  const std::vector<uint8_t> keepAlive = encodePacket({PacketType::kKeepAlive, 0, 0, 9, 0, 0}, {});
  stream.insert(stream.end(), keepAlive.begin(), keepAlive.end());
  PacketReader reader;
  std::vector<PacketType> seen;
  for (uint8_t byte : stream) {
    ASSERT_EQ(reader.feed({&byte, 1}), 1u);
    if (reader.ready()) {
      seen.push_back(reader.header().type);
      reader.next();
    }
  }
  EXPECT_EQ(reader.error(), ProtocolError::kOk);
  EXPECT_EQ(seen, (std::vector<PacketType>{PacketType::kAck, PacketType::kKeepAlive}));
}

TEST(PacketReader, StopsAtTheFirstBadPacket) {
  std::vector<uint8_t> stream = ackPacket();
  stream[kHeaderSize + 2] ^= 1;  // payload damaged
  PacketReader reader;
  reader.feed(stream);
  EXPECT_FALSE(reader.ready());
  EXPECT_EQ(reader.error(), ProtocolError::kBadPayloadCrc);
}

TEST(FaultSpec, ParsesAndExplains) {
  const FaultSpec s = parseFaultSpec("3:slow:10:5000");
  EXPECT_EQ(s.module, 3);
  EXPECT_EQ(s.fault.kind, FaultKind::kSlowLink);
  EXPECT_EQ(s.fault.count, 10u);
  EXPECT_EQ(s.fault.param, 5000u);
  EXPECT_EQ(parseFaultSpec("0:crash").fault.count, 1u);
  try {
    parseFaultSpec("1:melt");
    FAIL() << "accepted an unknown fault";
  } catch (const InputError& e) {
    EXPECT_EQ(e.location().field, "--fault");
    EXPECT_NE(std::string(e.what()).find("unknown fault \"melt\""), std::string::npos);
  }
  EXPECT_THROW(parseFaultSpec("x:drop"), InputError);
  EXPECT_THROW(parseFaultSpec("1:drop:2:3:4"), InputError);
}

}  // namespace
}  // namespace parallax::hw
