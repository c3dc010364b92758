#include "sitepose/output/can_sink.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <linux/can.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

#include "sitepose/output/candump.hpp"
#include "sitepose/testing/files.hpp"

namespace sitepose::output {
namespace {

CanFrame frame(std::uint32_t id, std::uint8_t dlc, std::uint8_t first) {
  CanFrame f;
  f.id = id;
  f.dlc = dlc;
  for (std::uint8_t i = 0; i < dlc; ++i) f.data[i] = static_cast<std::uint8_t>(first + i);
  return f;
}

struct SocketPair {
  SocketPair() {
    EXPECT_EQ(::socketpair(AF_UNIX, SOCK_SEQPACKET, 0, fds), 0) << std::strerror(errno);
  }
  ~SocketPair() {
    for (int fd : fds) {
      if (fd >= 0) ::close(fd);
    }
  }
  int fds[2] = {-1, -1};
};

TEST(CandumpSink, FileSinkWritesReadableLogAndCounts) {
  const sitepose::testing::TempDir dir;
  const std::string path = dir / "can_sink.log";
  {
    auto sink = CandumpSink::open_file(path, "can0");
    ASSERT_TRUE(sink.has_value()) << sink.error().message;
    EXPECT_TRUE((*sink)->send(1'700'000'000'000'000'000LL, frame(0x09F8011C, 8, 0x10)).has_value());
    EXPECT_TRUE((*sink)->send(1'700'000'000'000'100'000LL, frame(0x18FF101C, 3, 0xA0)).has_value());
    const Status bad = (*sink)->send(-5, frame(0x09F8011C, 8, 0));
    EXPECT_FALSE(bad.has_value());
    EXPECT_TRUE((*sink)->flush().has_value());
    EXPECT_EQ((*sink)->counters().frames_sent, 2u);
    EXPECT_EQ((*sink)->counters().send_errors, 1u);
    // Flushed lines are on disk before the sink is closed.
    const auto records = read_candump_file(path);
    ASSERT_TRUE(records.has_value()) << records.error().message;
    ASSERT_EQ(records->size(), 2u);
    EXPECT_EQ((*records)[0].frame, frame(0x09F8011C, 8, 0x10));
    EXPECT_EQ((*records)[1].frame, frame(0x18FF101C, 3, 0xA0));
    EXPECT_EQ((*records)[1].t_ns, 1'700'000'000'000'100'000LL);
    EXPECT_EQ((*records)[1].interface, "can0");
  }
}

TEST(CandumpSink, OpenFailureNamesPath) {
  const auto sink = CandumpSink::open_file("/nonexistent-dir/x.log", "can0");
  ASSERT_FALSE(sink.has_value());
  EXPECT_EQ(sink.error().code, ErrorCode::kIoError);
  EXPECT_NE(sink.error().message.find("/nonexistent-dir/x.log"), std::string::npos);
}

TEST(CandumpSink, StdoutSinkPrintsCandumpLines) {
  ::testing::internal::CaptureStdout();
  {
    auto sink = CandumpSink::make_stdout("can2");
    EXPECT_TRUE(sink->send(2'000'000, frame(0x09F8011C, 2, 0x01)).has_value());
    EXPECT_TRUE(sink->flush().has_value());
  }
  EXPECT_EQ(::testing::internal::GetCapturedStdout(), "(0.002000) can2 09F8011C#0102\n");
}

TEST(CanFrameFdSink, SendsOneSocketCanFramePerDatagram) {
  SocketPair sp;
  CanFrameFdSink sink(sp.fds[0]);
  const CanFrame a = frame(0x09F8011C, 8, 0x30);
  CanFrame b = frame(0x123, 2, 0x40);
  b.extended = false;
  ASSERT_TRUE(sink.send(0, a).has_value());
  ASSERT_TRUE(sink.send(0, b).has_value());
  EXPECT_TRUE(sink.flush().has_value());
  // The raw bytes are a Linux struct can_frame with CAN_EFF_FLAG for 29 bits.
  struct can_frame raw;
  ASSERT_EQ(::read(sp.fds[1], &raw, sizeof(raw)), static_cast<ssize_t>(sizeof(raw)));
  EXPECT_EQ(raw.can_id, 0x09F8011Cu | CAN_EFF_FLAG);
  EXPECT_EQ(raw.can_dlc, 8);
  EXPECT_EQ(std::memcmp(raw.data, a.data.data(), 8), 0);
  const auto second = read_can_frame_fd(sp.fds[1]);
  ASSERT_TRUE(second.has_value()) << second.error().message;
  EXPECT_EQ(*second, b);
  EXPECT_EQ(sink.counters().frames_sent, 2u);
  EXPECT_EQ(sink.counters().send_errors, 0u);
}

TEST(CanFrameFdSink, FullQueueAndClosedPeerAreCountedErrors) {
  SocketPair sp;
  ASSERT_EQ(::fcntl(sp.fds[0], F_SETFL, ::fcntl(sp.fds[0], F_GETFL) | O_NONBLOCK), 0);
  CanFrameFdSink sink(sp.fds[0]);
  Status st = ok_status();
  int sent = 0;
  while (sent < 1'000'000 && (st = sink.send(0, frame(0x09F8011C, 8, 0)))) ++sent;
  ASSERT_FALSE(st.has_value()) << "the socket buffer never filled";
  EXPECT_EQ(st.error().code, ErrorCode::kIoError);
  EXPECT_NE(st.error().message.find("errno " + std::to_string(EAGAIN)), std::string::npos)
      << st.error().message;
  EXPECT_EQ(sink.counters().send_errors, 1u);
  EXPECT_EQ(sink.counters().frames_sent, static_cast<std::uint64_t>(sent));
  // Peer gone (with unread frames: ECONNRESET, else EPIPE) is an error
  // value; no SIGPIPE kills the process.
  ::close(sp.fds[1]);
  sp.fds[1] = -1;
  const Status gone = sink.send(0, frame(0x09F8011C, 8, 0));
  ASSERT_FALSE(gone.has_value());
  const std::string& msg = gone.error().message;
  EXPECT_TRUE(msg.find("errno " + std::to_string(EPIPE)) != std::string::npos ||
              msg.find("errno " + std::to_string(ECONNRESET)) != std::string::npos)
      << msg;
  EXPECT_EQ(sink.counters().send_errors, 2u);
  // Again, now that the reset was reported: EPIPE.
  const Status again = sink.send(0, frame(0x09F8011C, 8, 0));
  ASSERT_FALSE(again.has_value());
  EXPECT_NE(again.error().message.find("errno " + std::to_string(EPIPE)), std::string::npos)
      << again.error().message;
  EXPECT_EQ(sink.counters().send_errors, 3u);
}

TEST(CanFrameFdSink, ReaderRejectsShortDatagramsAndEof) {
  SocketPair sp;
  const char junk[3] = {1, 2, 3};
  ASSERT_EQ(::write(sp.fds[0], junk, sizeof(junk)), 3);
  const auto short_read = read_can_frame_fd(sp.fds[1]);
  ASSERT_FALSE(short_read.has_value());
  EXPECT_NE(short_read.error().message.find("datagram of 3 bytes"), std::string::npos);
  ::close(sp.fds[0]);
  sp.fds[0] = -1;
  EXPECT_FALSE(read_can_frame_fd(sp.fds[1]).has_value());
}

}  // namespace
}  // namespace sitepose::output
