// The report page: every section, nothing fetched from a network, no script.

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace sitepose::views
