// siteposed's site map across restarts (issue 19; mapping.map_file,
// mapping.checkpoint_interval_s), the daemon as a process on a replayed
// simulated drive:
//   * stopped by SIGTERM mid-drive it saves the map; started again on the
//     rest of the drive it loads the map, relocalises in it within 5 frames
//     and continues in its frame (ATE over both runs together <= 0.02 m);
//   * a corrupt map file is refused naming why, kept as <file>.bad-1, and
//     the daemon runs with a new map (which it saves);
//   * checkpoints happen at the interval while it runs, and the copy under
//     the map's lock stays below one frame period.

#include <lcm/lcm-cpp.hpp>

#include "daemon_test_util.hpp"
#include "sitepose/mapfile/map_file.hpp"
#include "sitepose/output/lcm_messages.hpp"
#include "sitepose/pose_t.hpp"

namespace sitepose::daemon::testing {
namespace {

using namespace std::chrono_literals;

constexpr int kDriveFrames = 60;  // scenario static: 2 s standing, then 0.8 m/s along the lane

// `rate` recorded or max; `extra` more YAML (the mapping section).
std::string map_config(const std::string& seq, const std::string& run_dir, const std::string& rate,
                       const std::string& extra) {
  return "source:\n  replay: {sequence: \"" + seq + "\", rate: " + rate +
         "}\n"
         "pipeline: {stall_timeout_s: 2.0}\n"
         "supervisor: {log_interval_s: 0.5}\n"
         "outputs:\n"
         "  trajectory: {path: \"" +
         run_dir + "/traj.tum\", append: false}\n" + "  can: {enabled: false}\n" + "  lcm: {url: \"file://" +
         run_dir + "/poses.lcmlog?mode=w\"}\n" + "dynamic: {mode: none}\n" + extra;
}

std::vector<double> read_times_s(const std::string& path) {
  std::vector<double> times;
  for (const std::string& line : read_lines(path)) times.push_back(std::stod(line));
  return times;
}

// The frames of `seq` from `first` on, as a sequence of their own (times
// kept: the drive goes on), for the run after the restart.
std::string tail_sequence(const std::string& seq, std::size_t first, const std::string& out) {
  fs::create_directories(out + "/image_0");
  fs::create_directories(out + "/image_1");
  fs::copy_file(seq + "/calib.txt", out + "/calib.txt");
  const std::vector<std::string> times = read_lines(seq + "/times.txt");
  std::string kept;
  char name[32];
  for (std::size_t i = first; i < times.size(); ++i) {
    kept += times[i] + "\n";
    for (const char* side : {"/image_0/", "/image_1/"}) {
      std::snprintf(name, sizeof(name), "%06zu.png", i);
      const std::string from = seq + side + name;
      std::snprintf(name, sizeof(name), "%06zu.png", i - first);
      fs::copy_file(from, out + side + name);
    }
  }
  write_file(out + "/times.txt", kept);
  return out;
}

// The states of the poses in an LCM log, in order.
std::vector<std::int8_t> logged_states(const std::string& path) {
  std::vector<std::int8_t> states;
  lcm::LogFile log(path, "r");
  EXPECT_TRUE(log.good()) << path;
  if (!log.good()) return states;
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    if (ev->channel != "SITEPOSE_POSE") continue;
    auto pose = output::decode_lcm<sitepose::pose_t>(ev->data, ev->datalen);
    if (pose) states.push_back(pose->state);
  }
  return states;
}

TEST(DaemonMap, SavedOnSigtermThenLoadedAndRelocalisedInAfterRestart) {
  const std::string seq = simulated_sequence("static", kDriveFrames);
  ASSERT_FALSE(seq.empty());
  TempDir dir("maprestart");
  fs::create_directories(dir / "run1");
  fs::create_directories(dir / "run2");
  const std::string map_file = dir / "site.map";
  const std::string mapping = "mapping: {map_file: \"" + map_file + "\", checkpoint_interval_s: 0}\n";

  // Run 1, live: SIGTERM once half the drive is tracked.
  const std::string config1 = dir.write("run1.yaml", map_config(seq, dir / "run1", "recorded", mapping));
  {
    Child child({SITEPOSED_EXE, "--config", config1}, {}, dir / "run1/stderr.txt");
    ASSERT_TRUE(wait_for([&] { return read_lines(dir / "run1/traj.tum").size() >= 30; }, 30s, 50ms))
        << read_text(dir / "run1/stderr.txt");
    EXPECT_FALSE(fs::exists(map_file));  // no checkpoints: the save is the one at stop
    kill(child.pid(), SIGTERM);
    EXPECT_EQ(child.wait(10s), 0) << read_text(dir / "run1/stderr.txt");
  }
  const std::string err1 = read_text(dir / "run1/stderr.txt");
  EXPECT_NE(err1.find("no map file at"), std::string::npos) << err1;
  EXPECT_NE(err1.find("saved " + map_file + " at stop"), std::string::npos) << err1;
  auto saved = mapfile::load_map(map_file);
  ASSERT_TRUE(saved) << saved.error().message;
  EXPECT_GT(saved->map.keyframe_count(), 0u);

  // Run 2 on the rest of the drive, from the frame after run 1's last pose.
  auto est1 = io::read_tum_trajectory(dir / "run1/traj.tum");
  ASSERT_TRUE(est1 && !est1->empty());
  const std::vector<double> times = read_times_s(seq + "/times.txt");
  std::size_t first = 0;
  while (first < times.size() && times[first] <= est1->back().t_s + 1e-6) ++first;
  ASSERT_LT(first + 10, times.size());
  const std::string tail = tail_sequence(seq, first, dir / "tail");
  const std::string config2 = dir.write("run2.yaml", map_config(tail, dir / "run2", "max", mapping));
  Child child({SITEPOSED_EXE, "--config", config2}, {}, dir / "run2/stderr.txt");
  ASSERT_EQ(child.wait(60s), 0) << read_text(dir / "run2/stderr.txt");
  const std::string err2 = read_text(dir / "run2/stderr.txt");
  EXPECT_NE(err2.find("map: loaded " + map_file), std::string::npos) << err2;

  const std::vector<std::int8_t> states = logged_states(dir / "run2/poses.lcmlog");
  ASSERT_EQ(states.size(), times.size() - first);
  int back_after = -1, first_ok = -1;
  for (int k = 0; k < static_cast<int>(states.size()); ++k) {
    if (back_after < 0 && states[k] != sitepose::pose_t::STATE_LOST) back_after = k;
    if (first_ok < 0 && states[k] == sitepose::pose_t::STATE_OK) first_ok = k;
  }
  auto gt = io::read_kitti_trajectory(seq + "/poses.txt", seq + "/times.txt");
  auto est2 = io::read_tum_trajectory(dir / "run2/traj.tum");
  ASSERT_TRUE(gt && est2);
  io::Trajectory both = *est1;
  both.insert(both.end(), est2->begin(), est2->end());
  auto result = eval::evaluate(*gt, both, {});
  ASSERT_TRUE(result) << result.error().message;
  std::printf(
      "run 1: %zu poses, stopped at frame %zu; run 2: %zu frames, relocalised at frame %d, first OK %d, "
      "%zu OK poses; both: ATE rmse %.4f m, max %.4f m\n",
      est1->size(), first, states.size(), back_after, first_ok, est2->size(), result->ate_m.rmse,
      result->ate_m.max);
  EXPECT_GE(back_after, 0);
  EXPECT_LT(back_after, 5);
  EXPECT_LE(result->ate_m.rmse, 0.02);
  EXPECT_GE(est2->size(), states.size() - 10);
}

TEST(DaemonMap, CorruptFileIsKeptAsideAndANewMapStarts) {
  const std::string seq = shared_sequence();
  ASSERT_FALSE(seq.empty());
  TempDir dir("mapcorrupt");
  const std::string map_file = dir / "site.map";
  // A saved map with one payload byte flipped: its checksum no longer fits.
  {
    TempDir first("mapgood");
    const std::string config =
        first.write("d.yaml", map_config(seq, first.path().string(), "max",
                                         "mapping: {map_file: \"" + (first / "site.map") + "\"}\n"));
    Child child({SITEPOSED_EXE, "--config", config}, {}, first / "stderr.txt");
    ASSERT_EQ(child.wait(60s), 0) << read_text(first / "stderr.txt");
    std::string bytes = read_text(first / "site.map");
    ASSERT_GT(bytes.size(), 1000u);
    bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 0x10);
    write_file(map_file, bytes);
  }
  const std::string corrupt = read_text(map_file);
  const std::string config = dir.write(
      "d.yaml", map_config(seq, dir.path().string(), "max", "mapping: {map_file: \"" + map_file + "\"}\n"));
  Child child({SITEPOSED_EXE, "--config", config}, {}, dir / "stderr.txt");
  ASSERT_EQ(child.wait(60s), 0) << read_text(dir / "stderr.txt");
  const std::string err = read_text(dir / "stderr.txt");
  EXPECT_NE(err.find("map file refused: payload checksum"), std::string::npos) << err;
  EXPECT_NE(err.find("kept as " + map_file + ".bad-1; starting a new map"), std::string::npos) << err;
  EXPECT_EQ(read_text(map_file + ".bad-1"), corrupt);  // kept, byte for byte
  EXPECT_GE(read_lines(dir / "traj.tum").size(), static_cast<std::size_t>(kSequenceFrames) - 5u)
      << "the run tracks in its new map";
  auto fresh = mapfile::load_map(map_file);  // the new map, saved at the end
  ASSERT_TRUE(fresh) << fresh.error().message;
  EXPECT_GT(fresh->map.keyframe_count(), 0u);
}

