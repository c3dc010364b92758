#include "sitepose/config/orbslam2_settings.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <string>

namespace sitepose::config {
namespace {

const std::string kExample =
    std::string(SITEPOSE_SOURCE_DIR) + "/config/orbslam2/sitepose_default_stereo.yaml";

// A complete, valid file; tests replace or drop lines of it.
const std::string kGood =
    "%YAML:1.0\n"
    "Camera.fx: 718.856\n"
    "Camera.fy: 718.856\n"
    "Camera.cx: 607.1928\n"
    "Camera.cy: 185.2157\n"
    "Camera.k1: 0.0\n"
    "Camera.width: 1241\n"
    "Camera.height: 376\n"
    "Camera.fps: 10.0\n"
    "Camera.bf: 386.1448\n"
    "Camera.RGB: 1\n"
    "ThDepth: 35\n"
    "ORBextractor.nFeatures: 2000\n"
    "ORBextractor.scaleFactor: 1.2\n"
    "ORBextractor.nLevels: 8\n"
    "ORBextractor.iniThFAST: 20\n"
    "ORBextractor.minThFAST: 7\n"
    "Viewer.PointSize: 2\n";

std::string replace_line(const std::string& text, const std::string& key, const std::string& line) {
  const auto begin = text.find(key + ":");
  EXPECT_NE(begin, std::string::npos) << key;
  const auto end = text.find('\n', begin);
  return text.substr(0, begin) + line + text.substr(end);
}

std::string load_error(const std::string& text) {
  const auto settings = load_orbslam2_settings_from_string(text, "orb.yaml");
  EXPECT_FALSE(settings.has_value());
  if (settings) return "";
  return settings.error().message;
}

bool contains(const std::string& haystack, const std::string& needle) {
  return haystack.find(needle) != std::string::npos;
}

TEST(OrbSlam2Settings, ShippedExampleMatchesTheDefaultCamera) {
  const auto settings = load_orbslam2_settings(kExample);
  ASSERT_TRUE(settings.has_value()) << settings.error().message;
  EXPECT_DOUBLE_EQ(settings->camera.fx, 700.0);
  EXPECT_DOUBLE_EQ(settings->camera.fy, 700.0);
  EXPECT_DOUBLE_EQ(settings->camera.cx, 480.0);
  EXPECT_DOUBLE_EQ(settings->camera.cy, 270.0);
  EXPECT_DOUBLE_EQ(settings->camera.baseline_m, 1.0);
  EXPECT_EQ(settings->camera.width, 960);
  EXPECT_EQ(settings->camera.height, 540);
  EXPECT_DOUBLE_EQ(settings->fps_hz, 6.0);
  EXPECT_DOUBLE_EQ(settings->close_depth_baselines, 40.0);
  EXPECT_FALSE(settings->rgb);  // sitepose's default camera.channel_order, bgr
  // Its ORB block is sitepose's default ORB block.
  EXPECT_TRUE(settings->orb == OrbConfig{});
  EXPECT_EQ(settings->ignored_keys.size(), 10u);
  EXPECT_TRUE(std::all_of(settings->ignored_keys.begin(), settings->ignored_keys.end(),
                          [](const std::string& k) { return k.rfind("Viewer.", 0) == 0; }));
}

TEST(OrbSlam2Settings, ApplyOverridesOnlyWhatTheFileDefines) {
  const auto settings = load_orbslam2_settings(kExample);
  ASSERT_TRUE(settings.has_value()) << settings.error().message;
  SiteposeConfig config;
  config.orb.grid_cell_px = 40;
  apply_orbslam2_settings(*settings, config);
  ASSERT_TRUE(config.camera.stereo.has_value());
  EXPECT_DOUBLE_EQ(config.camera.stereo->bf(), 700.0);
  EXPECT_EQ(config.orb.grid_cell_px, 40);  // not in ORB-SLAM2 files
  EXPECT_EQ(config.tracking.keyframe_max_interval_frames, 6);
  SiteposeConfig expected;
  expected.camera.stereo = settings->camera;
  expected.orb.grid_cell_px = 40;
  expected.tracking.keyframe_max_interval_frames = 6;
  EXPECT_TRUE(config == expected);
}

// Camera.RGB becomes camera.channel_order (io::open_sequence makes colour
// images gray in that order: io_unit_test ...ChannelOrder...); absent is 0,
// BGR, as ORB-SLAM2 reads a missing key.
TEST(OrbSlam2Settings, CameraRgbSetsTheChannelOrder) {
  for (const auto& [line, order] :
       {std::pair{"Camera.RGB: 1", ChannelOrder::kRgb}, std::pair{"Camera.RGB: 0", ChannelOrder::kBgr},
        std::pair{"", ChannelOrder::kBgr}}) {
    const auto settings =
        load_orbslam2_settings_from_string(replace_line(kGood, "Camera.RGB", line), "kitti.yaml");
    ASSERT_TRUE(settings.has_value()) << settings.error().message;
    SiteposeConfig config;
    config.camera.channel_order = order == ChannelOrder::kRgb ? ChannelOrder::kBgr : ChannelOrder::kRgb;
    apply_orbslam2_settings(*settings, config);
    EXPECT_EQ(config.camera.channel_order, order) << line;
  }
}

// siteposed's source.orbslam2_settings may name anything: a folder or an
// endless device is refused, not read forever.
TEST(OrbSlam2Settings, AFolderOrAnEndlessFileIsRefused) {
  const auto folder = load_orbslam2_settings(SITEPOSE_SOURCE_DIR);
  ASSERT_FALSE(folder.has_value());
  EXPECT_TRUE(contains(folder.error().message, "is a directory")) << folder.error().message;
  const auto endless = load_orbslam2_settings("/dev/zero");
  ASSERT_FALSE(endless.has_value());
  EXPECT_TRUE(contains(endless.error().message, "/dev/zero: larger than 1048576 bytes"))
      << endless.error().message;
}

TEST(OrbSlam2Settings, KittiLikeTextLoads) {
  const auto settings = load_orbslam2_settings_from_string(kGood, "kitti.yaml");
  ASSERT_TRUE(settings.has_value()) << settings.error().message;
  EXPECT_NEAR(settings->camera.baseline_m, 386.1448 / 718.856, 1e-12);
  EXPECT_EQ(settings->orb.n_features, 2000);
  EXPECT_DOUBLE_EQ(settings->close_depth_baselines, 35.0);
  EXPECT_EQ(settings->ignored_keys, std::vector<std::string>{"Viewer.PointSize"});
}

TEST(OrbSlam2Settings, MissingKeysAreNamed) {
  std::string text = kGood;
  text = replace_line(text, "Camera.bf", "");
  text = replace_line(text, "ORBextractor.nLevels", "");
  const std::string message = load_error(text);
  EXPECT_TRUE(contains(message, "orb.yaml: Camera.bf: missing (required key)")) << message;
  EXPECT_TRUE(contains(message, "orb.yaml: ORBextractor.nLevels: missing (required key)")) << message;
}

TEST(OrbSlam2Settings, BadValuesAreNamed) {
  EXPECT_TRUE(contains(load_error(replace_line(kGood, "Camera.fx", "Camera.fx: \"wide\"")),
                       "Camera.fx = \"wide\": expected a number"));
  EXPECT_TRUE(contains(load_error(replace_line(kGood, "Camera.fx", "Camera.fx: -5.0")),
                       "Camera.fx = -5: must be > 0"));
  EXPECT_TRUE(
      contains(load_error(replace_line(kGood, "ORBextractor.nFeatures", "ORBextractor.nFeatures: 1000.5")),
               "ORBextractor.nFeatures = 1000.5: expected an integer"));
  EXPECT_TRUE(contains(load_error(replace_line(kGood, "Camera.k1", "Camera.k1: -0.17")),
                       "Camera.k1 = -0.17: must be 0"));
  EXPECT_TRUE(contains(load_error(replace_line(kGood, "Camera.cx", "Camera.cx: 1300.0")),
                       "Camera.cx = 1300: must be inside the image"));
  EXPECT_TRUE(
      contains(load_error(replace_line(kGood, "ORBextractor.minThFAST", "ORBextractor.minThFAST: 30")),
               "ORBextractor.minThFAST = 30: must be <= ORBextractor.iniThFAST (20)"));
  EXPECT_TRUE(contains(load_error(replace_line(kGood, "Camera.RGB", "Camera.RGB: 2")),
                       "Camera.RGB = 2: must be 0 (BGR) or 1 (RGB)"));
}

TEST(OrbSlam2Settings, RectificationMapsAreUnsupported) {
  const auto settings = load_orbslam2_settings_from_string(
      kGood + "LEFT.K: !!opencv-matrix\n  rows: 1\n  cols: 1\n  dt: d\n  data: [1.0]\n", "euroc.yaml");
  ASSERT_FALSE(settings.has_value());
  EXPECT_EQ(settings.error().code, ErrorCode::kUnsupported);
  EXPECT_TRUE(contains(settings.error().message, "euroc.yaml: LEFT.K"));
}

TEST(OrbSlam2Settings, MalformedFileIsAParseErrorNamingFileAndLine) {
  const auto settings =
      load_orbslam2_settings_from_string("%YAML:1.0\nCamera.fx: [700.0\nCamera.fy: 1\n", "m.yaml");
  ASSERT_FALSE(settings.has_value());
  EXPECT_EQ(settings.error().code, ErrorCode::kParseError);
  // OpenCV notices the open bracket on line 2 or 3 (where the list fails to
  // continue); either way the message starts with "m.yaml:<line>: malformed".
  const std::string& message = settings.error().message;
  EXPECT_EQ(message.rfind("m.yaml:", 0), 0u) << message;
  EXPECT_TRUE(message.size() > 7 && std::isdigit(static_cast<unsigned char>(message[7]))) << message;
  EXPECT_TRUE(contains(message, ": malformed ORB-SLAM2 settings file")) << message;

  const auto indent =
      load_orbslam2_settings_from_string("%YAML:1.0\nCamera.fx: 1\n  Camera.fy: 2\n", "i.yaml");
  ASSERT_FALSE(indent.has_value());
  EXPECT_TRUE(contains(indent.error().message, "i.yaml:3: malformed")) << indent.error().message;
}

// fuzz_orbslam2_settings: OpenCV's reader spun for good on this text (corpus
// orbslam2_settings/two_documents_hang); more than one document marker, or
// a marker line with more on it, is refused before OpenCV sees it.
TEST(OrbSlam2Settings, SecondDocumentMarkerIsRefusedNotAHang) {
  const auto hang = load_orbslam2_settings_from_string("%YAML:1.0\n----d\n----\ns: 1\n", "d.yaml");
  ASSERT_FALSE(hang.has_value());
  EXPECT_EQ(hang.error().code, ErrorCode::kParseError);
  EXPECT_TRUE(contains(hang.error().message, "d.yaml:2: malformed")) << hang.error().message;
  const auto two =
      load_orbslam2_settings_from_string("%YAML:1.0\n---\n" + kGood.substr(10) + "---\n", "t.yaml");
  ASSERT_FALSE(two.has_value());
  EXPECT_TRUE(contains(two.error().message, "document start")) << two.error().message;
  // One plain marker, as OpenCV writes files, still loads.
  const auto one = load_orbslam2_settings_from_string("%YAML:1.0\n---\n" + kGood.substr(10), "o.yaml");
  EXPECT_TRUE(one.has_value()) << one.error().message;
}

TEST(OrbSlam2Settings, MissingHeaderAndEmptyFileAreExplained) {
  const auto no_header = load_orbslam2_settings_from_string("Camera.fx: 1\n", "h.yaml");
  ASSERT_FALSE(no_header.has_value());
  EXPECT_EQ(no_header.error().code, ErrorCode::kParseError);
  EXPECT_TRUE(contains(no_header.error().message, "h.yaml: ")) << no_header.error().message;
  EXPECT_TRUE(contains(no_header.error().message, "%YAML:1.0")) << no_header.error().message;

  const auto empty = load_orbslam2_settings_from_string(" \n", "e.yaml");
  ASSERT_FALSE(empty.has_value());
  EXPECT_TRUE(contains(empty.error().message, "e.yaml: empty file")) << empty.error().message;
}

TEST(OrbSlam2Settings, MissingFileIsNotFound) {
  const auto settings = load_orbslam2_settings("/nonexistent/KITTI00-02.yaml");
  ASSERT_FALSE(settings.has_value());
  EXPECT_EQ(settings.error().code, ErrorCode::kNotFound);
  EXPECT_TRUE(contains(settings.error().message, "/nonexistent/KITTI00-02.yaml"));
}

}  // namespace
}  // namespace sitepose::config
