#include "sitepose/output/e2e.hpp"

#include <gtest/gtest.h>

#include <string_view>
#include <vector>

namespace sitepose::output {
namespace {

std::uint8_t crc_of(std::vector<std::uint8_t> bytes) { return crc8_sae_j1850(bytes); }

TEST(Crc8SaeJ1850, CheckValue) {
  constexpr std::string_view kCheck = "123456789";
  const std::vector<std::uint8_t> bytes(kCheck.begin(), kCheck.end());
  EXPECT_EQ(crc8_sae_j1850(bytes), 0x4B);
}

TEST(Crc8SaeJ1850, AutosarCrcLibraryTestVectors) {
  // AUTOSAR SWS CRC library, CRC8 SAE J1850 examples.
  EXPECT_EQ(crc_of({0x00, 0x00, 0x00, 0x00}), 0x59);
  EXPECT_EQ(crc_of({0xF2, 0x01, 0x83}), 0x37);
  EXPECT_EQ(crc_of({0x0F, 0xAA, 0x00, 0x55}), 0x79);
  EXPECT_EQ(crc_of({0x00, 0xFF, 0x55, 0x11}), 0xB8);
  EXPECT_EQ(crc_of({0x33, 0x22, 0x55, 0xAA, 0xBB, 0xCC, 0xDD, 0xEE, 0xFF}), 0xCB);
  EXPECT_EQ(crc_of({0x92, 0x6B, 0x55}), 0x8C);
  EXPECT_EQ(crc_of({0xFF, 0xFF, 0xFF, 0xFF}), 0x74);
}

TEST(Crc8SaeJ1850, IncrementalEqualsOneShotAndDetectsSingleBitFlips) {
  const std::vector<std::uint8_t> all{0x10, 0xFF, 0x03, 0x5E, 0x01, 0x0C, 0x00, 0x05, 0x4B};
  std::uint8_t crc = crc8_sae_j1850_update(kCrc8J1850Init, std::span(all).first(2));
  crc = crc8_sae_j1850_update(crc, std::span(all).subspan(2));
  EXPECT_EQ(crc ^ kCrc8J1850XorOut, crc8_sae_j1850(all));
  for (std::size_t byte = 0; byte < all.size(); ++byte) {
    for (int bit = 0; bit < 8; ++bit) {
      auto flipped = all;
      flipped[byte] ^= static_cast<std::uint8_t>(1 << bit);
      EXPECT_NE(crc8_sae_j1850(flipped), crc8_sae_j1850(all)) << byte << ":" << bit;
    }
  }
}

TEST(E2eAliveCounter, CountsModulo16) {
  E2eAliveCounter c;
  for (int i = 0; i < 40; ++i) EXPECT_EQ(c.next(), i % 16);
  EXPECT_EQ(c.peek(), 40 % 16);
}

}  // namespace
}  // namespace sitepose::output
