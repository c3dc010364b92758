// Faults, in-process through the daemon's seams: a source that stalls (the
// watchdog stops, LOST reaches every output, tracking resumes), LCM sends
// that fail (counted, retried, nothing lost or doubled), a CAN sink that
// fails (counted, resumed at the failed frame: no frame twice), a full disk
// under the trajectory (never a half line), a restart that appends. The
// faults siteposed meets as a process: daemon_process_faults_test.cpp.

#include <array>
#include <cstdio>
#include <fstream>
#include <lcm/lcm-cpp.hpp>

#include "daemon_test_util.hpp"
#include "sitepose/daemon/daemon.hpp"
#include "sitepose/output/candump.hpp"
#include "sitepose/output/lcm_messages.hpp"
#include "sitepose/pipeline/replay_source.hpp"
#include "sitepose/pose_t.hpp"
#include "sitepose/testing/file_size_limit.hpp"
#include "sitepose/testing/pipeline_fakes.hpp"

namespace sitepose::daemon::testing {
namespace {

using namespace std::chrono_literals;
using pipeline::SourceEvent;
using pipeline::SourceEventKind;

// Replays the sequence live at a fixed period; after `stall_after` frames it
// stays silent for `stall` (the capture stage's deadlines expire), then
// delivers the rest.
class StallingSource final : public pipeline::FrameSource {
 public:
  StallingSource(std::unique_ptr<pipeline::ReplaySource> replay, int stall_after,
                 std::chrono::milliseconds stall)
      : replay_(std::move(replay)), stall_after_(stall_after), stall_(stall) {}
  const StereoCamera& camera() const override { return replay_->camera(); }
  std::string describe() const override { return "stalling " + replay_->describe(); }
  bool live() const override { return true; }
  Expected<SourceEvent> next(std::stop_token stop, pipeline::SteadyTime deadline) override {
    std::unique_lock lock(mutex_);
    auto wait_until = [&](pipeline::SteadyTime t) { cv_.wait_until(lock, stop, t, [] { return false; }); };
    if (delivered_ == stall_after_ && !stall_begin_) {
      stall_begin_ = Clock::now();
      stall_end_ = *stall_begin_ + stall_;
    }
    if (stall_end_ && Clock::now() < *stall_end_) {
      wait_until(std::min(deadline, *stall_end_));
      if (stop.stop_requested()) return SourceEvent{SourceEventKind::kEnd, {}};
      if (Clock::now() < *stall_end_) return SourceEvent{SourceEventKind::kTimeout, {}};
    }
    wait_until(std::min(deadline, Clock::now() + 150ms));  // ~6.7 frames/s
    auto ev = replay_->next(stop, deadline);
    if (ev && ev->kind == SourceEventKind::kFrame) ++delivered_;
    return ev;
  }
  std::optional<Clock::time_point> stall_begin_, stall_end_;

