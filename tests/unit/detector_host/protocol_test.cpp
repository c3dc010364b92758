#include "sitepose/detector_host/protocol.hpp"

#include <sys/socket.h>
#include <unistd.h>

#include <cstring>

#include <gtest/gtest.h>

namespace sitepose::detector_host {
namespace {

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

sp_detection detection(const char* name, std::int32_t x, std::uint16_t instance) {
  sp_detection d{};
  std::strncpy(d.class_name, name, SP_CLASS_NAME_LEN - 1);
  d.score = 0.75f;
  d.x = x;
  d.y = -3;
  d.w = 40;
  d.h = 2147483647;
  d.instance = instance;
  return d;
}

bool same(const sp_detection& a, const sp_detection& b) {
  return std::memcmp(a.class_name, b.class_name, SP_CLASS_NAME_LEN) == 0 && a.score == b.score &&
         a.x == b.x && a.y == b.y && a.w == b.w && a.h == b.h && a.instance == b.instance;
}

DetectReply sample_reply() {
  DetectReply r;
  r.rc = 0;
  r.count = 300;  // more than it carries: the plugin's own *count
  r.detections = {detection("truck", 10, 1), detection("roller", -5, 65535)};
  r.detections[1].class_name[SP_CLASS_NAME_LEN - 1] = 'x';  // unterminated: carried as is
  r.error = "";
  return r;
}

Envelope round_trip(const Envelope& e) {
  auto back = decode(encode(e));
  EXPECT_TRUE(back) << back.error().message;
  EXPECT_EQ(back->call_id, e.call_id);
  EXPECT_EQ(type_of(back->message), type_of(e.message));
  return *back;
}

TEST(DetectorHostProtocol, EveryMessageRoundTrips) {
  const auto init = std::get<Init>(round_trip({1, Init{"/opt/p.so", "{a: 1, b: [x, y]}\n"}}).message);
  EXPECT_EQ(init.plugin_path, "/opt/p.so");
  EXPECT_EQ(init.config_yaml, "{a: 1, b: [x, y]}\n");
  const auto ready = std::get<Ready>(round_trip({2, Ready{3, 5u, "create failed: no model"}}).message);
  EXPECT_EQ(ready.status, 3);
  EXPECT_EQ(ready.capabilities, 5u);
  EXPECT_EQ(ready.error, "create failed: no model");
  const FrameRef frame{-7, 1'700'000'000'123'456'789, 960, 540};
  const auto detect = std::get<DetectRequest>(round_trip({3, DetectRequest{frame, 256}}).message);
  EXPECT_EQ(detect.frame.seq, -7);
  EXPECT_EQ(detect.frame.t_ns, 1'700'000'000'123'456'789);
  EXPECT_EQ(detect.frame.width, 960);
  EXPECT_EQ(detect.frame.height, 540);
  EXPECT_EQ(detect.capacity, 256);
  const DetectReply sent = sample_reply();
  const auto reply = std::get<DetectReply>(round_trip({4, sent}).message);
  EXPECT_EQ(reply.count, 300);
  ASSERT_EQ(reply.detections.size(), 2u);
  EXPECT_TRUE(same(reply.detections[0], sent.detections[0]));
  EXPECT_TRUE(same(reply.detections[1], sent.detections[1]));
  const auto segment =
      std::get<SegmentRequest>(round_trip({5, SegmentRequest{frame, {detection("a", 1, 9)}}}).message);
  ASSERT_EQ(segment.detections.size(), 1u);
  EXPECT_EQ(segment.detections[0].instance, 9);
  const auto segmented = std::get<SegmentReply>(round_trip({6, SegmentReply{1, "no masks"}}).message);
  EXPECT_EQ(segmented.rc, 1);
  EXPECT_EQ(segmented.error, "no masks");
}

TEST(DetectorHostProtocol, EveryTruncationIsRefusedAndNothingElse) {
  const std::vector<std::uint8_t> whole = encode({9, sample_reply()});
  for (std::size_t n = 0; n < whole.size(); ++n) {
    auto cut = decode(std::span(whole).first(n));
    ASSERT_FALSE(cut) << n << " of " << whole.size() << " bytes decoded";
    EXPECT_EQ(cut.error().code, ErrorCode::kParseError);
  }
  // The header's length agrees but the payload ends inside a field.
  std::vector<std::uint8_t> short_payload(whole.begin(), whole.end() - 3);
  const auto payload = static_cast<std::uint32_t>(short_payload.size() - kHeaderBytes);
  std::memcpy(short_payload.data() + 8, &payload, sizeof(payload));
  auto cut = decode(short_payload);
  ASSERT_FALSE(cut);
  EXPECT_TRUE(contains(cut.error().message, "payload ends early")) << cut.error().message;
  EXPECT_TRUE(decode(whole));
}

TEST(DetectorHostProtocol, OtherVersionIsRefusedNamingBoth) {
  std::vector<std::uint8_t> bytes = encode({1, DetectRequest{{0, 0, 64, 48}, 4}});
  const std::uint16_t other = kProtocolVersion + 1;
  std::memcpy(bytes.data() + 4, &other, sizeof(other));
  auto r = decode(bytes);
  ASSERT_FALSE(r);
  EXPECT_TRUE(contains(r.error().message, "version 2")) << r.error().message;
  EXPECT_TRUE(contains(r.error().message, "speaks 1")) << r.error().message;
}

TEST(DetectorHostProtocol, BadMagicTypeSizesAndTrailingBytesAreRefused) {
  const std::vector<std::uint8_t> good = encode({1, DetectRequest{{0, 0, 64, 48}, 4}});
  auto with = [&](std::size_t at, auto value) {
    std::vector<std::uint8_t> b = good;
    std::memcpy(b.data() + at, &value, sizeof(value));
    return decode(b);
  };
  EXPECT_TRUE(contains(with(0, std::uint32_t{0x12345678}).error().message, "bad magic"));
  EXPECT_TRUE(contains(with(6, std::uint16_t{77}).error().message, "unknown message type 77"));
  // width (after seq and t_ns) 0 and beyond the limit; capacity 0
  EXPECT_TRUE(contains(with(kHeaderBytes + 16, std::int32_t{0}).error().message, "frame size 0x48"));
  EXPECT_FALSE(with(kHeaderBytes + 16, std::int32_t{kMaxImageSide + 1}));
  EXPECT_TRUE(contains(with(kHeaderBytes + 24, std::int32_t{0}).error().message, "capacity 0"));
  std::vector<std::uint8_t> longer = good;
  longer.push_back(0);
  const auto payload = static_cast<std::uint32_t>(longer.size() - kHeaderBytes);
  std::memcpy(longer.data() + 8, &payload, sizeof(payload));
  EXPECT_TRUE(contains(decode(longer).error().message, "bytes left after the payload"));
  DetectReply many;
  many.detections.resize(static_cast<std::size_t>(kMaxDetections) + 1);
  EXPECT_TRUE(contains(decode(encode({1, many})).error().message, "4097 detections"));
}

TEST(DetectorHostProtocol, SocketCarriesMessagesAndReportsTimeoutAndClose) {
  int pair[2];
  ASSERT_EQ(::socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, pair), 0);
  auto nothing = receive_message(pair[0], 20);
  ASSERT_TRUE(nothing) << nothing.error().message;
  EXPECT_EQ(nothing->outcome, ReceiveOutcome::kTimeout);
  ASSERT_TRUE(send_message(pair[1], {42, sample_reply()}));
  auto got = receive_message(pair[0], 1000);
  ASSERT_TRUE(got) << got.error().message;
  ASSERT_EQ(got->outcome, ReceiveOutcome::kMessage);
  EXPECT_EQ(got->envelope.call_id, 42u);
  EXPECT_EQ(std::get<DetectReply>(got->envelope.message).detections.size(), 2u);
  // Garbage on the socket is an error, not a crash or a hang.
  const char junk[] = "not a message";
  ASSERT_EQ(::send(pair[1], junk, sizeof(junk), 0), static_cast<ssize_t>(sizeof(junk)));
  EXPECT_FALSE(receive_message(pair[0], 1000));
  ::close(pair[1]);
  auto closed = receive_message(pair[0], 1000);
  ASSERT_TRUE(closed);
  EXPECT_EQ(closed->outcome, ReceiveOutcome::kClosed);
  // Sending to a closed peer fails without SIGPIPE.
  EXPECT_FALSE(send_message(pair[0], {1, SegmentReply{}}));
  ::close(pair[0]);
}

}  // namespace
}  // namespace sitepose::detector_host
