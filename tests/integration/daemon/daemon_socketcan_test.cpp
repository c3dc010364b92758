// The daemon's CAN output on the SocketCAN sink, in-process through the
// sink's fd seam (a socketpair: no AF_CAN on CI): every pose the pipeline
// counts as published reaches the bus once, and when the controller goes
// bus-off the pipeline's health and the sink's counters tell the same story.
// Also the `outputs.can.sink: socketcan` settings.

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>

#include "can_test_support.hpp"
#include "sitepose/daemon/daemon.hpp"
#include "sitepose/output/j1939.hpp"
#include "sitepose/testing/pipeline_fakes.hpp"

namespace sitepose::daemon {
namespace {

using namespace std::chrono_literals;
namespace can = drivers::socketcan;

GeoConfig fixed_geo() {
  GeoConfig g;
  g.mode = GeoMode::kFixed;
  g.origin = {48.137, 11.575, 520.0};
  return g;
}

// A live source (one frame every 10 ms) and the pipeline's retry policy of
// the shipped config (3 attempts, 5 ms apart).
std::unique_ptr<pipeline::Pipeline> live_pipeline(int frames, std::unique_ptr<pipeline::PoseOutput> output) {
  pipeline::PipelineOptions o;
  o.publish_max_attempts = 3;
  o.publish_retry_delay_s = 0.005;
  std::vector<std::unique_ptr<pipeline::PoseOutput>> outputs;
  outputs.push_back(std::move(output));
  auto p =
      pipeline::Pipeline::create(o,
                                 std::make_unique<sitepose::testing::ScriptedSource>(
                                     sitepose::testing::ScriptedSource::frames(frames), true, false, 10ms),
                                 std::make_unique<pipeline::PassThroughDetect>(),
                                 std::make_unique<sitepose::testing::FakeTracker>(), std::move(outputs));
  EXPECT_TRUE(p);
  return p ? std::move(*p) : nullptr;
}

bool is_pose_quality(const output::CanFrame& f) {
  return output::split_j1939_id(f.id).pgn == output::kPgnSiteposePoseQuality;
}

CanOutputConfig can_config() {
  CanOutputConfig c;
  c.sink = CanSinkKind::kSocketCan;
  c.interface = "test0";
  c.socketcan.name.identity_number = 1234;
  return c;
}

TEST(DaemonSocketCan, EveryPublishedPoseReachesTheBusOnce) {
  auto anchoring = Anchoring::create(fixed_geo());
  ASSERT_TRUE(anchoring);
  can::testing::SocketPair pair;
  can::testing::FrameCollector bus(pair.bus());
  auto sink = can::SocketCanSink::open(socketcan_sink_options(can_config()), can::fd_socket_ops(pair.sink()));
  ASSERT_TRUE(sink) << sink.error().message;
  const can::SocketCanSink* view = sink->get();
  ASSERT_TRUE(can::testing::wait_until([&] { return view->stats().state == can::CanLinkState::kUp; }));
  auto p = live_pipeline(
      60, std::make_unique<CanOutput>(output::CanOutputOptions{}, std::move(*sink), **anchoring));
  ASSERT_TRUE(p);
  p->start();
  ASSERT_TRUE(p->wait());
  const auto h = p->health();
  // A live source may drop frames on a loaded machine (counted by the
  // pipeline); every pose that reached the output went out.
  const std::uint64_t published = h.outputs[0].published;
  EXPECT_GT(published, 40u);
  EXPECT_EQ(h.outputs[0].failed, 0u);
  ASSERT_TRUE(can::testing::wait_until([&] { return view->stats().poses_sent == published; }));
  ASSERT_TRUE(can::testing::wait_until([&] { return bus.count(is_pose_quality) == published; }));
  // The E2E alive counter of the pose/quality frame: no frame lost or repeated.
  std::uint8_t alive = 0;
  for (const auto& f : bus.frames()) {
    if (!is_pose_quality(f)) continue;
    EXPECT_EQ(f.data[1] & 0x0F, alive);
    EXPECT_EQ(f.id & 0xFF, 0x1Cu);  // the claimed address
    alive = (alive + 1) & 0x0F;
  }
}

TEST(DaemonSocketCan, BusOffIsCountedAlikeByThePipelineAndTheSink) {
  auto anchoring = Anchoring::create(fixed_geo());
  ASSERT_TRUE(anchoring);
  can::testing::SocketPair pair;
  can::testing::FrameCollector bus(pair.bus());
  can::testing::Faults faults;
  auto sink = can::SocketCanSink::open(socketcan_sink_options(can_config()),
                                       can::testing::faulty_ops(pair.sink(), faults));
  ASSERT_TRUE(sink) << sink.error().message;
  can::SocketCanSink* view = sink->get();
  ASSERT_TRUE(can::testing::wait_until([&] { return view->stats().state == can::CanLinkState::kUp; }));
  auto p = live_pipeline(
      80, std::make_unique<CanOutput>(output::CanOutputOptions{}, std::move(*sink), **anchoring));
  ASSERT_TRUE(p);
  p->start();
  // After 15 poses the controller goes bus-off for 100 ms, then restarts.
  ASSERT_TRUE(can::testing::wait_until([&] { return view->stats().poses_sent >= 15u; }));
  faults.set_persistent(ENOBUFS);
  can::ErrorFrameInfo off;
  off.bus_off = true;
  ASSERT_TRUE(can::testing::write_frame(pair.bus(), can::make_error_frame(off)));
  ASSERT_TRUE(can::testing::wait_until([&] { return view->stats().state == can::CanLinkState::kBusOff; }));
  std::this_thread::sleep_for(100ms);
  faults.set_persistent(0);
  can::ErrorFrameInfo restarted;
  restarted.restarted = true;
  ASSERT_TRUE(can::testing::write_frame(pair.bus(), can::make_error_frame(restarted)));
  ASSERT_TRUE(p->wait());
  const auto h = p->health();
  view->close();  // final counters: the last refused pose, if any, is abandoned
  const can::SocketCanStats s = view->stats();
  std::printf("pipeline: published=%llu failed=%llu errors=%llu | sink: %s\n",
              static_cast<unsigned long long>(h.outputs[0].published),
              static_cast<unsigned long long>(h.outputs[0].failed),
              static_cast<unsigned long long>(h.outputs[0].errors), can::format_stats("test0", s).c_str());
  EXPECT_EQ(s.bus_off, 1u);
  EXPECT_EQ(s.recoveries, 1u);
  EXPECT_GT(h.outputs[0].failed, 0u);  // bus-off and the address claim after it
  EXPECT_GT(s.poses_sent, 15u);        // and poses flowed again
  // One story: every pose the pipeline gave up on is a pose the sink refused,
  // every pose it published went out whole or is counted as dropped.
  EXPECT_EQ(s.poses_submitted, h.outputs[0].published + h.outputs[0].failed);
  EXPECT_EQ(s.poses_refused, h.outputs[0].failed);
  EXPECT_EQ(s.poses_sent + s.poses_dropped, h.outputs[0].published);
  // The bus side reads on its own thread: the last frames written before
  // close() may still be in the socket when the counters are read.
  EXPECT_TRUE(can::testing::wait_until([&] { return bus.count(is_pose_quality) == s.poses_sent; }))
      << "bus saw " << bus.count(is_pose_quality) << " pose/quality frames, sink sent " << s.poses_sent;
  EXPECT_NE(s.last_error.find("bus-off"), std::string::npos);
}

TEST(DaemonSocketCan, SettingsAreReadCheckedAndWrittenBack) {
  const std::string base =
      "source:\n  replay: {sequence: /nonexistent}\n"
      "outputs:\n  trajectory: {enabled: false}\n  lcm: {enabled: false}\n"
      "  can:\n    sink: socketcan\n    interface: can1\n    source_address: 40\n"
      "    socketcan:\n      queue_frames: 128\n      heartbeat_interval_s: 10\n"
      "      name: {identity_number: ";
  const std::string geo =
      "geo:\n  mode: fixed\n  origin: {latitude_deg: 48.1, longitude_deg: 11.5, height_m: 500}\n"
      "  T_site_slam: {translation_m: [0, 0, 0], rotation_wxyz: [1, 0, 0, 0]}\n";
  auto c = load_daemon_config_from_string(
      base + "777, manufacturer_code: 2000, industry_group: 4, arbitrary_address_capable: false}\n" + geo,
      "can.yaml", "");
  ASSERT_TRUE(c) << c.error().message;
  EXPECT_EQ(c->can.sink, CanSinkKind::kSocketCan);
  EXPECT_EQ(c->can.socketcan.queue_frames, 128);
  EXPECT_EQ(c->can.socketcan.name.identity_number, 777u);
  EXPECT_EQ(c->can.socketcan.name.manufacturer_code, 2000u);
  EXPECT_FALSE(c->can.socketcan.name.arbitrary_address_capable);
  const auto o = socketcan_sink_options(c->can);
  EXPECT_EQ(o.interface, "can1");
  EXPECT_EQ(o.node.preferred_address, 40);
  EXPECT_EQ(o.node.heartbeat_interval_ns, 10'000'000'000LL);
  EXPECT_EQ(o.node.transmitted_pgns.size(), 7u);
  EXPECT_TRUE(can::check_socketcan_sink_options(o).has_value());
  const std::string yaml = to_yaml(*c);
  EXPECT_NE(yaml.find("sink: socketcan"), std::string::npos) << yaml;
  EXPECT_NE(yaml.find("identity_number: 777"), std::string::npos) << yaml;

  auto bad = load_daemon_config_from_string(base + "2097152}\n" + geo, "bad.yaml", "");
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("outputs.can.socketcan.name.identity_number"), std::string::npos)
      << bad.error().message;
}

TEST(DaemonSocketCan, WithoutKernelSupportTheDaemonRefusesToStartAndSaysWhy) {
  can::RawSocketOptions raw;
  raw.interface = "can0";
  auto probe = can::open_raw_can_socket(raw);
  if (probe) {
    ::close(*probe);
    GTEST_SKIP() << "this kernel has AF_CAN and can0";
  }
  if (probe.error().code != ErrorCode::kUnsupported) GTEST_SKIP() << probe.error().message;
  CanOutputConfig c = can_config();
  c.interface = "can0";
  auto sink = can::SocketCanSink::open(socketcan_sink_options(c), can::raw_can_socket_ops(raw));
  ASSERT_FALSE(sink);
  EXPECT_EQ(sink.error().exit_status(), 2);
  EXPECT_NE(sink.error().message.find("no CAN support"), std::string::npos) << sink.error().message;
}

}  // namespace
}  // namespace sitepose::daemon