 private:
  std::unique_ptr<pipeline::ReplaySource> replay_;
  int stall_after_;
  std::chrono::milliseconds stall_;
  int delivered_ = 0;
  std::mutex mutex_;
  std::condition_variable_any cv_;
};

TEST(DaemonFaults, StalledSourceStopsTheWatchdogAndPublishesLost) {
  const std::string seq = shared_sequence();
  ASSERT_FALSE(seq.empty());
  TempDir dir("stall");
  const std::string text =
      "source:\n  replay: {sequence: \"" + seq +
      "\", rate: max, max_frames: 16}\n"
      "pipeline: {stall_timeout_s: 0.3}\n"
      "supervisor: {status_interval_s: 0.2}\n"
      "outputs:\n  trajectory: {path: \"" +
      (dir / "traj.tum") +
      "\", append: false}\n"
      "  can: {path: \"" +
      (dir / "can.log") +
      "\"}\n"
      "  lcm: {url: \"file://" +
      (dir / "poses.lcmlog") +
      "?mode=w\"}\n"
      "geo:\n  mode: fixed\n  origin: {latitude_deg: 48.137, longitude_deg: 11.575, height_m: 520.0}\n"
      "  T_site_slam: {translation_m: [0, 0, 2], rotation_wxyz: [0.5, -0.5, 0.5, -0.5]}\n"
      "dynamic: {mode: none}\n";
  auto config = load_daemon_config_from_string(text, "stall.yaml", "");
  ASSERT_TRUE(config) << config.error().message;
  auto replay = pipeline::ReplaySource::open(config->replay);
  ASSERT_TRUE(replay);
  auto source = std::make_unique<StallingSource>(std::move(*replay), 8, 2000ms);
  StallingSource* stalling = source.get();

  NotifySocket notify(dir / "notify.sock");
  ASSERT_TRUE(notify.ok());
  setenv("NOTIFY_SOCKET", (dir / "notify.sock").c_str(), 1);
  setenv("WATCHDOG_USEC", "400000", 1);
  setenv("WATCHDOG_PID", std::to_string(getpid()).c_str(), 1);
  auto daemon = Daemon::create(*config, std::move(source));
  ASSERT_TRUE(daemon) << daemon.error().message;
  sigset_t none;
  sigemptyset(&none);
  sigaddset(&none, SIGUSR2);  // never sent: the run ends with the source
  pthread_sigmask(SIG_BLOCK, &none, nullptr);
  EXPECT_EQ((*daemon)->run(none), 0);
  // The pipeline's threads have ended: the source's record is stable (and
  // goes with the daemon).
  ASSERT_TRUE(stalling->stall_begin_);
  const auto stall_begin = *stalling->stall_begin_, stall_end = *stalling->stall_end_;
  daemon->reset();
  // STOPPING=1 is the daemon's last notify message: with it, all are in.
  notify.wait_for_message("STOPPING=1", 5s);
  unsetenv("NOTIFY_SOCKET");
  unsetenv("WATCHDOG_USEC");
  unsetenv("WATCHDOG_PID");

  // Watchdog: pinged while frames flowed, silent through the stall (after
  // the frames already in the pipeline were tracked), pinged again after.
  int before = 0, during = 0, after = 0;
  for (const auto& m : notify.with("WATCHDOG=1")) {
    if (m.t < stall_begin)
      ++before;
    else if (m.t > stall_begin + 600ms && m.t < stall_end)
      ++during;
    else if (m.t > stall_end + 200ms)
      ++after;
  }
  EXPECT_GT(before, 0);
  EXPECT_EQ(during, 0);
  EXPECT_GT(after, 0);
  if (::testing::Test::HasFailure()) {
    for (const auto& m : notify.messages()) {
      std::printf("%+6.0f ms %s\n", std::chrono::duration<double, std::milli>(m.t - stall_begin).count(),
                  m.text.c_str());
    }
  }
  bool lost_status = false;
  for (const auto& m : notify.with("STATUS=LOST")) {
    lost_status |=
        m.t > stall_begin && m.t < stall_end + 300ms && m.text.find("source stalled") != std::string::npos;
  }
  EXPECT_TRUE(lost_status);

  // LCM: LOST poses naming the stall, then tracking again.
  lcm::LogFile log(dir / "poses.lcmlog", "r");
  ASSERT_TRUE(log.good());
  int stalled = 0, after_stall_tracked = 0;
  std::int64_t last_seq = -1;
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    if (ev->channel != "SITEPOSE_POSE") continue;
    auto pose = output::decode_lcm<sitepose::pose_t>(ev->data, ev->datalen);
    ASSERT_TRUE(pose);
    if (pose->state == sitepose::pose_t::STATE_LOST &&
        pose->state_reason.find("source stalled") != std::string::npos) {
      ++stalled;
      EXPECT_EQ(pose->seq, 7);  // repeats the last frame
    }
    if (pose->seq > 7 && pose->state != sitepose::pose_t::STATE_LOST) ++after_stall_tracked;
    EXPECT_GE(pose->seq, last_seq);
    last_seq = pose->seq;
  }
  EXPECT_GE(stalled, 4);  // 2 s / 0.3 s
  EXPECT_GE(after_stall_tracked, 4);
  EXPECT_EQ(last_seq, 15);

