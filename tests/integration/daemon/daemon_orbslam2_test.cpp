// siteposed with source.orbslam2_settings: an ORB-SLAM2 stereo settings file
// replaces the camera and ORB settings as `sitepose run --orbslam2-settings`
// does; the keys it does not use are logged; a file whose image size is not
// the source's, or with a bad value, stops the start with exit 2 before any
// frame is tracked.

#include <cstdio>

#include "daemon_test_util.hpp"
#include "sitepose/io/sequence.hpp"

namespace sitepose::daemon::testing {
namespace {

using namespace std::chrono_literals;

// The settings of `camera` (the sequence's calib.txt) in ORB-SLAM2's layout,
// with an ORB block that differs from sitepose's defaults and a Viewer key.
std::string orbslam2_text(const StereoCamera& camera, int width, int height, const std::string& fx) {
  char text[1024];
  std::snprintf(text, sizeof(text),
                "%%YAML:1.0\n"
                "Camera.fx: %s\nCamera.fy: %.6f\nCamera.cx: %.6f\nCamera.cy: %.6f\n"
                "Camera.k1: 0.0\nCamera.width: %d\nCamera.height: %d\nCamera.fps: 6.0\n"
                "Camera.bf: %.6f\nCamera.RGB: 1\nThDepth: 35\n"
                "ORBextractor.nFeatures: 1100\nORBextractor.scaleFactor: 1.2\nORBextractor.nLevels: 8\n"
                "ORBextractor.iniThFAST: 19\nORBextractor.minThFAST: 7\n"
                "Viewer.PointSize: 2\nViewer.ViewpointF: 2000\n",
                fx.c_str(), camera.fy, camera.cx, camera.cy, width, height, camera.bf());
  return text;
}

std::string daemon_yaml(const std::string& seq, const TempDir& dir, const std::string& settings) {
  return "source:\n  orbslam2_settings: \"" + settings + "\"\n  replay: {sequence: \"" + seq +
         "\", rate: max}\n"
         "pipeline: {stall_timeout_s: 2.0}\n"
         "outputs:\n  trajectory: {path: \"" +
         (dir / "traj.tum") +
         "\", append: false}\n  can: {enabled: false}\n  lcm: {url: \"memq://\"}\n"
         "dynamic: {mode: none}\n";
}

std::pair<int, std::string> run_siteposed(const std::vector<std::string>& args, const TempDir& dir) {
  std::vector<std::string> argv{SITEPOSED_EXE};
  argv.insert(argv.end(), args.begin(), args.end());
  Child child(argv, {}, dir / "out.txt");
  const int status = child.wait(120s);
  return {status, read_text(dir / "out.txt")};
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// The shared sequence and its camera (the size from its images), or the
// reason why not.
std::string shared_replay(std::string& seq, StereoCamera& camera) {
  seq = shared_sequence();
  if (seq.empty()) return "the simulated sequence could not be made";
  auto sequence = io::open_sequence(seq);
  if (!sequence) return sequence.error().message;
  camera = (*sequence)->camera();
  return "";
}

TEST(DaemonOrbSlam2, SettingsFileReplacesCameraAndOrbAndTheReplayIsTracked) {
  std::string seq;
  StereoCamera camera;
  ASSERT_EQ(shared_replay(seq, camera), "");
  TempDir dir("orbslam2");
  write_file(dir / "orb.yaml", orbslam2_text(camera, camera.width, camera.height, std::to_string(camera.fx)));
  write_file(dir / "d.yaml", daemon_yaml(seq, dir, "orb.yaml"));  // relative to d.yaml

  auto [check_status, check_out] = run_siteposed({"--config", dir / "d.yaml", "--check-config"}, dir);
  ASSERT_EQ(check_status, 0) << check_out;
  // The resolved settings carry the file's values.
  EXPECT_TRUE(contains(check_out, "n_features: 1100")) << check_out;
  EXPECT_TRUE(contains(check_out, "ini_fast_threshold: 19")) << check_out;
  EXPECT_TRUE(contains(check_out, "keyframe_max_interval_frames: 6")) << check_out;
  EXPECT_TRUE(contains(check_out, "channel_order: rgb")) << check_out;
  EXPECT_TRUE(contains(check_out, dir / "orb.yaml")) << check_out;  // resolved against d.yaml
  EXPECT_TRUE(contains(check_out, "keys sitepose does not use, ignored: Viewer.PointSize, Viewer.ViewpointF"))
      << check_out;

  auto [status, out] = run_siteposed({"--config", dir / "d.yaml"}, dir);
  EXPECT_EQ(status, 0) << out;
  EXPECT_TRUE(contains(out, "ignored: Viewer.PointSize, Viewer.ViewpointF")) << out;
  const auto lines = read_lines(dir / "traj.tum");
  EXPECT_GE(lines.size(), static_cast<std::size_t>(kSequenceFrames - 2)) << out;
  expect_complete_tum_lines(lines);
}

TEST(DaemonOrbSlam2, WrongImageSizeOrBadValueExitsTwoBeforeAnyFrame) {
  std::string seq;
  StereoCamera camera;
  ASSERT_EQ(shared_replay(seq, camera), "");
  TempDir dir("orbslam2bad");
  const std::string size = std::to_string(camera.width) + "x" + std::to_string(camera.height);
  // A KITTI-sized file (1241x376) for a sequence of another size.
  write_file(dir / "kitti.yaml", orbslam2_text(camera, 1241, 376, std::to_string(camera.fx)));
  write_file(dir / "size.yaml", daemon_yaml(seq, dir, dir / "kitti.yaml"));
  for (const bool check : {true, false}) {
    std::vector<std::string> args{"--config", dir / "size.yaml"};
    if (check) args.emplace_back("--check-config");
    auto [status, out] = run_siteposed(args, dir);
    EXPECT_EQ(status, 2) << out;
    EXPECT_TRUE(contains(out, "camera.stereo (from source.orbslam2_settings " + (dir / "kitti.yaml") +
                                  ") is 1241x376 but the source's images are " + size))
        << out;
    EXPECT_FALSE(fs::exists(dir / "traj.tum")) << "no frame may be tracked";
  }
  // A bad value and a missing file: named with the key that brought them.
  write_file(dir / "negative.yaml", orbslam2_text(camera, camera.width, camera.height, "-700.0"));
  for (const auto& [file, named] :
       {std::pair{dir / "negative.yaml", std::string("Camera.fx = -700: must be > 0")},
        std::pair{dir / "absent.yaml", std::string("cannot open ORB-SLAM2 settings file")}}) {
    write_file(dir / "bad.yaml", daemon_yaml(seq, dir, file));
    auto [status, out] = run_siteposed({"--config", dir / "bad.yaml"}, dir);
    EXPECT_EQ(status, 2) << out;
    EXPECT_TRUE(contains(out, "bad.yaml: source.orbslam2_settings: ")) << out;
    EXPECT_TRUE(contains(out, named)) << out;
    EXPECT_FALSE(fs::exists(dir / "traj.tum"));
  }
}

}  // namespace
}  // namespace sitepose::daemon::testing
