// The libusb transport's logic, driven through the UsbBackend seam by devices that fail like
// real ones; and the real libusb backend on this machine, which has no matching devices.

#include "hw/link/usb_transport.h"

#include <gtest/gtest.h>

#include <random>

#include "common/input_error.h"
#include "fake_usb_backend.h"
#include "hw/link/link_client.h"
#include "hw/link/link_factory.h"
#include "random_frame.h"

namespace parallax::hw {
namespace {

constexpr int kWidth = 64, kHeight = 48;  // 9216-byte frames: five 2 KiB transfers

std::shared_ptr<const Image> makeFrame(uint32_t seed) { return randomFrame(kWidth, kHeight, seed); }

UsbTransportOptions usbOptions(std::vector<std::string> serials) {
  UsbTransportOptions o;
  o.serials = std::move(serials);
  o.transferSize = 2048;
  o.transfersInFlight = 3;
  o.transferTimeoutMs = 50;
  return o;
}

LinkOptions linkOptions() {
  LinkOptions o;
  o.chunkSize = 4096;
  o.ackTimeoutMs = 200;
  o.reconnectAttempts = 2;
  o.reconnectDelayMs = 5;
  o.linkDownRetryMs = 0;
  return o;
}

struct UsbRig {
  FakeUsbBackend* backend;
  UsbTransport* transport;
  std::unique_ptr<LinkClient> link;
};

UsbRig makeRig(std::vector<std::string> present, std::vector<std::string> map) {
  auto backend = std::make_unique<FakeUsbBackend>(present, kWidth, kHeight);
  UsbRig rig;
  rig.backend = backend.get();
  auto transport = std::make_unique<UsbTransport>(usbOptions(map), std::move(backend));
  rig.transport = transport.get();
  rig.link = std::make_unique<LinkClient>(std::move(transport), linkOptions());
  return rig;
}

TEST(UsbTransport, RealLibusbWithoutDevicesSaysSoInOneLine) {
  UsbTransportOptions o;
  o.vendorId = 0x1209;
  o.productId = 0x0001;  // pid.codes' test id: nothing here answers to it
  UsbTransport transport(o, makeLibusbBackend());
  std::string error;
  EXPECT_EQ(transport.open(&error), TransportStatus::kUnavailable);
  EXPECT_EQ(error.rfind("no USB devices", 0), 0u) << error;
  EXPECT_EQ(error.find('\n'), std::string::npos);
  EXPECT_FALSE(transport.isOpen());
  std::vector<ReceivedPacket> packets;
  EXPECT_EQ(transport.receive(&packets, 10), TransportStatus::kDisconnected);
}

TEST(UsbTransport, NoUsbSubsystemSaysSoInOneLine) {
  UsbTransport transport(usbOptions({}),
                         std::make_unique<FakeUsbBackend>(std::vector<std::string>{}, 8, 8, false));
  std::string error;
  EXPECT_EQ(transport.open(&error), TransportStatus::kUnavailable);
  EXPECT_EQ(error.rfind("no USB devices: USB is not available", 0), 0u) << error;
  // Through LinkClient the same line becomes the exception text.
  try {
    LinkClient client(std::make_unique<UsbTransport>(
        usbOptions({}), std::make_unique<FakeUsbBackend>(std::vector<std::string>{}, 8, 8)));
    FAIL() << "came up without devices";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("no USB devices with VID:PID 1209:7078", 0), 0u)
        << e.what();
  }
}

TEST(UsbTransport, SerialMapDecidesWhichDeviceIsWhichModule) {
  UsbRig rig = makeRig({"A", "B", "C"}, {"C", "A", "B"});
  ASSERT_EQ(rig.link->modules().size(), 3u);
  EXPECT_EQ(rig.link->modules()[0].info.serial, "C0000");
  std::vector<std::shared_ptr<const Image>> frames;
  for (int m = 0; m < 3; ++m) {
    frames.push_back(makeFrame(m));
    rig.link->submit(m, frames.back());
  }
  rig.link->flush();
  for (const FrameOutcome& o : rig.link->takeOutcomes()) {
    EXPECT_EQ(o.status, FrameStatus::kDelivered) << o.reason;
  }
  EXPECT_EQ(rig.backend->device("C").hardware->shownFrame(0).pixels, frames[0]->pixels);
  EXPECT_EQ(rig.backend->device("A").hardware->shownFrame(0).pixels, frames[1]->pixels);
  EXPECT_EQ(rig.backend->device("B").hardware->shownFrame(0).pixels, frames[2]->pixels);
  EXPECT_GT(rig.transport->stats().transfers, 3u * 4u);  // several transfers per frame
}

TEST(UsbTransport, TimeoutsStallsAndShortWritesAreResubmittedWithoutLoss) {
  UsbRig rig = makeRig({"A", "B"}, {"A", "B"});
  FakeUsbBackend::FakeDevice& a = rig.backend->device("A");
  a.script = {{UsbResult::kOk, SIZE_MAX}, {UsbResult::kTimeout, 700}, {UsbResult::kOk, SIZE_MAX},
              {UsbResult::kStall, 0},     {UsbResult::kOk, 100},      {UsbResult::kOk, SIZE_MAX},
              {UsbResult::kTimeout, 0},   {UsbResult::kOk, 1}};
  std::vector<std::shared_ptr<const Image>> last(2);
  for (int round = 0; round < 3; ++round) {
    for (int m = 0; m < 2; ++m) {
      last[m] = makeFrame(10 * round + m);
      rig.link->submit(m, last[m]);
    }
  }
  rig.link->flush();
  for (const FrameOutcome& o : rig.link->takeOutcomes()) {
    EXPECT_EQ(o.status, FrameStatus::kDelivered) << o.reason;
    EXPECT_EQ(o.attempts, 1) << "the transfer layer alone should absorb these";
  }
  const UsbTransportStats& s = rig.transport->stats();
  EXPECT_EQ(s.timeouts, 2u);
  EXPECT_EQ(s.stalls, 1u);
  EXPECT_EQ(s.shortWrites, 2u);
  EXPECT_EQ(rig.backend->clearHalts, 1);
  EXPECT_EQ(rig.backend->deviceParseErrors, 0);
  EXPECT_EQ(a.hardware->shownFrame(0).pixels, last[0]->pixels);
  EXPECT_EQ(rig.backend->device("B").hardware->shownFrame(0).pixels, last[1]->pixels);
}

TEST(UsbTransport, EndlessTimeoutsFailTheFrameWithAReason) {
  UsbRig rig = makeRig({"A"}, {"A"});
  FakeUsbBackend::FakeDevice& a = rig.backend->device("A");
  a.script.assign(200, {UsbResult::kTimeout, 0});
  const uint64_t ticket = rig.link->submit(0, makeFrame(1));
  rig.link->flush();
  const auto outcomes = rig.link->takeOutcomes();
  ASSERT_EQ(outcomes.size(), 1u);
  EXPECT_EQ(outcomes[0].ticket, ticket);
  EXPECT_EQ(outcomes[0].status, FrameStatus::kFailed);
  EXPECT_FALSE(outcomes[0].reason.empty());
  EXPECT_TRUE(a.hardware->shownFrame(0).empty());
}

TEST(UsbTransport, DeviceGoneMidTransferIsReportedThenRecoversAfterReplug) {
  UsbRig rig = makeRig({"A", "B"}, {"A", "B"});
  rig.link->submit(1, makeFrame(1));
  rig.link->flush();
  rig.link->takeOutcomes();
  // B vanishes in the middle of its next frame (LIBUSB_ERROR_NO_DEVICE on a transfer).
  rig.backend->device("B").script = {{UsbResult::kOk, SIZE_MAX}, {UsbResult::kNoDevice, 300}};
  const uint64_t doomed = rig.link->submit(1, makeFrame(2));
  rig.link->flush();
  auto outcomes = rig.link->takeOutcomes();
  ASSERT_EQ(outcomes.size(), 1u);
  EXPECT_EQ(outcomes[0].ticket, doomed);
  EXPECT_EQ(outcomes[0].status, FrameStatus::kFailed);
  EXPECT_NE(outcomes[0].reason.find("link down"), std::string::npos) << outcomes[0].reason;
  EXPECT_GE(rig.transport->stats().noDevice, 1u);

  // Plugged back in (hotplug arrival): the next frame reconnects and arrives.
  rig.backend->replug("B");
  auto next = makeFrame(3);
  rig.link->submit(1, next);
  rig.link->flush();
  outcomes = rig.link->takeOutcomes();
  ASSERT_EQ(outcomes.size(), 1u);
  EXPECT_EQ(outcomes[0].status, FrameStatus::kDelivered) << outcomes[0].reason;
  EXPECT_EQ(rig.backend->device("B").hardware->shownFrame(0).pixels, next->pixels);
}

TEST(LinkFactory, AutoFallsBackToTheSimulatorWithOneLineWhy) {
  // This machine (a container / CI) has no modules on USB.
  LinkSelection selection;
  selection.simhwSocket = "/tmp/nowhere.sock";
  const SelectedLink chosen = selectLink(selection);
  ASSERT_TRUE(chosen.transport);
  EXPECT_EQ(chosen.transport->name(), "simhw:/tmp/nowhere.sock");
  EXPECT_EQ(chosen.note.rfind("link: no USB devices", 0), 0u) << chosen.note;
  EXPECT_NE(chosen.note.find("using the simulator at /tmp/nowhere.sock"), std::string::npos);
  EXPECT_EQ(chosen.note.find('\n'), std::string::npos);
  selection.spec = "simhw:/tmp/x.sock";
  EXPECT_EQ(selectLink(selection).transport->name(), "simhw:/tmp/x.sock");
}

TEST(UsbTransport, OptionsExplainThemselves) {
  UsbTransportOptions o;
  o.serials = {"X", "Y", "X"};
  try {
    o.validate();
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.location().field, "usb.serials[2]");
  }
  EXPECT_THROW(createLinkTransport("usb:12G9:0001"), InputError);
  EXPECT_THROW(createLinkTransport("warp:drive"), InputError);
  EXPECT_NO_THROW(createLinkTransport("usb:1209:0001:S1,S2"));
}

}  // namespace
}  // namespace parallax::hw