  // CAN: the pose/quality frames said LOST during the stall.
  int can_lost = 0;
  auto records = output::read_candump_file(dir / "can.log");
  ASSERT_TRUE(records);
  for (const auto& r : *records) {
    if (((r.frame.id >> 8) & 0xFFFF) == 0xFF10 && (r.frame.data[1] >> 4) == 2) ++can_lost;
  }
  EXPECT_GE(can_lost, stalled);
  expect_complete_tum_lines(read_lines(dir / "traj.tum"));
}

GeoConfig fixed_geo() {
  GeoConfig g;
  g.mode = GeoMode::kFixed;
  g.origin = {48.137, 11.575, 520.0};
  return g;
}

std::unique_ptr<pipeline::Pipeline> fake_pipeline(
    int frames, std::vector<std::unique_ptr<pipeline::PoseOutput>> outputs) {
  pipeline::PipelineOptions o;
  o.publish_retry_delay_s = 0.0;
  o.publish_max_attempts = 4;
  auto p = pipeline::Pipeline::create(o,
                                      std::make_unique<sitepose::testing::ScriptedSource>(
                                          sitepose::testing::ScriptedSource::frames(frames), false),
                                      std::make_unique<pipeline::PassThroughDetect>(),
                                      std::make_unique<sitepose::testing::FakeTracker>(), std::move(outputs));
  EXPECT_TRUE(p);
  return p ? std::move(*p) : nullptr;
}

TEST(DaemonFaults, LcmSendFailuresAreCountedAndRetried) {
  auto anchoring = Anchoring::create(fixed_geo());
  ASSERT_TRUE(anchoring);
  std::vector<std::int64_t> delivered;
  int calls = 0;
  output::LcmOptions options;
  options.max_send_attempts = 1;  // leave the retrying to the publish stage
  // Every third send fails, as a full socket buffer would.
  auto publisher = output::LcmPublisher::create_with_sender(
      options, [&](const std::string& channel, const void* data, unsigned size) {
        if (++calls % 3 == 0) return -1;
        if (channel == options.pose_channel) {
          auto pose = output::decode_lcm<sitepose::pose_t>(data, size);
          if (pose) delivered.push_back(pose->seq);
        }
        return 0;
      });
  ASSERT_TRUE(publisher);
  std::vector<std::unique_ptr<pipeline::PoseOutput>> outputs;
  outputs.push_back(std::make_unique<LcmOutput>(std::move(*publisher), **anchoring));
  auto p = fake_pipeline(30, std::move(outputs));
  ASSERT_TRUE(p);
  p->start();
  ASSERT_TRUE(p->wait());
  ASSERT_EQ(delivered.size(), 30u);
  for (std::size_t i = 0; i < delivered.size(); ++i) EXPECT_EQ(delivered[i], (std::int64_t)i);
  const auto h = p->health();
  ASSERT_EQ(h.outputs.size(), 1u);
  EXPECT_GT(h.outputs[0].errors, 5u);
  EXPECT_EQ(h.outputs[0].retries, h.outputs[0].errors);
  EXPECT_EQ(h.outputs[0].failed, 0u);
  EXPECT_EQ(h.outputs[0].published, 30u);
}

// Fails every `period`-th frame, otherwise writes to a candump file.
class FlakySink final : public output::CanSink {
 public:
  FlakySink(std::unique_ptr<output::CanSink> inner, int period) : inner_(std::move(inner)), period_(period) {}
  Status flush() override { return inner_->flush(); }

 protected:
  Status do_send(std::int64_t t_ns, const output::CanFrame& frame) override {
    if (++calls_ % period_ == 0) return make_error(ErrorCode::kIoError, "injected: no buffer space");
    return inner_->send(t_ns, frame);
  }

