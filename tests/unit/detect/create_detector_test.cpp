#include "sitepose/detect/create_detector.hpp"

#include <cstdlib>

#include <gtest/gtest.h>

#include "sitepose/testing/cameras.hpp"
#include "test_util.hpp"

namespace sitepose::detect {
namespace {

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(CreateDetector, BuiltinPluginsAreFoundInTheBuildTree) {
  for (const char* name : {"labels", "stereo-geometric", "opencv-dnn"}) {
    auto path = builtin_plugin_path(name);
    ASSERT_TRUE(path) << path.error().message;
    EXPECT_TRUE(std::filesystem::is_regular_file(*path)) << *path;
  }
  auto path = builtin_plugin_path("stereo-geometric");
  EXPECT_TRUE(contains(*path, "libsitepose_detector_stereo_geometric.so")) << *path;
}

TEST(CreateDetector, UnknownBuiltinNameIsBadInput) {
  auto path = builtin_plugin_path("yolo");
  ASSERT_FALSE(path);
  EXPECT_EQ(path.error().code, ErrorCode::kInvalidArgument);
  EXPECT_TRUE(contains(path.error().message, "yolo"));
}

TEST(CreateDetector, EnvironmentDirectoryTakesPrecedence) {
  const testing::TempDir tmp;
  const std::filesystem::path& dir = tmp.path();
  // Stand-in "labels" plugin: the garbage test plugin under the built-in name.
  std::filesystem::copy_file(DETECT_TEST_GARBAGE_PLUGIN, dir / "libsitepose_detector_labels.so");
  ::setenv("SITEPOSE_DETECTOR_PLUGIN_DIR", dir.c_str(), 1);
  auto path = builtin_plugin_path("labels");
  ::unsetenv("SITEPOSE_DETECTOR_PLUGIN_DIR");
  ASSERT_TRUE(path) << path.error().message;
  EXPECT_EQ(std::filesystem::path(*path).parent_path(), std::filesystem::canonical(dir));
}

TEST(CreateDetector, ContextTheBuiltinsNeedIsChecked) {
  config::DetectorConfig labels;
  labels.name = "labels";
  auto no_sequence = create_detector(labels, {});
  ASSERT_FALSE(no_sequence);
  EXPECT_EQ(no_sequence.error().code, ErrorCode::kInvalidArgument);
  EXPECT_TRUE(contains(no_sequence.error().message, "sequence directory"));

  config::DetectorConfig geometric;
  geometric.name = "stereo-geometric";
  auto no_camera = create_detector(geometric, {});
  ASSERT_FALSE(no_camera);
  EXPECT_TRUE(contains(no_camera.error().message, "camera"));
}

TEST(CreateDetector, PluginConfigCarriesTheContext) {
  config::DetectorConfig c;
  c.name = "stereo-geometric";
  c.geometric_max_range_m = 21.5;
  DetectorContext context;
  StereoCamera cam = testing::centred_camera(480, 270, 350.0, 1.0);
  cam.fy = 351;
  context.camera = cam;
  auto yaml = plugin_config_yaml(c, context);
  ASSERT_TRUE(yaml) << yaml.error().message;
  EXPECT_TRUE(contains(*yaml, "fy: 351")) << *yaml;
  EXPECT_TRUE(contains(*yaml, "max_range_m: 21.5")) << *yaml;
  auto detector = create_detector(c, context);
  ASSERT_TRUE(detector) << detector.error().message;
  EXPECT_EQ((*detector)->name(), "stereo-geometric");
  EXPECT_TRUE((*detector)->capabilities().has_segmentation);
  EXPECT_TRUE((*detector)->capabilities().tracks_ids);
}

TEST(CreateDetector, APathLoadsAThirdPartyPlugin) {
  config::DetectorConfig c;
  c.name = DETECT_TEST_GARBAGE_PLUGIN;
  c.score_threshold = 0.0;
  auto detector = create_detector(c, {});
  ASSERT_TRUE(detector) << detector.error().message;
  auto dets = (*detector)->detect(test::gray_frame(64, 48));
  ASSERT_TRUE(dets);
  EXPECT_EQ(dets->size(), 2u);
  c.name = "/nonexistent/plugin.so";
  auto missing = create_detector(c, {});
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().code, ErrorCode::kNotFound);
}

// Isolation applies to a plugin .so only: with a host that cannot start,
// a built-in still loads (in this process) and a .so path fails naming it.
TEST(CreateDetector, IsolationRunsPluginPathsInTheHostAndBuiltinsHere) {
  IsolationOptions isolation;
  isolation.in_child_process = true;
  isolation.host_path = "/nonexistent/sitepose-detector-host";
  config::DetectorConfig geometric;
  geometric.name = "stereo-geometric";
  DetectorContext context;
  context.camera = testing::centred_camera(480, 270, 350.0, 1.0);
  auto builtin = create_detector(geometric, context, isolation);
  EXPECT_TRUE(builtin) << builtin.error().message;
  config::DetectorConfig plugin;
  plugin.name = DETECT_TEST_GARBAGE_PLUGIN;
  auto isolated = create_detector(plugin, {}, isolation);
  ASSERT_FALSE(isolated);
  EXPECT_TRUE(contains(isolated.error().message, "/nonexistent/sitepose-detector-host"))
      << isolated.error().message;
  isolation.host_path.clear();
  auto in_host = create_detector(plugin, {}, isolation);
  ASSERT_TRUE(in_host) << in_host.error().message;
  auto dets = (*in_host)->detect(test::gray_frame(64, 48));
  ASSERT_TRUE(dets) << dets.error().message;
  EXPECT_EQ(dets->size(), 2u);
}

}  // namespace
}  // namespace sitepose::detect
