#include "detail/distribution.hpp"
#include "detail/subpixel.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <opencv2/features2d.hpp>
#include <set>

#include "test_images.hpp"

namespace sitepose::features::detail {
namespace {

cv::KeyPoint candidate(float x, float y, float response) { return cv::KeyPoint(x, y, 7.0f, -1.0f, response); }

TEST(CellThresholds, OnePassEqualsFastAtTheInitialThreshold) {
  // The extractor runs FAST once at the minimum threshold and filters by
  // score; that must give exactly FAST's result at the higher threshold.
  const cv::Mat image = sitepose::features::test::make_texture(cv::Size(400, 300), 11);
  std::vector<cv::KeyPoint> low;
  std::vector<cv::KeyPoint> high;
  cv::FAST(image, low, 7, true);
  cv::FAST(image, high, 20, true);
  std::set<std::pair<int, int>> from_low;
  std::set<std::pair<int, int>> from_high;
  for (const auto& kp : low) {
    if (kp.response >= 20.0f) from_low.insert({int(kp.pt.x), int(kp.pt.y)});
  }
  for (const auto& kp : high) from_high.insert({int(kp.pt.x), int(kp.pt.y)});
  ASSERT_GT(from_high.size(), 100u);
  EXPECT_EQ(from_low, from_high);
}

TEST(CellThresholds, KeepsStrongOrFallsBackPerCell) {
  const cv::Rect area(0, 0, 100, 50);  // two 50 px cells
  const std::vector<cv::KeyPoint> candidates = {
      candidate(10, 10, 25), candidate(20, 20, 8),   // left cell: one strong, one weak
      candidate(60, 10, 9), candidate(80, 30, 12)};  // right cell: weak only
  const auto kept = apply_cell_thresholds(candidates, area, 50, 20);
  ASSERT_EQ(kept.size(), 3u);
  EXPECT_EQ(kept[0].response, 25.0f);
  EXPECT_EQ(kept[1].response, 9.0f);
  EXPECT_EQ(kept[2].response, 12.0f);
}

TEST(Quadtree, IsolatedCandidatesWinOverADenseCluster) {
  std::vector<cv::KeyPoint> candidates;
  for (int i = 0; i < 1000; ++i) candidates.push_back(candidate(10.0f + (i % 40) * 0.5f, 10.0f + (i / 40) * 0.5f, 100.0f));
  std::vector<int> isolated;
  for (int gx = 0; gx < 4; ++gx) {
    for (int gy = 0; gy < 3; ++gy) {
      if (gx == 0 && gy == 0) continue;
      isolated.push_back(static_cast<int>(candidates.size()));
      candidates.push_back(candidate(50.0f + gx * 100.0f, 50.0f + gy * 100.0f, 1.0f));  // weak
    }
  }
  const auto picked = distribute_quadtree(candidates, cv::Rect2f(0, 0, 400, 300), 30);
  EXPECT_LE(picked.size(), 30u);
  EXPECT_GE(picked.size(), 25u);
  for (const int i : isolated) EXPECT_TRUE(std::binary_search(picked.begin(), picked.end(), i)) << i;
}

TEST(Quadtree, StrongestPerNodeAndAllWhenFew) {
  const std::vector<cv::KeyPoint> few = {candidate(1, 1, 1), candidate(2, 2, 2)};
  EXPECT_EQ(distribute_quadtree(few, cv::Rect2f(0, 0, 10, 10), 5), (std::vector<int>{0, 1}));
  // Identical positions cannot be split: one node, strongest kept.
  const std::vector<cv::KeyPoint> same = {candidate(5, 5, 1), candidate(5, 5, 9), candidate(5, 5, 3)};
  EXPECT_EQ(distribute_quadtree(same, cv::Rect2f(0, 0, 10, 10), 2), (std::vector<int>{1}));
  EXPECT_TRUE(distribute_quadtree(same, cv::Rect2f(0, 0, 10, 10), 0).empty());
}

TEST(Parabola, VertexAndDegenerateCases) {
  EXPECT_NEAR(*parabola_vertex_offset(4.0, 1.0, 4.0), 0.0, 1e-12);
  // Samples of (x - 0.3)^2 at -1, 0, 1.
  EXPECT_NEAR(*parabola_vertex_offset(1.69, 0.09, 0.49), 0.3, 1e-12);
  EXPECT_FALSE(parabola_vertex_offset(2.0, 2.0, 2.0).has_value());  // flat
  EXPECT_FALSE(parabola_vertex_offset(1.0, 3.0, 1.0).has_value());  // maximum, not minimum
  EXPECT_FALSE(parabola_vertex_offset(10.0, 1.0, -5.0).has_value());  // vertex beyond one sample
}

}  // namespace
}  // namespace sitepose::features::detail
