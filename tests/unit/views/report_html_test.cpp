// The report page: every section, nothing fetched from a network, no script.

#include <gtest/gtest.h>

#include <cmath>

#include "sitepose/testing/files.hpp"
#include "sitepose/views/report_html.hpp"

namespace sitepose::views {
namespace {

DebugRecord small_record() {
  DebugRecord record;
  record.info.mode = "full";
  record.info.version = "0.1.0";
  record.config_yaml = "dynamic:\n  mode: <full>\n";
  for (int i = 0; i < 20; ++i) {
    FrameRecord f;
    f.seq = i;
    f.t_ns = i * 100'000'000LL;
    f.state = TrackingState::kOk;
    f.T_world_cam = SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.1 * i, 0.0, 0.0));
    f.timings.total_ms = 20.0 + i;
    f.timings.extract_left_ms = 5.0 + 0.1 * i;
    f.mar = 0.02 * i;
    f.pixel_mask_used = i > 15;
    f.trace.boxes.push_back({3, "truck", 1.0, cv::Rect(1, 1, 5, 5)});
    dynamic::ObjectVerdict v;
    v.instance = 3;
    v.state = i < 10 ? dynamic::MotionState::kStatic : dynamic::MotionState::kMoving;
    f.objects.push_back(v);
    f.trace.keyframes_in_map = 1 + i / 5;
    record.frames.push_back(f);
  }
  return record;
}

TEST(ReportHtml, HasEverySectionAndNeedsNoNetwork) {
  const std::string html = render_report_html(small_record(), nullptr, "sitepose test");
  for (const auto& id : report_sections()) {
    EXPECT_NE(html.find("<section id='" + id + "'>"), std::string::npos) << id;
  }
  EXPECT_EQ(html.find("http:"), std::string::npos);
  EXPECT_EQ(html.find("https:"), std::string::npos);
  EXPECT_EQ(html.find("<script"), std::string::npos);
  // The config is escaped, the run's pixel-mask calls counted.
  EXPECT_NE(html.find("mode: &lt;full&gt;"), std::string::npos);
  EXPECT_NE(html.find("Pixel-mask calls: 4 of 20"), std::string::npos);
  EXPECT_NE(html.find("Accuracy not evaluated: no ground truth"), std::string::npos);
  // Both states of instance 3 are on its timeline.
  EXPECT_NE(html.find("#3 run"), std::string::npos);
  EXPECT_NE(html.find("#e000e0"), std::string::npos);
  EXPECT_NE(html.find("#00a0e0"), std::string::npos);
}

// meta.json through the JSON parser: null (how a NaN is written) reads as
// NaN, no list as none; a file that is not JSON or a list that is not
// numbers is an error naming the file, not a guess.
TEST(ReportHtml, OcclusionRatiosAreReadFromMetaJson) {
  testing::TempDir dir;
  const std::string meta = dir / "meta.json";
  testing::write_file(meta, "{\"T_site_world\": [[1, 0], [0, 1]], \"occlusion_ratio\": [0.25, null, 1e-3]}");
  auto read = read_occlusion_ratios(meta);
  ASSERT_TRUE(read) << read.error().message;
  ASSERT_EQ(read->size(), 3u);
  EXPECT_DOUBLE_EQ((*read)[0], 0.25);
  EXPECT_TRUE(std::isnan((*read)[1]));
  EXPECT_DOUBLE_EQ((*read)[2], 1e-3);

  testing::write_file(meta, "{\"frames\": 3}");
  read = read_occlusion_ratios(meta);
  ASSERT_TRUE(read) << read.error().message;
  EXPECT_TRUE(read->empty());

  testing::write_file(meta, "{\"occlusion_ratio\": [0.1 0.2]}");
  read = read_occlusion_ratios(meta);
  ASSERT_FALSE(read);
  EXPECT_EQ(read.error().code, ErrorCode::kParseError);
  EXPECT_NE(read.error().message.find(meta), std::string::npos) << read.error().message;

  testing::write_file(meta, "{\"occlusion_ratio\": [0.1, \"high\"]}");
  read = read_occlusion_ratios(meta);
  ASSERT_FALSE(read);
  EXPECT_NE(read.error().message.find("not a list of numbers"), std::string::npos) << read.error().message;
}

}  // namespace
}  // namespace sitepose::views
