#include "sitepose/output/can_frame.hpp"

#include <gtest/gtest.h>

namespace sitepose::output {
namespace {

TEST(J1939Id, PlatformExample129025) {
  // PLATFORM.md: PGN 129025, priority 2, SA 0x1C -> 0x09F8011C.
  const auto id = make_j1939_id({2, 129025, 0x1C});
  ASSERT_TRUE(id.has_value());
  EXPECT_EQ(*id, 0x09F8011Cu);
}

TEST(J1939Id, Pdu2AndPdu1Layouts) {
  // VP 65267 = 0xFEF3, priority 6, SA 0x1C: 6 << 26 = 0x18000000.
  EXPECT_EQ(*make_j1939_id({6, 65267, 0x1C}), 0x18FEF31Cu);
  // Proprietary B 0xFF10 keeps its group extension byte.
  EXPECT_EQ(*make_j1939_id({6, 0xFF10, 0x1C}), 0x18FF101Cu);
  // TP.CM 60416 = 0xEC00 is PDU1: the PS byte becomes the destination.
  EXPECT_EQ(*make_j1939_id({7, 0xEC00, 0x1C, 0xFF}), 0x1CECFF1Cu);
  EXPECT_EQ(*make_j1939_id({7, 0xEC00, 0x1C, 0x25}), 0x1CEC251Cu);
  // DP bit (NMEA 2000 PGNs above 0xFFFF).
  EXPECT_EQ(*make_j1939_id({3, 129029, 0x00}), 0x0DF80500u);
}

TEST(J1939Id, RejectsOutOfRangeFieldsNamingThem) {
  const auto bad_priority = make_j1939_id({8, 65267, 0x1C});
  ASSERT_FALSE(bad_priority.has_value());
  EXPECT_NE(bad_priority.error().message.find("priority = 8"), std::string::npos);
  const auto bad_pgn = make_j1939_id({6, 0x40000, 0x1C});
  ASSERT_FALSE(bad_pgn.has_value());
  EXPECT_NE(bad_pgn.error().message.find("0x40000"), std::string::npos);
  const auto bad_pdu1 = make_j1939_id({6, 0xEC01, 0x1C});
  ASSERT_FALSE(bad_pdu1.has_value());
  EXPECT_NE(bad_pdu1.error().message.find("PDU1"), std::string::npos);
}

TEST(J1939Id, SplitInvertsMake) {
  const J1939Id a = split_j1939_id(0x09F8011C);
  EXPECT_EQ(a.priority, 2);
  EXPECT_EQ(a.pgn, 129025u);
  EXPECT_EQ(a.source_address, 0x1C);
  const J1939Id b = split_j1939_id(0x1CEC251C);
  EXPECT_EQ(b.priority, 7);
  EXPECT_EQ(b.pgn, 0xEC00u);
  EXPECT_EQ(b.destination_address, 0x25);
  EXPECT_EQ(b.source_address, 0x1C);
}

}  // namespace
}  // namespace sitepose::output