 private:
  std::unique_ptr<output::CanSink> inner_;
  int period_;
  int calls_ = 0;
};

TEST(DaemonFaults, CanSinkErrorsAreCountedAndResumedWithoutDuplicates) {
  TempDir dir("cansink");
  auto anchoring = Anchoring::create(fixed_geo());
  ASSERT_TRUE(anchoring);
  auto file = output::CandumpSink::open_file(dir / "can.log", "can0");
  ASSERT_TRUE(file);
  // One failure at most per pose (13 frames), so 4 attempts always suffice.
  auto sink = std::make_unique<FlakySink>(std::move(*file), 17);
  output::CanSink* sink_view = sink.get();
  std::vector<std::unique_ptr<pipeline::PoseOutput>> outputs;
  outputs.push_back(std::make_unique<CanOutput>(output::CanOutputOptions{}, std::move(sink), **anchoring));
  auto p = fake_pipeline(20, std::move(outputs));
  ASSERT_TRUE(p);
  p->start();
  ASSERT_TRUE(p->wait());
  const auto h = p->health();
  EXPECT_EQ(h.outputs[0].failed, 0u);
  EXPECT_EQ(h.outputs[0].published, 20u);
  EXPECT_EQ(sink_view->counters().send_errors, h.outputs[0].errors);
  EXPECT_GE(h.outputs[0].errors, 15u);  // 260 frames / 17, each a retried pose
  // 13 frames a pose (7 fast-packet frames of 129029 included), each once.
  auto records = output::read_candump_file(dir / "can.log");
  ASSERT_TRUE(records);
  EXPECT_EQ(records->size(), 20u * 13u);
  int quality = 0;
  std::uint8_t expected_alive = 0;
  for (const auto& r : *records) {
    if (((r.frame.id >> 8) & 0xFFFF) != 0xFF10) continue;
    EXPECT_EQ(r.frame.data[1] & 0x0F, expected_alive) << "E2E alive counter: a frame lost or repeated";
    expected_alive = (expected_alive + 1) & 0x0F;
    ++quality;
  }
  EXPECT_EQ(quality, 20);
}

// issue 20: on a full disk health said can ok=90 failed=0 while the frames
// of 28 poses were lost. Now a pose whose frames could not be written is
// counted failed, and the sink's count is what the log holds.
TEST(DaemonFaults, CanFullDiskIsCountedTruthfully) {
  TempDir dir("canfull");
  auto anchoring = Anchoring::create(fixed_geo());
  ASSERT_TRUE(anchoring);
  auto file = output::CandumpSink::open_file(dir / "can.log", "can0");
  ASSERT_TRUE(file);
  output::CanSink* sink_view = file->get();
  std::vector<std::unique_ptr<pipeline::PoseOutput>> outputs;
  outputs.push_back(std::make_unique<CanOutput>(output::CanOutputOptions{}, std::move(*file), **anchoring));
  auto p = fake_pipeline(20, std::move(outputs));
  ASSERT_TRUE(p);
  {
    sitepose::testing::FileSizeLimit full(3000);  // about 5 of 20 poses (13 frames, ~45 bytes each)
    ASSERT_TRUE(full.ok());
    p->start();
    ASSERT_TRUE(p->wait());
  }
  const auto h = p->health();
  EXPECT_GE(h.outputs[0].failed, 10u);
  EXPECT_GE(h.outputs[0].published, 3u);
  EXPECT_EQ(h.outputs[0].published + h.outputs[0].failed, 20u);
  auto records = output::read_candump_file(dir / "can.log");
  ASSERT_TRUE(records) << records.error().message;
  EXPECT_EQ(sink_view->counters().frames_sent, records->size());
  EXPECT_GE(records->size(), h.outputs[0].published * 13u);
}

pipeline::PosePacket ok_pose(std::int64_t seq) {
  pipeline::PosePacket packet;
  packet.pose.seq = seq;
  packet.pose.t_ns = 1'000'000'000 + seq * 100'000'000;
  packet.pose.state = TrackingState::kOk;
  packet.pose.T_world_cam = SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.5 * seq, -1.25, 3.0));
  return packet;
}