TEST(DaemonMap, CheckpointsAtTheIntervalWhileRunning) {
  const std::string seq = shared_sequence();  // 30 frames at 6 fps: 5 s live
  ASSERT_FALSE(seq.empty());
  TempDir dir("mapcheckpoint");
  const std::string map_file = dir / "site.map";
  const std::string config = dir.write(
      "d.yaml", map_config(seq, dir.path().string(), "recorded",
                           "mapping: {map_file: \"" + map_file + "\", checkpoint_interval_s: 1.0}\n"));
  Child child({SITEPOSED_EXE, "--config", config}, {}, dir / "stderr.txt");
  // The first checkpoint about a second after the start, the run still going.
  EXPECT_TRUE(wait_for([&] { return fs::exists(map_file); }, 4s, 20ms)) << read_text(dir / "stderr.txt");
  EXPECT_EQ(waitpid(child.pid(), nullptr, WNOHANG), 0) << "the daemon ended before its first checkpoint";
  auto checkpoint = mapfile::load_map(map_file);
  ASSERT_TRUE(checkpoint) << checkpoint.error().message;
  ASSERT_EQ(child.wait(30s), 0) << read_text(dir / "stderr.txt");
  // The last health line before the save at stop: saves, copy times.
  int saves = 0;
  double max_copy_ms = -1.0;
  for (const std::string& line : read_lines(dir / "stderr.txt")) {
    const std::size_t at = line.find(" map[saves=");
    if (at == std::string::npos || line.find("age=never") != std::string::npos) continue;
    std::sscanf(line.c_str() + at, " map[saves=%d", &saves);
    const std::size_t max_at = line.find(" max=", at);
    if (max_at != std::string::npos) std::sscanf(line.c_str() + max_at, " max=%lfms", &max_copy_ms);
  }
  std::printf("checkpoints logged: %d (run of 5 s, interval 1 s), longest copy under the map lock %.2f ms\n",
              saves, max_copy_ms);
  EXPECT_GE(saves, 3);  // 4 periodic ones fit, and the save at stop
  EXPECT_GE(max_copy_ms, 0.0);
  EXPECT_LT(max_copy_ms, 1000.0 / 6.0);  // the tracker waits less than one frame period
}

}  // namespace
}  // namespace sitepose::daemon::testing
