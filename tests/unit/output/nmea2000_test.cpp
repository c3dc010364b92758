#include "sitepose/output/nmea2000.hpp"

#include <gtest/gtest.h>

#include <limits>
#include <numbers>

#include "test_util.hpp"

namespace sitepose::output {
namespace {

using testing::expect_data;
using testing::hex_bytes;
constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kPi = std::numbers::pi;

TEST(N2kPositionRapidUpdate, PlatformExampleLine) {
  // PLATFORM.md: 09F8011C#6A3C4B23D0F1C204 = lat 0x234B3C6A = 592133226
  // (59.2133226 deg), lon 0x04C2F1D0 = 79884752 (7.9884752 deg).
  const CanFrame f = encode_n2k_position_rapid_update(59.2133226, 7.9884752, 0x1C);
  EXPECT_EQ(f.id, 0x09F8011Cu);
  expect_data(f, {0x6A, 0x3C, 0x4B, 0x23, 0xD0, 0xF1, 0xC2, 0x04});
}

TEST(N2kPositionRapidUpdate, NegativeNotAvailableAndClamp) {
  // -33.8568 deg = -338568000 = 0xEBD1DCC0; -151.2153 deg = -1512153000 = 0xA5DE6058.
  expect_data(encode_n2k_position_rapid_update(-33.8568, -151.2153, 0x1C),
              {0xC0, 0xDC, 0xD1, 0xEB, 0x58, 0x60, 0xDE, 0xA5});
  expect_data(encode_n2k_position_rapid_update(kNan, kNan, 0x1C),
              {0xFF, 0xFF, 0xFF, 0x7F, 0xFF, 0xFF, 0xFF, 0x7F});
  // 250 deg does not fit an int32 at 1e-7: clamps to 0x7FFFFFFC (max valid).
  expect_data(encode_n2k_position_rapid_update(250.0, -250.0, 0x1C),
              {0xFC, 0xFF, 0xFF, 0x7F, 0x01, 0x00, 0x00, 0x80});
}

TEST(N2kVesselHeading, HandComputedBytes) {
  // SID 5; pi/2 rad -> 15708 = 0x3D5C; deviation n/a 0x7FFF; variation
  // -0.1 rad -> -1000 = 0xFC18; reference true (0) with 6 reserved 1-bits.
  const CanFrame f =
      encode_n2k_vessel_heading({5, kPi / 2, kNan, -0.1, HeadingReference::kTrue}, 0x1C);
  EXPECT_EQ(f.id, 0x09F1121Cu);
  expect_data(f, {0x05, 0x5C, 0x3D, 0xFF, 0x7F, 0x18, 0xFC, 0xFC});
  // -pi/2 wraps to 3 pi / 2 -> 47124 = 0xB814; magnetic reference = 1.
  expect_data(encode_n2k_vessel_heading({0, -kPi / 2, 0.0, 0.0, HeadingReference::kMagnetic}, 0x1C),
              {0x00, 0x14, 0xB8, 0x00, 0x00, 0x00, 0x00, 0xFD});
  expect_data(encode_n2k_vessel_heading(
                  {kN2kSidNotAvailable, kNan, kNan, kNan, HeadingReference::kTrue}, 0x1C),
              {0xFF, 0xFF, 0xFF, 0xFF, 0x7F, 0xFF, 0x7F, 0xFC});
}

TEST(N2kCogSogRapidUpdate, HandComputedBytes) {
  // SID 7; ref true + reserved -> 0xFC; COG pi -> 31416 = 0x7AB8; SOG 2.5 m/s
  // -> 250 = 0x00FA; two reserved bytes 0xFF.
  const CanFrame f = encode_n2k_cog_sog_rapid_update({7, HeadingReference::kTrue, kPi, 2.5}, 0x1C);
  EXPECT_EQ(f.id, 0x09F8021Cu);
  expect_data(f, {0x07, 0xFC, 0xB8, 0x7A, 0xFA, 0x00, 0xFF, 0xFF});
  // Negative speed clamps to 0; 1000 m/s to 0xFFFC; NaN COG -> 0xFFFF.
  expect_data(encode_n2k_cog_sog_rapid_update({1, HeadingReference::kTrue, kNan, -1.0}, 0x1C),
              {0x01, 0xFC, 0xFF, 0xFF, 0x00, 0x00, 0xFF, 0xFF});
  expect_data(encode_n2k_cog_sog_rapid_update({1, HeadingReference::kTrue, 0.0, 1000.0}, 0x1C),
              {0x01, 0xFC, 0x00, 0x00, 0xFC, 0xFF, 0xFF, 0xFF});
}

GnssPositionData example_gnss() {
  GnssPositionData g;
  g.sid = 9;
  g.utc_t_ns = 1'700'000'000'123'456'789LL;  // 2023-11-14 22:13:20.1234 UTC
  g.latitude_deg = 59.2133226;
  g.longitude_deg = -151.2153;
  g.altitude_m = 123.456789;
  g.type = GnssType::kIntegrated;
  g.method = GnssMethod::kEstimated;
  g.integrity = GnssIntegrity::kCaution;
  return g;
}

TEST(N2kGnssPositionData, HandComputedPayload) {
  // date 19675 days = 0x4CDB; time 80000.1234 s -> 800001234 = 0x2FAF0CD2;
  // lat = round(59.2133226 (as double) * 1e16) = 592133225999999979;
  // lon = -1512153000000000134; alt 123456789 um; type 6 | method 6 << 4 =
  // 0x66; integrity 2 | reserved 0xFC = 0xFE; nSV n/a 0xFF; HDOP, PDOP n/a
  // 0x7FFF; geoidal separation n/a 0x7FFFFFFF; 0 reference stations.
  const std::vector<std::uint8_t> expected{
      0x09, 0xDB, 0x4C, 0xD2, 0x0C, 0xAF, 0x2F, 0xEB, 0xA3, 0x6F, 0x23, 0x08, 0xAE, 0x37, 0x08,
      0x7A, 0x6F, 0xF5, 0xB4, 0xDB, 0xC0, 0x03, 0xEB, 0x15, 0xCD, 0x5B, 0x07, 0x00, 0x00, 0x00,
      0x00, 0x66, 0xFE, 0xFF, 0xFF, 0x7F, 0xFF, 0x7F, 0xFF, 0xFF, 0xFF, 0x7F, 0x00};
  const auto payload = encode_n2k_gnss_position_payload(example_gnss());
  ASSERT_EQ(payload.size(), kGnssPositionDataBytes);
  EXPECT_EQ(hex_bytes(payload.data(), payload.size()), hex_bytes(expected.data(), expected.size()));
}

TEST(N2kGnssPositionData, OptionalFieldsWhenGiven) {
  GnssPositionData g = example_gnss();
  g.type = GnssType::kGps;
  g.method = GnssMethod::kRtkFixed;
  g.integrity = GnssIntegrity::kSafe;
  g.satellites = 12;
  g.hdop = 0.8;
  g.pdop = 1.25;
  g.geoidal_separation_m = 45.67;
  const auto p = encode_n2k_gnss_position_payload(g);
  // type 0 | method 4 << 4 = 0x40; integrity 1 | 0xFC = 0xFD; 12 SVs;
  // HDOP 80 = 0x0050; PDOP 125 = 0x007D; separation 4567 = 0x000011D7.
  const std::vector<std::uint8_t> tail{0x40, 0xFD, 0x0C, 0x50, 0x00, 0x7D,
                                       0x00, 0xD7, 0x11, 0x00, 0x00, 0x00};
  EXPECT_EQ(hex_bytes(p.data() + 31, 12), hex_bytes(tail.data(), tail.size()));
  g.utc_t_ns = -1;  // unknown time: date and time n/a
  const auto q = encode_n2k_gnss_position_payload(g);
  EXPECT_EQ(hex_bytes(q.data() + 1, 6), "FF FF FF FF FF FF");
}

TEST(N2kGnssPositionData, SevenFastPacketFrames) {
  const auto frames = encode_n2k_gnss_position_data(example_gnss(), 5, 0x1C);
  const auto payload = encode_n2k_gnss_position_payload(example_gnss());
  ASSERT_EQ(frames.size(), 7u);                               // 6 + 6 * 7 = 48 >= 43
  for (const auto& f : frames) EXPECT_EQ(f.id, 0x0DF8051Cu);  // priority 3
  expect_data(frames[0], {0xA0, 43, 0x09, 0xDB, 0x4C, 0xD2, 0x0C, 0xAF});
  expect_data(frames[1], {0xA1, 0x2F, 0xEB, 0xA3, 0x6F, 0x23, 0x08, 0xAE});
  // Last frame: payload bytes 41, 42, then 5 pad bytes.
  expect_data(frames[6], {0xA6, 0x7F, 0x00, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF});
}

TEST(FastPacket, SegmentationCountersAndPadding) {
  std::vector<std::uint8_t> payload(20);
  for (std::size_t i = 0; i < payload.size(); ++i) payload[i] = static_cast<std::uint8_t>(i + 1);
  const auto frames = fast_packet_frames(0x09F8051C, payload, 7);
  ASSERT_TRUE(frames.has_value());
  ASSERT_EQ(frames->size(), 3u);  // 6 + 7 + 7 = 20
  expect_data((*frames)[0], {0xE0, 20, 1, 2, 3, 4, 5, 6});
  expect_data((*frames)[1], {0xE1, 7, 8, 9, 10, 11, 12, 13});
  expect_data((*frames)[2], {0xE2, 14, 15, 16, 17, 18, 19, 20});

  const std::vector<std::uint8_t> six{1, 2, 3, 4, 5, 6};
  const auto one = fast_packet_frames(0x09F8051C, six, 0);
  ASSERT_TRUE(one.has_value());
  ASSERT_EQ(one->size(), 1u);
  expect_data((*one)[0], {0x00, 6, 1, 2, 3, 4, 5, 6});

  const std::vector<std::uint8_t> seven{1, 2, 3, 4, 5, 6, 7};
  const auto two = fast_packet_frames(0x09F8051C, seven, 1);
  ASSERT_TRUE(two.has_value());
  ASSERT_EQ(two->size(), 2u);
  expect_data((*two)[1], {0x21, 7, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF});
}

TEST(FastPacket, MaximumAndRejections) {
  const std::vector<std::uint8_t> max(kFastPacketMaxBytes, 0x55);
  const auto frames = fast_packet_frames(0x09F8051C, max, 2);
  ASSERT_TRUE(frames.has_value());
  ASSERT_EQ(frames->size(), 32u);
  EXPECT_EQ(frames->back().data[0], (2 << 5) | 31);
  EXPECT_EQ(frames->back().data[7], 0x55);  // 223 = 6 + 31 * 7 exactly: no padding

  const std::vector<std::uint8_t> too_long(kFastPacketMaxBytes + 1, 0);
  const auto bad = fast_packet_frames(0x09F8051C, too_long, 0);
  ASSERT_FALSE(bad.has_value());
  EXPECT_NE(bad.error().message.find("224 bytes"), std::string::npos);
  EXPECT_FALSE(fast_packet_frames(0x09F8051C, std::vector<std::uint8_t>{}, 0).has_value());
  const auto bad_seq = fast_packet_frames(0x09F8051C, max, 8);
  ASSERT_FALSE(bad_seq.has_value());
  EXPECT_NE(bad_seq.error().message.find("counter = 8"), std::string::npos);
}

}  // namespace
}  // namespace sitepose::output
