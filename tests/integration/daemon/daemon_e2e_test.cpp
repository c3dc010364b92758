// siteposed as a process, end to end: replays a simulated sequence; an LCM
// subscriber (udpm, inside a network namespace this test creates: the
// multicast route stays off the host) receives every pose; the candump log
// decodes (tools/can_decode.py, an independent decoder) to the same poses;
// the trajectory matches the ground truth; sd_notify READY / STATUS /
// WATCHDOG arrive on a test socket. Plus: SIGTERM mid-run, bad configs,
// --check-config, and `systemd-analyze verify` of the unit.

#include <sched.h>

#include <lcm/lcm-cpp.hpp>

#include "daemon_test_util.hpp"
#include "sitepose/health_t.hpp"
#include "sitepose/io/json_file.hpp"
#include "sitepose/pose_t.hpp"

namespace sitepose::daemon::testing {
namespace {

using namespace std::chrono_literals;

constexpr char kPython[] = "/usr/bin/python3";

struct LcmCapture {
  std::mutex mutex;
  std::vector<sitepose::pose_t> poses;
  std::vector<sitepose::health_t> health;
  void on_pose(const lcm::ReceiveBuffer*, const std::string&, const sitepose::pose_t* m) {
    std::lock_guard lock(mutex);
    poses.push_back(*m);
  }
  void on_health(const lcm::ReceiveBuffer*, const std::string&, const sitepose::health_t* m) {
    std::lock_guard lock(mutex);
    health.push_back(*m);
  }
};

// Enters a fresh network namespace with lo up and a multicast route (root
// only); false with the reason when not permitted.
bool enter_network_namespace(std::string& why) {
  if (unshare(CLONE_NEWNET) != 0) {
    why = std::string("unshare(CLONE_NEWNET): ") + std::strerror(errno) + " (needs root)";
    return false;
  }
  if (std::system("ip link set lo up && ip route add 224.0.0.0/4 dev lo") != 0) {
    why = "ip link/route in the new namespace failed";
    return false;
  }
  return true;
}

TEST(DaemonEndToEnd, ReplayPublishesEveryPoseOnLcmCanAndTrajectory) {
  const std::string seq = shared_sequence();
  ASSERT_FALSE(seq.empty()) << "could not simulate the test sequence";
  std::string why;
  if (!enter_network_namespace(why)) GTEST_SKIP() << why;
  TempDir dir("e2e");
  const std::string url = "udpm://239.255.76.67:7667?ttl=0";
  write_file(dir / "siteposed.yaml", config_text(seq, dir, "max", url));

  lcm::LCM lcm(url);
  ASSERT_TRUE(lcm.good());
  LcmCapture capture;
  lcm.subscribe("SITEPOSE_POSE", &LcmCapture::on_pose, &capture);
  lcm.subscribe("SITEPOSE_HEALTH", &LcmCapture::on_health, &capture);
  std::atomic<int> empty_polls{0};  // receives that timed out with nothing to read
  std::jthread receiver([&](std::stop_token stop) {
    while (!stop.stop_requested()) {
      if (lcm.handleTimeout(50) == 0) ++empty_polls;
    }
  });

  NotifySocket notify(dir / "notify.sock");
  ASSERT_TRUE(notify.ok());
  // The one clock every time field is checked against (UTC microseconds).
  auto utc_now_us = [] {
    return std::chrono::duration_cast<std::chrono::microseconds>(
               std::chrono::system_clock::now().time_since_epoch())
        .count();
  };
  const std::int64_t started_us = utc_now_us();
  Child daemon(
      {SITEPOSED_EXE, "--config", dir / "siteposed.yaml"},
      {{"NOTIFY_SOCKET", dir / "notify.sock"}, {"WATCHDOG_USEC", "2000000"}, {"WATCHDOG_PID", "self"}},
      dir / "stderr.txt");
  const int status = daemon.wait(90s);
  const std::int64_t ended_us = utc_now_us();
  // The daemon sent everything before it exited. Wait until every pose and
  // a health report are in and a receive that began after the exit found
  // nothing more (so an extra pose is counted too); STOPPING=1 is the last
  // notify message.
  const int empty_at_exit = empty_polls;
  wait_for(
      [&] {
        std::lock_guard lock(capture.mutex);
        return capture.poses.size() >= static_cast<std::size_t>(kSequenceFrames) && !capture.health.empty() &&
               empty_polls >= empty_at_exit + 2;
      },
      5s);
  notify.wait_for_message("STOPPING=1", 5s);
  receiver = {};
  const std::string log = [&] {
    std::string s;
    for (auto& l : read_lines(dir / "stderr.txt")) s += l + "\n";
    return s;
  }();
  ASSERT_EQ(status, 0) << log;

  // LCM: every frame's pose once, in order, stamped with the frame's
  // capture time in UTC: the replay's times shifted to now, so within this
  // run on the test's clock and spaced as times.txt.
  const auto times = io::read_times(seq + "/times.txt");
  ASSERT_TRUE(times);
  std::lock_guard lock(capture.mutex);
  ASSERT_EQ(capture.poses.size(), static_cast<std::size_t>(kSequenceFrames)) << log;
  int ok = 0;
  const std::int64_t first_us = capture.poses.front().utime;
  for (std::size_t i = 0; i < capture.poses.size(); ++i) {
    const auto& p = capture.poses[i];
    EXPECT_EQ(p.seq, static_cast<std::int64_t>(i));
    // At rate max the replay runs ahead of the clock by up to its length.
    EXPECT_GE(p.utime, started_us) << i;
    EXPECT_LE(p.utime, ended_us + static_cast<std::int64_t>(((*times).back() - (*times)[0]) * 1e6)) << i;
    EXPECT_NEAR(static_cast<double>(p.utime - first_us), ((*times)[i] - (*times)[0]) * 1e6, 1.0) << i;
    EXPECT_EQ(p.frame, sitepose::pose_t::FRAME_SITE);
    EXPECT_NEAR(p.latitude_deg, 48.137, 0.001);
    ok += p.state == sitepose::pose_t::STATE_OK;
  }
  EXPECT_GE(ok, kSequenceFrames - 2);
  ASSERT_FALSE(capture.health.empty());
  EXPECT_EQ(capture.health.back().num_stages, 4);
  // health_t on the same clock: reports within the run, naming a pose
  // published before them and its latency; the last names the last pose.
  for (const auto& h : capture.health) {
    EXPECT_GE(h.utime, started_us);
    EXPECT_LE(h.utime, ended_us);
    if (h.last_pose_utime >= 0) {
      EXPECT_GE(h.last_pose_utime, first_us);
      EXPECT_GE(h.last_pose_latency_ms, 0.0f);
      EXPECT_LE(h.last_pose_latency_ms, 1e-3 * static_cast<double>(ended_us - started_us));
    }
  }
  EXPECT_EQ(capture.health.back().last_pose_utime, capture.poses.back().utime);

  // Trajectory: one complete line per pose that is not LOST; ATE within the
  // SLAM accuracy (2 cm).
  const auto tum = read_lines(dir / "traj.tum");
  expect_complete_tum_lines(tum);
  int not_lost = 0;
  for (const auto& p : capture.poses) not_lost += p.state != sitepose::pose_t::STATE_LOST;
  EXPECT_EQ(static_cast<int>(tum.size()), not_lost);
  EXPECT_LE(ate_rmse_m(seq, dir / "traj.tum"), 0.02);

  // CAN: the independent decoder reads the candump log back to the same poses.
  const std::string cmd = std::string(kPython) + " " SITEPOSE_SOURCE_DIR "/tools/can_decode.py --dbc " +
                          SITEPOSE_SOURCE_DIR "/config/can/sitepose.dbc " + (dir / "can.log") + " > " +
                          (dir / "can.json");
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  auto decoded = io::read_json_file(dir / "can.json");
  ASSERT_TRUE(decoded.has_value()) << decoded.error().message;
  EXPECT_TRUE(decoded->at("errors").empty());
  std::vector<const io::Json*> rapid, quality, gnss;
  for (const auto& m : decoded->at("messages")) {
    if (m.at("name").get<std::string>() == "N2kPositionRapidUpdate") rapid.push_back(&m);
    if (m.at("name").get<std::string>() == "SiteposePoseQuality") quality.push_back(&m);
    if (m.at("name").get<std::string>() == "N2kGnssPositionData") gnss.push_back(&m);
  }
  ASSERT_EQ(rapid.size(), capture.poses.size());
  ASSERT_EQ(quality.size(), capture.poses.size());
  ASSERT_EQ(gnss.size(), capture.poses.size());
  for (std::size_t i = 0; i < rapid.size(); ++i) {
    const auto& p = capture.poses[i];
    // candump line times and 129029's date (days) + time of day (1e-4 s):
    // the pose's utime.
    EXPECT_NEAR(rapid[i]->at("t").get<double>(), p.utime * 1e-6, 2e-6) << i;
    EXPECT_NEAR(gnss[i]->at("t").get<double>(), p.utime * 1e-6, 2e-6) << i;
    const double n2k_s = gnss[i]->at("signals").at("Date").get<double>() * 86400.0 +
                         gnss[i]->at("signals").at("Time").get<double>();
    EXPECT_NEAR(n2k_s, p.utime * 1e-6, 1.01e-4) << i;
    EXPECT_NEAR(rapid[i]->at("signals").at("Latitude").get<double>(), p.latitude_deg, 0.5e-7 + 1e-12) << i;
    EXPECT_NEAR(rapid[i]->at("signals").at("Longitude").get<double>(), p.longitude_deg, 0.5e-7 + 1e-12) << i;
    EXPECT_EQ(quality[i]->at("signals").at("TrackingState").get<double>(), p.state) << i;
  }

  // systemd: READY once, STATUS lines, WATCHDOG pings while frames flowed.
  EXPECT_EQ(notify.with("READY=1").size(), 1u);
  EXPECT_FALSE(notify.with("STATUS=OK").empty());
  EXPECT_FALSE(notify.with("WATCHDOG=1").empty());
  EXPECT_FALSE(notify.with("STOPPING=1").empty());
}

// The dynamic layer in the daemon: on `parallel` machines drive beside the
// roller and pull plain stereo SLAM along; siteposed in mode full (labels
// detector in the detect stage, two-pass tracking in the track stage)
// keeps the SLAM accuracy. Mode none on the same frames is the contrast.
TEST(DaemonEndToEnd, FullModeKeepsThePoseWhereMachinesPullPlainSlamAlong) {
  constexpr int kFrames = 90;
  const std::string seq = simulated_sequence("parallel", kFrames);
  ASSERT_FALSE(seq.empty()) << "could not simulate the test sequence";
  TempDir dir("dynamic");
  auto run_mode = [&](const std::string& mode) {
    const std::string tum = dir / ("traj_" + mode + ".tum");
    write_file(dir / (mode + ".yaml"), "source:\n  replay: {sequence: \"" + seq +
                                           "\", rate: max}\n"
                                           "outputs:\n  trajectory: {path: \"" +
                                           tum +
                                           "\", append: false}\n"
                                           "  can: {enabled: false}\n  lcm: {enabled: false}\n"
                                           "dynamic: {mode: " +
                                           mode + "}\ndetector: {name: labels}\n");
    Child daemon({SITEPOSED_EXE, "--config", dir / (mode + ".yaml")}, {}, dir / (mode + ".txt"));
    const int status = daemon.wait(120s);
    std::string log;
    for (auto& l : read_lines(dir / (mode + ".txt"))) log += l + "\n";
    EXPECT_EQ(status, 0) << log;
    const auto lines = read_lines(tum);
    expect_complete_tum_lines(lines);
    EXPECT_EQ(static_cast<int>(lines.size()), kFrames) << log;
    return std::pair{ate_rmse_m(seq, tum), log};
  };
  const auto [full_ate_m, full_log] = run_mode("full");
  const auto [none_ate_m, none_log] = run_mode("none");
  std::printf("[figures] siteposed on parallel (%d frames): ATE full %.4f m, none %.4f m\n", kFrames,
              full_ate_m, none_ate_m);
  EXPECT_NE(full_log.find("detect stage: detector labels, dynamic.mode full"), std::string::npos) << full_log;
  EXPECT_NE(full_log.find("dynamic[detect_errors=0 reused_boxes=0 unmasked=0"), std::string::npos)
      << full_log;
  EXPECT_LE(full_ate_m, 0.02);
  EXPECT_LE(full_ate_m, 0.5 * none_ate_m);
}

TEST(DaemonEndToEnd, SigtermMidRunStopsWithinTwoSecondsAndLosesNoLine) {
  const std::string seq = shared_sequence();
  ASSERT_FALSE(seq.empty());
  TempDir dir("sigterm");
  // Recorded rate (6 fps): still running when the signal comes. LCM into an
  // in-process queue nobody reads (this test is about files).
  write_file(dir / "siteposed.yaml", config_text(seq, dir, "recorded", "memq://"));
  NotifySocket notify(dir / "notify.sock");
  Child daemon({SITEPOSED_EXE, "--config", dir / "siteposed.yaml"}, {{"NOTIFY_SOCKET", dir / "notify.sock"}},
               dir / "stderr.txt");
  wait_for([&] { return read_lines(dir / "traj.tum").size() >= 8; }, 60s, 50ms);
  ASSERT_GE(read_lines(dir / "traj.tum").size(), 8u);
  const auto t0 = Clock::now();
  ASSERT_EQ(kill(daemon.pid(), SIGTERM), 0);
  const int status = daemon.wait(10s);
  const auto stop_time = Clock::now() - t0;
  EXPECT_EQ(status, 0);
  EXPECT_LT(stop_time, 2s);
  const auto tum = read_lines(dir / "traj.tum");
  expect_complete_tum_lines(tum);
  EXPECT_LT(tum.size(), static_cast<std::size_t>(kSequenceFrames)) << "the signal came too late to test";
  const auto [published, not_lost] = count_quality_frames(dir / "can.log");
  EXPECT_EQ(static_cast<int>(tum.size()), not_lost) << "TUM lines vs poses published on CAN";
  EXPECT_GE(published, not_lost);
  EXPECT_TRUE(notify.wait_for_message("STOPPING=1", 5s));
}

// SIGTERM at spread-out points of a run, 8 times (50: daemon_sigterm_sweep_test).
TEST(DaemonEndToEnd, SigtermAtRandomPointsLosesNoLine) { expect_sigterm_at_random_points_loses_no_line(8); }

// The replayed sequence loses its images mid-run (a disk unmounted, a
// folder cleaned): siteposed ends with status 1 naming the missing image,
// within seconds, and the trajectory keeps whole lines of every pose published.
TEST(DaemonFaults, ReplayImagesVanishingMidRunEndTheRunCleanly) {
  const std::string seq = shared_sequence();
  ASSERT_FALSE(seq.empty());
  TempDir dir("vanish");
  fs::copy(seq, dir / "seq", fs::copy_options::recursive);
  write_file(dir / "siteposed.yaml", config_text(dir / "seq", dir, "recorded", "memq://"));
  Child daemon({SITEPOSED_EXE, "--config", dir / "siteposed.yaml"}, {}, dir / "stderr.txt");
  wait_for([&] { return read_lines(dir / "traj.tum").size() >= 5; }, 60s, 20ms);
  ASSERT_GE(read_lines(dir / "traj.tum").size(), 5u);
  const auto t0 = Clock::now();
  fs::remove_all(fs::path(dir / "seq") / "image_0");
  const int status = daemon.wait(10s);
  // The frames already in the rings are tracked first: 2.35 s once on a
  // machine loaded 12 times over.
  EXPECT_LT(Clock::now() - t0, 5s);
  EXPECT_EQ(status, 1);
  const std::string err = read_text(dir / "stderr.txt");
  EXPECT_NE(err.find("image_0"), std::string::npos) << err;
  const auto tum = read_lines(dir / "traj.tum");
  expect_complete_tum_lines(tum);
  EXPECT_LT(tum.size(), static_cast<std::size_t>(kSequenceFrames));
  const auto [published, not_lost] = count_quality_frames(dir / "can.log");
  EXPECT_EQ(static_cast<int>(tum.size()), not_lost) << "TUM lines vs poses published on CAN";
}

// LCM unreachable at start (udpm without a multicast route, in a network
// namespace of this test): a clear error naming the provider and the fix,
// status 1, at once, and no output file started.
TEST(DaemonFaults, LcmUnreachableAtStartFailsClearly) {
  const std::string seq = shared_sequence();
  ASSERT_FALSE(seq.empty());
  if (unshare(CLONE_NEWNET) != 0)
    GTEST_SKIP() << "unshare(CLONE_NEWNET): " << std::strerror(errno) << " (needs root)";
  // lo stays down: no interface, no multicast route.
  TempDir dir("lcmdown");
  write_file(dir / "siteposed.yaml", config_text(seq, dir, "max", "udpm://239.255.76.67:7667?ttl=0"));
  const auto t0 = Clock::now();
  Child daemon({SITEPOSED_EXE, "--config", dir / "siteposed.yaml"}, {}, dir / "stderr.txt");
  const int status = daemon.wait(20s);
  EXPECT_LT(Clock::now() - t0, 10s);
  EXPECT_EQ(status, 1);
  const std::string err = read_text(dir / "stderr.txt");
  EXPECT_NE(err.find("LCM: cannot open provider"), std::string::npos) << err;
  EXPECT_NE(err.find("multicast route"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir / "traj.tum"));
}

std::pair<int, std::string> run_siteposed(const std::vector<std::string>& args, const TempDir& dir) {
  std::vector<std::string> argv{SITEPOSED_EXE};
  argv.insert(argv.end(), args.begin(), args.end());
  Child child(argv, {}, dir / "out.txt");
  const int status = child.wait(30s);
  std::string out;
  for (auto& l : read_lines(dir / "out.txt")) out += l + "\n";
  return {status, out};
}

TEST(DaemonConfig, BadConfigExitsTwoNamingEveryKey) {
  TempDir dir("badcfg");
  write_file(dir / "bad.yaml",
             "source:\n  replay: {sequence: /nonexistent, rate: fastest}\n"
             "pipeline: {capture_ring_capacity: 6}\n"
             "outputs:\n  lcm: {urll: x}\n  can: {enabled: true, path: can.log}\n"
             "dynamic: {mode: fullest}\n");
  auto [status, out] = run_siteposed({"--config", dir / "bad.yaml"}, dir);
  EXPECT_EQ(status, 2) << out;
  for (const char* key : {"source.replay.rate", "pipeline.capture_ring_capacity", "outputs.lcm.urll",
                          "outputs.can.enabled", "dynamic.mode"}) {
    EXPECT_NE(out.find(key), std::string::npos) << key << " not named in:\n" << out;
  }
  auto [missing_status, missing_out] = run_siteposed({"--config", dir / "nope.yaml"}, dir);
  EXPECT_EQ(missing_status, 2) << missing_out;
  EXPECT_NE(missing_out.find("nope.yaml"), std::string::npos);
  auto [usage_status, usage_out] = run_siteposed({}, dir);
  EXPECT_EQ(usage_status, 2) << usage_out;
}

TEST(DaemonConfig, CheckConfigValidatesAndPrintsTheResolvedSettings) {
  const std::string seq = shared_sequence();
  ASSERT_FALSE(seq.empty());
  TempDir dir("check");
  write_file(dir / "good.yaml", config_text(seq, dir, "max", "memq://"));
  auto [status, out] = run_siteposed({"--config", dir / "good.yaml", "--check-config"}, dir);
  EXPECT_EQ(status, 0) << out;
  EXPECT_NE(out.find("rate: max"), std::string::npos) << out;
  EXPECT_NE(out.find("mode: none"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(dir / "traj.tum")) << "--check-config must not start anything";
  // The shipped settings file is valid apart from its deployment paths.
  auto [shipped_status, shipped_out] =
      run_siteposed({"--config", SITEPOSE_SOURCE_DIR "/config/siteposed.yaml", "--check-config"}, dir);
  EXPECT_EQ(shipped_status, 2);
  EXPECT_NE(shipped_out.find("source.replay.sequence: /var/lib/siteposed/replay"), std::string::npos)
      << shipped_out;
}

// issue 20: --check-config said "configuration ok" for an LCM URL
// `garbage`, output folders that do not exist, a missing detector .so and
// mode full on a sequence without labels; the real start then failed.
TEST(DaemonConfig, CheckConfigChecksWhatAStartChecks) {
  const std::string seq = shared_sequence();
  ASSERT_FALSE(seq.empty());
  TempDir dir("checkstart");
  // The sequence without its labels (the rest linked).
  fs::create_directories(dir / "nolabels");
  for (const auto& entry : fs::directory_iterator(seq)) {
    if (entry.path().filename() != "labels")
      fs::create_symlink(entry.path(), dir / "nolabels" / entry.path().filename());
  }
  const std::string good = config_text(seq, dir, "max", "memq://");
  const auto replace = [](std::string text, const std::string& from, const std::string& to) {
    const auto pos = text.find(from);
    EXPECT_NE(pos, std::string::npos) << from;
    return pos == std::string::npos ? text : text.replace(pos, from.size(), to);
  };
  const struct {
    const char* name;
    std::string yaml;
    const char* named;
  } cases[] = {
      {"lcm", replace(good, "memq://", "garbage"), "outputs.lcm.url"},
      {"lcm_port", replace(good, "memq://", "udpm://239.255.76.67:99999"), "outputs.lcm.url"},
      {"traj", replace(good, dir / "traj.tum", dir / "no/such/folder/traj.tum"), "outputs.trajectory.path"},
      {"can", replace(good, dir / "can.log", dir / "nofolder/can.log"), "outputs.can.path"},
      {"map", good + "mapping: {map_file: \"" + (dir / "no/such/folder/site.map") + "\"}\n",
       "mapping.map_file"},
      {"plugin",
       replace(good, "dynamic: {mode: none}",
               "dynamic: {mode: bbox}\ndetector: {name: " + (dir / "nope.so") + "}"),
       "nope.so"},
      {"labels",
       replace(replace(good, "dynamic: {mode: none}", "dynamic: {mode: full}\ndetector: {name: labels}"), seq,
               dir / "nolabels"),
       "labels"},
  };
  for (const auto& c : cases) {
    const std::string file = dir / (std::string(c.name) + ".yaml");
    write_file(file, c.yaml);
    auto [status, out] = run_siteposed({"--config", file, "--check-config"}, dir);
    EXPECT_EQ(status, 2) << c.name << ":\n" << out;
    EXPECT_NE(out.find(c.named), std::string::npos) << c.name << ":\n" << out;
    EXPECT_EQ(out.find("configuration ok"), std::string::npos) << c.name << ":\n" << out;
  }
  // The good file with labels and mode full passes, and leaves no file behind.
  write_file(dir / "full.yaml",
             replace(good, "dynamic: {mode: none}", "dynamic: {mode: full}\ndetector: {name: labels}"));
  auto [status, out] = run_siteposed({"--config", dir / "full.yaml", "--check-config"}, dir);
  EXPECT_EQ(status, 0) << out;
  EXPECT_FALSE(fs::exists(dir / "traj.tum"));
  EXPECT_FALSE(fs::exists(dir / "can.log"));
}

TEST(SystemdUnit, VerifiesWithoutAnyMessage) {
  if (std::system("command -v systemd-analyze > /dev/null") != 0) GTEST_SKIP() << "no systemd-analyze";
  TempDir dir("unit");
  // verify checks that ExecStart's binary exists: point it at the build.
  std::string unit = read_text(SITEPOSE_SOURCE_DIR "/systemd/siteposed.service");
  ASSERT_NE(unit.find("Type=notify"), std::string::npos);
  ASSERT_NE(unit.find("WatchdogSec="), std::string::npos);
  for (auto pos = unit.find("/usr/bin/siteposed"); pos != std::string::npos;
       pos = unit.find("/usr/bin/siteposed", pos)) {
    unit.replace(pos, std::strlen("/usr/bin/siteposed"), SITEPOSED_EXE);
  }
  write_file(dir / "siteposed.service", unit);
  const std::string cmd =
      "systemd-analyze verify " + (dir / "siteposed.service") + " > " + (dir / "verify.txt") + " 2>&1";
  const int rc = std::system(cmd.c_str());
  std::string out;
  for (auto& l : read_lines(dir / "verify.txt")) out += l + "\n";
  EXPECT_EQ(rc, 0) << out;
  // Unknown keys only warn (exit 0): any message at all fails the lint.
  EXPECT_TRUE(out.empty()) << out;
}

}  // namespace
}  // namespace sitepose::daemon::testing