// issue 20: a short write on a full disk was kept and the next pose's line
// spliced onto it (a 10-field line that eval rejects).
TEST(DaemonFaults, FullDiskLeavesNoHalfTrajectoryLine) {
  TempDir dir("fulldisk");
  auto output = TrajectoryOutput::open(dir / "traj.tum", false);
  ASSERT_TRUE(output) << output.error().message;
  ASSERT_TRUE((*output)->publish(ok_pose(0)));
  const auto line_bytes = fs::file_size(dir / "traj.tum");
  {
    sitepose::testing::FileSizeLimit full(2 * line_bytes + 20);  // pose 2 fits 20 bytes
    ASSERT_TRUE(full.ok());
    ASSERT_TRUE((*output)->publish(ok_pose(1)));
    EXPECT_FALSE((*output)->publish(ok_pose(2)));
    EXPECT_FALSE((*output)->retry());  // still full
    EXPECT_EQ(fs::file_size(dir / "traj.tum"), 2 * line_bytes);
  }
  ASSERT_TRUE((*output)->publish(ok_pose(3)));  // pose 2 abandoned, space back
  {
    sitepose::testing::FileSizeLimit full(3 * line_bytes + 20);
    ASSERT_TRUE(full.ok());
    EXPECT_FALSE((*output)->publish(ok_pose(4)));
  }
  ASSERT_TRUE((*output)->retry());  // space back: pose 4 whole, once
  EXPECT_EQ((*output)->lines_written(), 4u);
  const auto lines = read_lines(dir / "traj.tum");
  expect_complete_tum_lines(lines);
  auto tum = io::read_tum_trajectory(dir / "traj.tum");
  ASSERT_TRUE(tum) << tum.error().message;
  ASSERT_EQ(tum->size(), 4u);
  const double expected_x[] = {0.0, 0.5, 1.5, 2.0};  // poses 0, 1, 3, 4
  for (std::size_t i = 0; i < 4; ++i)
    EXPECT_DOUBLE_EQ((*tum)[i].T_world_cam.translation().x(), expected_x[i]);
}

std::vector<std::int64_t> tum_times_ns(const std::string& path) {
  auto tum = io::read_tum_trajectory(path);
  EXPECT_TRUE(tum) << tum.error().message;
  std::vector<std::int64_t> out;
  if (tum) {
    for (const auto& p : *tum) out.push_back(std::llround(p.t_s * 1e9));
  }
  return out;
}

// issue 20: a restart with append: true wrote times from 0 again into the
// same trajectory (a replay restarts its time base), which eval rejects.
TEST(DaemonFaults, RestartAppendsWhileTimesContinueAndMovesTheFileWhenTheyGoBack) {
  TempDir dir("restart");
  const std::string path = dir / "traj.tum";
  {
    auto output = TrajectoryOutput::open(path, false);
    ASSERT_TRUE(output) << output.error().message;
    for (int seq = 0; seq < 3; ++seq) ASSERT_TRUE((*output)->publish(ok_pose(seq)));
  }
  {  // times continue (a camera clock): appended to the same file
    auto output = TrajectoryOutput::open(path, true);
    ASSERT_TRUE(output) << output.error().message;
    ASSERT_TRUE((*output)->publish(ok_pose(3)));
  }
  EXPECT_EQ(read_lines(path).size(), 4u);
  EXPECT_FALSE(fs::exists(path + ".1"));
  {  // the replay starts again at its first time: a new file, the old one kept whole
    auto output = TrajectoryOutput::open(path, true);
    ASSERT_TRUE(output) << output.error().message;
    for (int seq = 0; seq < 2; ++seq) ASSERT_TRUE((*output)->publish(ok_pose(seq)));
  }
  const std::int64_t t0 = ok_pose(0).pose.t_ns, dt = ok_pose(1).pose.t_ns - t0;
  EXPECT_EQ(tum_times_ns(path + ".1"), (std::vector<std::int64_t>{t0, t0 + dt, t0 + 2 * dt, t0 + 3 * dt}));
  EXPECT_EQ(tum_times_ns(path), (std::vector<std::int64_t>{t0, t0 + dt}));
  {  // once more: the next free name
    auto output = TrajectoryOutput::open(path, true);
    ASSERT_TRUE(output) << output.error().message;
    ASSERT_TRUE((*output)->publish(ok_pose(0)));
  }
  EXPECT_EQ(tum_times_ns(path + ".2").size(), 2u);
  EXPECT_EQ(tum_times_ns(path).size(), 1u);
}

}  // namespace
}  // namespace sitepose::daemon::testing
