// The ACTION_CMD / ACTION_ACK codec, byte for byte (GigE Vision 2.x GVCP:
// big-endian, key 0x42, flags 0x01 ack required and 0x80 scheduled).
#include "sitepose/drivers/aravis/gvcp_action.hpp"

#include <gtest/gtest.h>

namespace sitepose::drivers::aravis::gvcp {
namespace {

using Bytes = std::vector<std::uint8_t>;

ActionCommand keys() {
  ActionCommand c;
  c.device_key = 0x11223344;
  c.group_key = 0x00000024;
  c.group_mask = 0x80000001;
  return c;
}

TEST(GvcpAction, EncodesAnUnscheduledCommand) {
  const Bytes expected = {0x42, 0x01, 0x01, 0x00, 0x00, 0x0C, 0x12, 0x34,  // header
                          0x11, 0x22, 0x33, 0x44, 0x00, 0x00, 0x00, 0x24,  // device, group key
                          0x80, 0x00, 0x00, 0x01};                         // group mask
  EXPECT_EQ(encode_action_command({keys(), 0x1234, true}), expected);
}

TEST(GvcpAction, EncodesAScheduledCommandWithItsTime) {
  ActionCommand c = keys();
  c.action_time_ns = 0x0102030405060708ULL;
  const Bytes expected = {
      0x42, 0x81, 0x01, 0x00, 0x00, 0x14, 0x00, 0x07,   // header: ack + scheduled, 20 bytes
      0x11, 0x22, 0x33, 0x44, 0x00, 0x00, 0x00, 0x24,   // device, group key
      0x80, 0x00, 0x00, 0x01,                           // group mask
      0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08};  // action time, high word first
  EXPECT_EQ(encode_action_command({c, 7, true}), expected);
  // Without acknowledgement only the scheduled flag stays.
  EXPECT_EQ(encode_action_command({c, 7, false})[1], 0x80);
}

TEST(GvcpAction, DecodesWhatItEncodes) {
  ActionCommand c = keys();
  c.action_time_ns = 1'700'000'000'123'456'789ULL;
  const auto packet = decode_action_command(encode_action_command({c, 0xFFFF, true}));
  ASSERT_TRUE(packet) << packet.error().message;
  EXPECT_EQ(packet->request_id, 0xFFFF);
  EXPECT_TRUE(packet->ack_required);
  EXPECT_EQ(packet->command.device_key, c.device_key);
  EXPECT_EQ(packet->command.group_key, c.group_key);
  EXPECT_EQ(packet->command.group_mask, c.group_mask);
  EXPECT_EQ(packet->command.action_time_ns, c.action_time_ns);

  const auto unscheduled = decode_action_command(encode_action_command({keys(), 3, false}));
  ASSERT_TRUE(unscheduled) << unscheduled.error().message;
  EXPECT_FALSE(unscheduled->ack_required);
  EXPECT_FALSE(unscheduled->command.action_time_ns.has_value());
}

void expect_refused(const Bytes& datagram, const std::string& why) {
  const auto packet = decode_action_command(datagram);
  ASSERT_FALSE(packet) << "accepted; expected: " << why;
  EXPECT_EQ(packet.error().code, ErrorCode::kParseError);
  EXPECT_NE(packet.error().message.find(why), std::string::npos) << packet.error().message;
}

TEST(GvcpAction, RefusesMalformedCommands) {
  const Bytes good = encode_action_command({keys(), 5, true});
  Bytes bad_key = good;
  bad_key[0] = 0x43;
  expect_refused(bad_key, "key 0x43");
  Bytes read_register = good;
  read_register[3] = 0x80;  // command 0x0180
  expect_refused(read_register, "command 0x180, expected 0x100");
  expect_refused(Bytes(good.begin(), good.begin() + 6), "shorter than the 8-byte header");
  Bytes long_length = good;
  long_length[5] = 0x14;  // says 20, carries 12
  expect_refused(long_length, "length field 20 but 12 bytes");
  Bytes flagged = good;
  flagged[1] |= kFlagScheduledAction;  // scheduled without a time
  expect_refused(flagged, "12 payload bytes, expected 20 (scheduled)");
  Bytes id_zero = good;
  id_zero[7] = 0;
  expect_refused(id_zero, "request id 0");
}

TEST(GvcpAction, EncodesAndDecodesAcks) {
  const Bytes expected = {0x80, 0x16, 0x01, 0x01, 0x00, 0x00, 0xBE, 0xEF};
  EXPECT_EQ(encode_action_ack({kStatusActionLate, 0xBEEF}), expected);
  const auto ack = decode_action_ack(expected);
  ASSERT_TRUE(ack) << ack.error().message;
  EXPECT_EQ(ack->status, kStatusActionLate);
  EXPECT_EQ(ack->ack_id, 0xBEEF);
  EXPECT_EQ(status_name(ack->status), "ACTION_LATE");
  EXPECT_EQ(status_name(0x8001), "status 0x8001");

  Bytes write_ack = expected;
  write_ack[3] = 0x83;  // WRITEREG_ACK
  EXPECT_FALSE(decode_action_ack(write_ack));
  Bytes with_payload = expected;
  with_payload[5] = 4;  // claims 4 bytes that are not there
  EXPECT_FALSE(decode_action_ack(with_payload));
  EXPECT_FALSE(decode_action_ack(Bytes(expected.begin(), expected.begin() + 7)));
}

TEST(GvcpAction, ADeviceActsOnItsKeysAndACommonMaskBit) {
  const ActionCommand c = keys();  // mask 0x80000001
  EXPECT_TRUE(action_matches(c, 0x11223344, 0x24, 0x00000001));
  EXPECT_TRUE(action_matches(c, 0x11223344, 0x24, 0xFFFFFFFF));
  EXPECT_FALSE(action_matches(c, 0x11223345, 0x24, 0x00000001));  // device key
  EXPECT_FALSE(action_matches(c, 0x11223344, 0x25, 0x00000001));  // group key
  EXPECT_FALSE(action_matches(c, 0x11223344, 0x24, 0x00000002));  // no mask bit in common
}

TEST(GvcpAction, RequestIdsSkipZero) {
  EXPECT_EQ(next_request_id(0), 1);
  EXPECT_EQ(next_request_id(41), 42);
  EXPECT_EQ(next_request_id(0xFFFF), 1);
}

TEST(GvcpAction, KeysReadDecimalOrHexAndWriteBackAsHex) {
  EXPECT_EQ(*parse_key("36"), 36u);
  EXPECT_EQ(*parse_key("0x24"), 36u);
  EXPECT_EQ(*parse_key("0XFFFFFFFF"), 0xFFFFFFFFu);
  EXPECT_EQ(format_key(36), "0x00000024");
  EXPECT_EQ(*parse_key(format_key(0x80000001)), 0x80000001u);
  for (const char* bad : {"", "0x", "0x100000000", "4294967296", "-1", "12ab", "0x12 "}) {
    EXPECT_FALSE(parse_key(bad)) << bad;
  }
}

}  // namespace
}  // namespace sitepose::drivers::aravis::gvcp
