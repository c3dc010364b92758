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
#include "sitepose/testing/file_size_limit.hpp"
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

// issue 20: a restart reopened the log with "w" and wiped the frames before it.
TEST(CandumpSink, ReopenAppendsToTheLog) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("sitepose_can_sink_append_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "can.log").string();
  for (int run = 0; run < 2; ++run) {
    auto sink = CandumpSink::open_file(path, "can0");
    ASSERT_TRUE(sink.has_value()) << sink.error().message;
    EXPECT_TRUE((*sink)->send(1'000'000 * (run + 1), frame(0x09F8011C, 8, static_cast<std::uint8_t>(run))));
  }
  const auto records = read_candump_file(path);
  ASSERT_TRUE(records.has_value()) << records.error().message;
  ASSERT_EQ(records->size(), 2u);
  EXPECT_EQ((*records)[0].frame, frame(0x09F8011C, 8, 0));
  EXPECT_EQ((*records)[1].frame, frame(0x09F8011C, 8, 1));
  std::filesystem::remove_all(dir);
}

// issue 20: on a full disk stdio kept the frames in its buffer (each send
// counted ok), then dropped them at the failed flush; the retried flush
// succeeded on the empty buffer. Now a frame counts as sent only when its
// whole line was written, and a failed one can be sent again.
TEST(CandumpSink, FullDiskCountsFailuresAndResendsWhole) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("sitepose_can_sink_full_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "can.log").string();
  auto sink = CandumpSink::open_file(path, "can0");
  ASSERT_TRUE(sink.has_value()) << sink.error().message;
  const std::size_t line_bytes =
      format_candump_line({1000, "can0", frame(0x09F8011C, 8, 0)})->size() + 1;  // same for all 8
  int failed = 0;
  {
    sitepose::testing::FileSizeLimit full(5 * line_bytes + 7);
    ASSERT_TRUE(full.ok());
    for (int i = 0; i < 8; ++i) {
      const Status st = (*sink)->send(1000 * (i + 1), frame(0x09F8011C, 8, static_cast<std::uint8_t>(i)));
      if (!st) ++failed;
      EXPECT_TRUE((*sink)->flush());
    }
  }
  EXPECT_EQ(failed, 3);
  EXPECT_EQ((*sink)->counters().frames_sent, 5u);
  EXPECT_EQ((*sink)->counters().send_errors, 3u);
  EXPECT_EQ(std::filesystem::file_size(path), 5 * line_bytes);
  // Space back: the lost frames are sent again, each once and whole.
  for (int i = 5; i < 8; ++i) {
    EXPECT_TRUE((*sink)->send(1000 * (i + 1), frame(0x09F8011C, 8, static_cast<std::uint8_t>(i))));
  }
  const auto records = read_candump_file(path);
  ASSERT_TRUE(records.has_value()) << records.error().message;
  ASSERT_EQ(records->size(), 8u);
  for (std::size_t i = 0; i < 8; ++i) EXPECT_EQ((*records)[i].frame.data[0], i);
  std::filesystem::remove_all(dir);
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
