// The SocketCAN sink through its fd seam: a socketpair end stands for the
// raw CAN socket (PLATFORM.md: no AF_CAN on CI), a wrapper injects the errno
// values the kernel returns, and error frames come in on the socket as the
// kernel would deliver them.

#include "sitepose/drivers/socketcan/socketcan_sink.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>

#include "can_test_support.hpp"
#include "sitepose/output/can_pose_encoder.hpp"
#include "sitepose/output/j1939_network.hpp"
#include "sitepose/output/nmea2000.hpp"

namespace sitepose::drivers::socketcan {
namespace {

using namespace std::chrono_literals;
using output::CanFrame;
using testing::Faults;
using testing::SocketPair;
using testing::wait_until;

constexpr std::uint8_t kAddress = 0x1C;

SocketCanSinkOptions sink_options(std::uint32_t identity = 42) {
  SocketCanSinkOptions o;
  o.interface = "test0";
  o.node.name.identity_number = identity;
  o.node.name.manufacturer_code = 0x7FE;
  o.node.preferred_address = kAddress;
  o.node.claim_settle_ns = 20'000'000;  // 250 ms on a real bus; shorter keeps tests quick
  o.node.heartbeat_interval_ns = 0;
  o.node.transmitted_pgns = output::transmitted_pgns(output::CanOutputOptions{});
  o.backoff_min_ns = 100'000;
  o.backoff_max_ns = 20'000'000;
  o.close_drain_ns = 500'000'000;
  return o;
}

output::CanPoseInputs pose_inputs(int i) {
  output::CanPoseInputs in;
  in.utc_t_ns = 1'700'000'000'000'000'000LL + i * 33'333'333LL;
  in.latitude_deg = 10.0 + i * 1e-5;
  in.longitude_deg = 11.5 + i * 2e-6;
  in.altitude_m = 500.0 + 0.01 * i;
  in.heading_rad = 0.001 * i;
  in.course_over_ground_rad = 0.5;
  in.speed_over_ground_mps = 1.25;
  in.pitch_rad = 0.01;
  in.quality.state = TrackingState::kOk;
  in.quality.features_used = 300;
  in.quality.position_std_m = 0.01;
  return in;
}

// Sends one pose's frames and flushes; returns the flush status.
Status publish(SocketCanSink& sink, const std::vector<CanFrame>& frames) {
  for (const CanFrame& f : frames) SITEPOSE_TRY_STATUS(sink.send(0, f));
  return sink.flush();
}

bool is_pose_pgn(std::uint32_t pgn) {
  const auto pgns = output::transmitted_pgns(output::CanOutputOptions{});
  return std::find(pgns.begin(), pgns.end(), pgn) != pgns.end();
}

std::unique_ptr<SocketCanSink> open_sink(const SocketCanSinkOptions& o, CanSocketOps ops) {
  auto sink = SocketCanSink::open(o, std::move(ops));
  EXPECT_TRUE(sink.has_value()) << sink.error().message;
  return sink ? std::move(*sink) : nullptr;
}

bool is_up(const SocketCanSink& sink) { return sink.stats().state == CanLinkState::kUp; }

void expect_every_pose_accounted(const SocketCanStats& s) {
  EXPECT_EQ(s.poses_submitted, s.poses_sent + s.poses_refused + s.poses_dropped + s.poses_queued)
      << format_stats("test0", s);
}

bool is_pose_frame(const CanFrame& f) { return is_pose_pgn(output::split_j1939_id(f.id).pgn); }

// Publishes a pose; when the sink refuses it (its queue is full while the
// bus drains), flushes again until it is admitted, as the pipeline retries.
::testing::AssertionResult publish_until_admitted(SocketCanSink& sink, const std::vector<CanFrame>& frames) {
  if (publish(sink, frames) || wait_until([&] { return sink.flush().has_value(); })) {
    return ::testing::AssertionSuccess();
  }
  return ::testing::AssertionFailure() << "not admitted: " << format_stats("test0", sink.stats());
}

TEST(SocketCanSink, WritesTheEncodedPosesFromTheClaimedAddress) {
  SocketPair pair;
  testing::FrameCollector bus(pair.bus());
  auto sink = open_sink(sink_options(), fd_socket_ops(pair.sink()));
  ASSERT_TRUE(sink);
  ASSERT_TRUE(wait_until([&] { return is_up(*sink); }));
  // The claim came first, from the preferred address, with the NAME.
  const auto first = bus.frames();
  ASSERT_FALSE(first.empty());
  const auto claim = output::parse_address_claimed(first[0]);
  ASSERT_TRUE(claim);
  EXPECT_EQ(claim->source_address, kAddress);
  EXPECT_EQ(output::unpack_j1939_name(claim->name).identity_number, 42u);

  output::CanOutputOptions encoder_options;
  encoder_options.source_address = 0x55;  // the sink sends from its claimed address
  output::CanPoseEncoder encoder(encoder_options);
  std::vector<CanFrame> expected;
  for (int i = 0; i < 40; ++i) {
    const auto frames = encoder.encode(pose_inputs(i));
    ASSERT_TRUE(publish_until_admitted(*sink, frames));
    for (CanFrame f : frames) {
      f.id = (f.id & ~0xFFu) | kAddress;
      expected.push_back(f);
    }
  }
  ASSERT_TRUE(wait_until([&] { return bus.count(is_pose_frame) == expected.size(); }));
  std::vector<CanFrame> got = bus.frames();
  std::erase_if(got, [](const CanFrame& f) { return !is_pose_frame(f); });
  ASSERT_EQ(got.size(), expected.size());
  for (std::size_t k = 0; k < got.size(); ++k) EXPECT_EQ(got[k], expected[k]) << "frame " << k;
  sink->close();
  const SocketCanStats s = sink->stats();
  EXPECT_EQ(s.poses_sent, 40u);
  EXPECT_EQ(s.poses_submitted, 40u);
  EXPECT_EQ(s.state, CanLinkState::kClosed);
  EXPECT_EQ(s.source_address, output::kJ1939NullAddress);
  expect_every_pose_accounted(s);
}

TEST(SocketCanSink, RefusesPosesDuringTheClaimAndCountsTheAbandonedOnes) {
  SocketPair pair;
  SocketCanSinkOptions o = sink_options();
  o.node.claim_settle_ns = 2'000'000'000;  // long enough to publish during it
  auto sink = open_sink(o, fd_socket_ops(pair.sink()));
  ASSERT_TRUE(sink);
  output::CanPoseEncoder encoder(output::CanOutputOptions{});
  const Status st = publish(*sink, encoder.encode(pose_inputs(0)));
  ASSERT_FALSE(st.has_value());
  EXPECT_NE(st.error().message.find("address claim in progress"), std::string::npos);
  EXPECT_NE(st.error().message.find("test0"), std::string::npos);
  EXPECT_FALSE(sink->flush().has_value());  // a retry is refused too, and is the same pose
  EXPECT_FALSE(publish(*sink, encoder.encode(pose_inputs(1))).has_value());  // abandons pose 0
  SocketCanStats s = sink->stats();
  EXPECT_EQ(s.poses_submitted, 2u);
  EXPECT_EQ(s.poses_refused, 1u);
  EXPECT_EQ(s.flush_refusals, 3u);
  sink->close();  // abandons pose 1
  s = sink->stats();
  EXPECT_EQ(s.poses_refused, 2u);
  EXPECT_EQ(s.poses_sent, 0u);
  expect_every_pose_accounted(s);
}

TEST(SocketCanSink, FullTransmitQueueIsRefusedCountedAndRecovers) {
  SocketPair pair;
  SocketCanSinkOptions o = sink_options();
  o.queue_frames = 26;  // two poses
  auto sink = open_sink(o, fd_socket_ops(pair.sink()));
  ASSERT_TRUE(sink);
  ASSERT_TRUE(wait_until([&] { return is_up(*sink); }));
  // Nobody reads the "bus": the socket fills (EAGAIN, as a full CAN transmit
  // queue), then the sink's queue, then poses are refused.
  output::CanPoseEncoder encoder(output::CanOutputOptions{});
  std::set<int> admitted;
  Status refused = ok_status();
  for (int i = 0; i < 200 && refused; ++i) {
    refused = publish(*sink, encoder.encode(pose_inputs(i)));
    if (!refused && wait_until([&] { return sink->flush().has_value(); }, 200ms)) {
      refused = ok_status();
    }
    if (refused) admitted.insert(i);
  }
  ASSERT_FALSE(refused.has_value()) << "the queue never filled";
  EXPECT_NE(refused.error().message.find("transmit queue full"), std::string::npos);
  EXPECT_GT(sink->stats().tx_full, 0u);
  EXPECT_EQ(sink->stats().poses_queued, 2u);
  // The bus drains: every admitted pose arrives, and new poses flow again.
  testing::FrameCollector bus(pair.bus());
  ASSERT_TRUE(wait_until([&] { return sink->stats().poses_queued == 0; }));
  const int next = *admitted.rbegin() + 1000;  // abandons the refused pose
  ASSERT_TRUE(publish(*sink, encoder.encode(pose_inputs(next))).has_value());
  sink->close();
  std::set<int> arrived;
  for (const CanFrame& f : bus.frames()) {
    if (output::split_j1939_id(f.id).pgn != output::kPgnPositionRapidUpdate) continue;
    std::int32_t lat_raw;
    std::memcpy(&lat_raw, f.data.data(), 4);
    arrived.insert(static_cast<int>(std::lround((lat_raw * 1e-7 - 10.0) / 1e-5)));
  }
  const SocketCanStats s = sink->stats();
  for (int i : admitted) EXPECT_TRUE(arrived.contains(i)) << "pose " << i;
  EXPECT_TRUE(arrived.contains(next));
  EXPECT_EQ(arrived.size(), admitted.size() + 1);
  EXPECT_EQ(s.poses_dropped, 0u);
  EXPECT_EQ(s.poses_refused, 1u);
  expect_every_pose_accounted(s);
}

TEST(SocketCanSink, EnobufsIsRetriedAfterABackoffWithoutLoss) {
  SocketPair pair;
  testing::FrameCollector bus(pair.bus());
  Faults faults;
  faults.set_random(ENOBUFS, 0.3, 7);
  auto sink = open_sink(sink_options(), testing::faulty_ops(pair.sink(), faults));
  ASSERT_TRUE(sink);
  ASSERT_TRUE(wait_until([&] { return is_up(*sink); }));
  output::CanPoseEncoder encoder(output::CanOutputOptions{});
  for (int i = 0; i < 50; ++i) {
    ASSERT_TRUE(publish_until_admitted(*sink, encoder.encode(pose_inputs(i))));
  }
  ASSERT_TRUE(wait_until([&] { return sink->stats().poses_sent == 50u; }));
  const SocketCanStats s = sink->stats();
  EXPECT_EQ(s.poses_submitted, 50u);
  EXPECT_EQ(s.poses_refused, 0u);
  EXPECT_GT(s.tx_full, 0u);
  EXPECT_EQ(s.tx_full, faults.injected());
  EXPECT_EQ(s.poses_dropped, 0u);
  EXPECT_EQ(s.state, CanLinkState::kUp);
  ASSERT_TRUE(wait_until([&] { return bus.count(is_pose_frame) == 50u * 13u; }));
}

// A sink on a socketpair whose sends go through `faults`, claimed and up.
struct FaultySink {
  FaultySink() : sink(open_sink(sink_options(), testing::faulty_ops(pair.sink(), faults))) {}
  SocketPair pair;
  Faults faults;
  std::unique_ptr<SocketCanSink> sink;
  output::CanPoseEncoder encoder{output::CanOutputOptions{}};
};

// After a recovery the node claims its address again before any pose.
bool claims_again(int bus_fd) {
  return testing::read_until(bus_fd,
                             [](const CanFrame& f) { return output::parse_address_claimed(f).has_value(); })
      .has_value();
}

TEST(SocketCanSink, BusOffDropsTheQueueRefusesPosesAndRecoversWhenTheControllerRestarts) {
  FaultySink f;
  auto& [pair, faults, sink, encoder] = f;
  ASSERT_TRUE(sink);
  ASSERT_TRUE(wait_until([&] { return is_up(*sink); }));
  // The controller goes bus-off: its queue stops (the kernel returns
  // ENOBUFS) and an error frame says why.
  faults.set_persistent(ENOBUFS);
  ASSERT_TRUE(publish(*sink, encoder.encode(pose_inputs(0))).has_value());  // queued, stuck
  ErrorFrameInfo bus_off;
  bus_off.bus_off = true;
  ASSERT_TRUE(testing::write_frame(pair.bus(), make_error_frame(bus_off)));
  ASSERT_TRUE(wait_until([&] { return sink->stats().state == CanLinkState::kBusOff; }));
  SocketCanStats s = sink->stats();
  EXPECT_EQ(s.bus_off, 1u);
  EXPECT_EQ(s.poses_dropped, 1u);
  EXPECT_NE(s.last_error.find("bus-off"), std::string::npos);
  const Status refused = publish(*sink, encoder.encode(pose_inputs(1)));
  ASSERT_FALSE(refused.has_value());
  EXPECT_NE(refused.error().message.find("bus-off"), std::string::npos);
  // Restart (restart-ms or `ip link set test0 type can restart`).
  faults.set_persistent(0);
  while (testing::read_frame(pair.bus(), 1ms)) {
  }
  ErrorFrameInfo restarted;
  restarted.restarted = true;
  ASSERT_TRUE(testing::write_frame(pair.bus(), make_error_frame(restarted)));
  ASSERT_TRUE(claims_again(pair.bus()));
  ASSERT_TRUE(wait_until([&] { return is_up(*sink); }));
  ASSERT_TRUE(publish(*sink, encoder.encode(pose_inputs(2))).has_value());
  ASSERT_TRUE(wait_until([&] { return sink->stats().poses_sent == 1u; }));
  sink->close();
  s = sink->stats();
  EXPECT_EQ(s.recoveries, 1u);
  EXPECT_EQ(s.poses_refused, 1u);
  expect_every_pose_accounted(s);
}

TEST(SocketCanSink, InterfaceDownIsProbedWithAClaimUntilItComesBack) {
  FaultySink f;
  auto& [pair, faults, sink, encoder] = f;
  ASSERT_TRUE(sink);
  ASSERT_TRUE(wait_until([&] { return is_up(*sink); }));
  faults.set_persistent(ENETDOWN);
  ASSERT_TRUE(publish(*sink, encoder.encode(pose_inputs(0))).has_value());
  ASSERT_TRUE(wait_until([&] { return sink->stats().state == CanLinkState::kDown; }));
  EXPECT_FALSE(publish(*sink, encoder.encode(pose_inputs(1))).has_value());
  // Several probes fail meanwhile (back-off up to 20 ms).
  const std::uint64_t failed = faults.persistent_failures();
  ASSERT_TRUE(wait_until([&] { return faults.persistent_failures() >= failed + 3; }));
  EXPECT_EQ(sink->stats().state, CanLinkState::kDown);
  EXPECT_EQ(sink->stats().link_down, 1u);
  while (testing::read_frame(pair.bus(), 1ms)) {
  }
  faults.set_persistent(0);
  ASSERT_TRUE(claims_again(pair.bus()));
  ASSERT_TRUE(wait_until([&] { return is_up(*sink); }));
  ASSERT_TRUE(publish(*sink, encoder.encode(pose_inputs(2))).has_value());
  sink->close();
  const SocketCanStats s = sink->stats();
  EXPECT_EQ(s.poses_sent, 1u);
  EXPECT_EQ(s.poses_dropped, 1u);
  EXPECT_EQ(s.poses_refused, 1u);
  EXPECT_EQ(s.recoveries, 1u);
  expect_every_pose_accounted(s);
}

TEST(SocketCanSink, VanishedInterfaceIsOpenedAgain) {
  SocketPair first, second;
  std::mutex m;
  std::deque<int> fds = {first.sink(), second.sink()};
  CanSocketOps ops = fd_socket_ops(-1);
  ops.open = [&]() -> Expected<int> {
    std::lock_guard lock(m);
    if (fds.empty()) return make_error(ErrorCode::kNotFound, "test0: no such interface");
    const int fd = fds.front();
    fds.pop_front();
    return fd;
  };
  auto sink = open_sink(sink_options(), ops);
  ASSERT_TRUE(sink);
  ASSERT_TRUE(wait_until([&] { return is_up(*sink); }));
  ::close(first.fds[1]);  // the adapter is unplugged: end of stream on the socket
  first.fds[1] = -1;
  ASSERT_TRUE(wait_until([&] { return sink->stats().link_gone == 1u; }));
  ASSERT_TRUE(testing::read_until(
      second.bus(), [](const CanFrame& f) { return output::parse_address_claimed(f).has_value(); }));
  ASSERT_TRUE(wait_until([&] { return is_up(*sink); }));
  output::CanPoseEncoder encoder(output::CanOutputOptions{});
  ASSERT_TRUE(publish(*sink, encoder.encode(pose_inputs(0))).has_value());
  ASSERT_TRUE(testing::read_until(second.bus(), [](const CanFrame& f) {
    return output::split_j1939_id(f.id).pgn == output::kPgnSiteposePoseQuality;
  }));
  sink->close();
  EXPECT_EQ(sink->stats().recoveries, 1u);
}

// 10 000 poses while sends fail at random (ENOBUFS), the interface goes
// down and the controller goes bus-off: every pose that did not arrive whole
// is in a counter, every pose that arrived is intact, none arrives twice.
TEST(SocketCanSink, TenThousandPosesWithInjectedFailuresLoseNoneTheCountersDoNotReport) {
  constexpr int kPoses = 10'000;
  SocketPair pair;
  Faults faults;
  faults.set_random(ENOBUFS, 0.05, 2024);
  auto sink = open_sink(sink_options(), testing::faulty_ops(pair.sink(), faults));
  ASSERT_TRUE(sink);
  ASSERT_TRUE(wait_until([&] { return is_up(*sink); }));

  std::vector<CanFrame> received;
  std::thread reader([&] {
    struct can_frame cf;
    for (;;) {
      struct pollfd p = {pair.bus(), POLLIN, 0};
      if (::poll(&p, 1, 1000) <= 0) continue;
      const ssize_t n = ::recv(pair.bus(), &cf, sizeof(cf), MSG_DONTWAIT);
      if (n == 0) return;  // the sink's end closed
      if (n != static_cast<ssize_t>(sizeof(cf))) continue;
      if (auto f = from_can_frame(cf)) received.push_back(*f);
    }
  });

  output::CanPoseEncoder encoder(output::CanOutputOptions{});
  std::vector<std::vector<CanFrame>> expected(kPoses);
  std::set<int> admitted;
  int never_admitted = 0;
  for (int i = 0; i < kPoses; ++i) {
    if (i == 2000) faults.set_persistent(ENETDOWN);
    if (i == 2300) faults.set_persistent(0);
    if (i == 5000) {
      faults.set_persistent(ENOBUFS);
      ErrorFrameInfo e;
      e.bus_off = true;
      ASSERT_TRUE(testing::write_frame(pair.bus(), make_error_frame(e)));
    }
    if (i == 5300) {
      faults.set_persistent(0);
      ErrorFrameInfo e;
      e.restarted = true;
      ASSERT_TRUE(testing::write_frame(pair.bus(), make_error_frame(e)));
    }
    expected[i] = encoder.encode(pose_inputs(i));
    for (CanFrame& f : expected[i]) f.id = (f.id & ~0xFFu) | kAddress;
    // As the pipeline does: up to 3 attempts, a short wait between.
    bool ok = false;
    for (int attempt = 0; attempt < 3 && !ok; ++attempt) {
      if (attempt > 0) std::this_thread::sleep_for(200us);
      ok = attempt == 0 ? publish(*sink, expected[i]).has_value() : sink->flush().has_value();
    }
    if (ok) {
      admitted.insert(i);
    } else {
      ++never_admitted;
    }
  }
  sink->close();
  const SocketCanStats s = sink->stats();
  ::close(pair.fds[0]);
  pair.fds[0] = -1;
  reader.join();

  // Split the pose frames into poses: each starts with its 129025 frame,
  // whose latitude says which pose it is.
  std::map<int, std::vector<CanFrame>> arrived;
  int duplicates = 0, current = -1;
  for (const CanFrame& f : received) {
    const std::uint32_t pgn = output::split_j1939_id(f.id).pgn;
    if (!is_pose_pgn(pgn)) continue;
    if (pgn == output::kPgnPositionRapidUpdate) {
      std::int32_t lat_raw;
      std::memcpy(&lat_raw, f.data.data(), 4);
      current = static_cast<int>(std::lround((lat_raw * 1e-7 - 10.0) / 1e-5));
      ASSERT_GE(current, 0);
      ASSERT_LT(current, kPoses);
      duplicates += arrived.contains(current);
    }
    ASSERT_GE(current, 0) << "a pose frame before any pose began";
    arrived[current].push_back(f);
  }
  EXPECT_EQ(duplicates, 0);
  std::uint64_t complete = 0, partial = 0;
  for (const auto& [i, frames] : arrived) {
    ASSERT_TRUE(admitted.contains(i)) << "pose " << i << " was never admitted";
    ASSERT_LE(frames.size(), expected[i].size()) << "pose " << i;
    for (std::size_t k = 0; k < frames.size(); ++k) {
      ASSERT_EQ(frames[k], expected[i][k]) << "pose " << i << " frame " << k;
    }
    (frames.size() == expected[i].size() ? complete : partial) += 1;
  }
  EXPECT_EQ(s.poses_submitted, static_cast<std::uint64_t>(kPoses));
  EXPECT_EQ(s.poses_sent, complete);
  EXPECT_EQ(s.poses_partially_sent, partial);
  EXPECT_EQ(s.poses_refused, static_cast<std::uint64_t>(never_admitted));
  EXPECT_EQ(s.poses_sent + s.poses_dropped, admitted.size());
  EXPECT_EQ(s.poses_queued, 0u);
  expect_every_pose_accounted(s);
  // The faults did happen, and most poses still went out.
  EXPECT_GT(s.tx_full, 100u);
  EXPECT_EQ(s.link_down, 1u);
  EXPECT_EQ(s.bus_off, 1u);
  EXPECT_EQ(s.recoveries, 2u);
  EXPECT_GT(s.poses_refused, 0u);
  EXPECT_GT(s.poses_sent, static_cast<std::uint64_t>(kPoses / 2));
  std::printf("10000 poses: %s\n", format_stats("test0", s).c_str());
}

TEST(SocketCanSinkOptions, CheckNamesTheField) {
  SocketCanSinkOptions o = sink_options();
  o.queue_frames = 5;
  EXPECT_NE(check_socketcan_sink_options(o).error().message.find("queue"), std::string::npos);
  o = sink_options();
  o.node.preferred_address = 255;
  EXPECT_NE(check_socketcan_sink_options(o).error().message.find("preferred address"), std::string::npos);
  SocketPair pair;
  EXPECT_FALSE(SocketCanSink::open(o, fd_socket_ops(pair.sink())).has_value());
  EXPECT_TRUE(check_socketcan_sink_options(sink_options()).has_value());
}

}  // namespace
}  // namespace sitepose::drivers::socketcan
