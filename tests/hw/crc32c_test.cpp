#include "hw/link/crc32c.h"

#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <vector>

#include "hw/link/content_hash.h"

namespace parallax::hw {
namespace {

TEST(Crc32c, KnownAnswers) {
  // The CRC-32C check value (RFC 3720, B.4) and the iSCSI test vector of 32 zero bytes.
  EXPECT_EQ(crc32c("123456789", 9), 0xE3069283u);
  EXPECT_EQ(crc32cPortable("123456789", 9), 0xE3069283u);
  const std::vector<uint8_t> zeros(32, 0);
  EXPECT_EQ(crc32c(zeros.data(), zeros.size()), 0x8A9136AAu);
  EXPECT_EQ(crc32c(nullptr, 0), 0u);
}

TEST(Crc32c, FastPathMatchesPortableOnEverySizeAndAlignment) {
  std::mt19937 rng(7);
  std::vector<uint8_t> data(3 * 8192 * 3 + 123);
  for (auto& b : data) b = static_cast<uint8_t>(rng());
  // Sizes around the three-lane block boundary, at odd offsets.
  for (size_t size : {0ul, 1ul, 7ul, 8ul, 9ul, 24575ul, 24576ul, 24577ul, 49152ul + 5, 70000ul}) {
    for (size_t offset : {0ul, 1ul, 3ul}) {
      if (offset + size > data.size()) continue;
      EXPECT_EQ(crc32c(data.data() + offset, size), crc32cPortable(data.data() + offset, size))
          << "size " << size << " offset " << offset;
    }
  }
}

TEST(Crc32c, ChainingAndCombiningEqualTheWholeBuffer) {
  std::mt19937 rng(11);
  std::vector<uint8_t> data(100000);
  for (auto& b : data) b = static_cast<uint8_t>(rng());
  const uint32_t whole = crc32c(data.data(), data.size());
  for (size_t split : {0ul, 1ul, 4096ul, 33333ul, 99999ul, 100000ul}) {
    const uint32_t a = crc32c(data.data(), split);
    const uint32_t b = crc32c(data.data() + split, data.size() - split);
    EXPECT_EQ(crc32c(data.data() + split, data.size() - split, a), whole) << split;
    EXPECT_EQ(crc32cCombine(a, b, data.size() - split), whole) << split;
  }
}

TEST(Crc32c, DetectsEverySingleBitFlip) {
  std::vector<uint8_t> data(4096, 0x5A);
  const uint32_t clean = crc32c(data.data(), data.size());
  for (size_t i = 0; i < data.size(); i += 97) {
    for (int bit = 0; bit < 8; ++bit) {
      data[i] ^= static_cast<uint8_t>(1 << bit);
      EXPECT_NE(crc32c(data.data(), data.size()), clean);
      data[i] ^= static_cast<uint8_t>(1 << bit);
    }
  }
}

TEST(ContentHash, ChangesWithAnyByteAndWithLength) {
  std::vector<uint8_t> data(1000, 0);
  const uint64_t h = contentHash64(data.data(), data.size());
  EXPECT_EQ(h, contentHash64(data.data(), data.size()));
  EXPECT_NE(h, contentHash64(data.data(), data.size() - 1));
  for (size_t i = 0; i < data.size(); ++i) {
    data[i] = 1;
    EXPECT_NE(contentHash64(data.data(), data.size()), h) << i;
    data[i] = 0;
  }
}

}  // namespace
}  // namespace parallax::hw
