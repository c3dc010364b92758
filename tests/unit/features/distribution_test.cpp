#include "detail/distribution.hpp"
#include "detail/subpixel.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <opencv2/features2d.hpp>
#include <set>

#include "sitepose/testing/images.hpp"

namespace sitepose::features::detail {
namespace {

cv::KeyPoint candidate(float x, float y, float response) { return cv::KeyPoint(x, y, 7.0f, -1.0f, response); }

using PointSet = std::set<std::pair<int, int>>;

PointSet positions(const std::vector<cv::KeyPoint>& kps, const cv::Rect& inside) {
  PointSet out;
  for (const auto& kp : kps) {
    const cv::Point p(int(kp.pt.x), int(kp.pt.y));
    if (inside.contains(p)) out.insert({p.x, p.y});
  }
  return out;
}

// One side: every candidate kept unless `masked` says so; every cell may hold it.
template <typename Masked>
std::vector<cv::KeyPoint> detect_unmasked(const cv::Mat& image, const cv::Rect& area, int cell_px,
                                          Masked masked) {
  CandidateSides sides;
  sides.side_of = [&](float x, float y) { return masked(x, y) ? -1 : 0; };
  sides.may_hold = [](const cv::Rect&, int) { return true; };
  return detect_fast_per_cell(image, area, cell_px, std::vector<int>{20, 7}, sides)[0];
}

const auto kNothingMasked = [](float, float) { return false; };

TEST(CellThresholds, StrongCellsMatchWholeImageFast) {
  // Contrast everywhere: every cell is served at the initial threshold, so
  // the result is exactly FAST(20) over the area.
  const cv::Mat image = testing::make_texture(cv::Size(400, 300), 11);
  const cv::Rect area(16, 16, 368, 268);
  const auto kept = detect_unmasked(image, area, 35, kNothingMasked);
  std::vector<cv::KeyPoint> whole;
  cv::FAST(image, whole, 20, true);
  ASSERT_GT(kept.size(), 500u);
  EXPECT_EQ(positions(kept, area), positions(whole, area));
}

TEST(CellThresholds, WeakCellsFallBackToTheMinimumThreshold) {
  // Left half strong, right half so faint that nothing passes 20: the right
  // half must hold exactly what FAST(7) finds there over the whole image
  // (the per-cell search has an apron, so suppression matches).
  const cv::Mat texture = testing::make_texture(cv::Size(400, 300), 12);
  const cv::Mat image = testing::with_contrast(texture, cv::Rect(0, 0, 200, 300), 0.1);
  const cv::Rect area(16, 16, 368, 268);
  const auto kept = detect_unmasked(image, area, 46, kNothingMasked);
  std::vector<cv::KeyPoint> strong;
  std::vector<cv::KeyPoint> weak;
  cv::FAST(image, strong, 20, true);
  cv::FAST(image, weak, 7, true);
  const cv::Rect left_cells(16, 16, 184, 268);    // 4 cells of 46 px
  const cv::Rect right_cells(200, 16, 184, 268);  // 4 cells of 46 px
  ASSERT_TRUE(positions(strong, right_cells).empty());
  ASSERT_GT(positions(weak, right_cells).size(), 200u);
  EXPECT_EQ(positions(kept, right_cells), positions(weak, right_cells));
  EXPECT_EQ(positions(kept, left_cells), positions(strong, left_cells));
}

TEST(CellThresholds, EachCellTakesTheHighestRungOfTheLadderThatFindsACorner) {
  // Three bands of falling contrast under a ladder {40, 20, 7}: cells of the
  // strong band keep FAST(40) alone, cells where nothing reaches 40 the
  // FAST(20) corners, cells where nothing reaches 20 the FAST(7) ones; each
  // as a whole-image run at that threshold finds them there.
  const cv::Mat texture = testing::make_texture(cv::Size(400, 300), 14);
  cv::Mat image = testing::with_contrast(texture, cv::Rect(0, 0, 150, 300), 0.22);
  testing::with_contrast(texture, cv::Rect(), 0.1).colRange(288, 400).copyTo(image.colRange(288, 400));
  const cv::Rect area(16, 16, 368, 268);  // 8 x 6 cells of 46 px, column edges 16, 62, ..., 384
  const cv::Rect strong_cells(16, 16, 138, 268);
  const cv::Rect middle_cells(154, 16, 138, 268);
  const cv::Rect faint_cells(292, 16, 92, 268);
  std::vector<cv::KeyPoint> at40;
  std::vector<cv::KeyPoint> at20;
  std::vector<cv::KeyPoint> at7;
  cv::FAST(image, at40, 40, true);
  cv::FAST(image, at20, 20, true);
  cv::FAST(image, at7, 7, true);
  ASSERT_GT(positions(at40, strong_cells).size(), 100u);
  ASSERT_LT(positions(at40, strong_cells).size(), positions(at20, strong_cells).size());
  ASSERT_TRUE(positions(at40, middle_cells).empty());
  ASSERT_GT(positions(at20, middle_cells).size(), 50u);
  ASSERT_TRUE(positions(at20, faint_cells).empty());
  ASSERT_GT(positions(at7, faint_cells).size(), 50u);

  CandidateSides sides;
  sides.side_of = [](float, float) { return 0; };
  sides.may_hold = [](const cv::Rect&, int) { return true; };
  const auto kept = detect_fast_per_cell(image, area, 46, std::vector<int>{40, 20, 7}, sides)[0];
  EXPECT_EQ(positions(kept, strong_cells), positions(at40, strong_cells));
  EXPECT_EQ(positions(kept, middle_cells), positions(at20, middle_cells));
  EXPECT_EQ(positions(kept, faint_cells), positions(at7, faint_cells));
}

TEST(CellThresholds, MaskedStrongCornersMakeTheCellFallBack) {
  const cv::Mat image = testing::make_texture(cv::Size(200, 200), 13);
  const cv::Rect area(16, 16, 168, 168);
  // Mask every strong candidate: all cells fall back, and no masked pixel
  // survives.
  std::vector<cv::KeyPoint> strong;
  cv::FAST(image, strong, 20, true);
  const PointSet strong_set = positions(strong, area);
  const auto masked = [&](float x, float y) { return strong_set.count({int(x), int(y)}) > 0; };
  const auto kept = detect_unmasked(image, area, 42, masked);
  ASSERT_FALSE(kept.empty());
  int weak_only = 0;
  for (const auto& kp : kept) {
    EXPECT_FALSE(masked(kp.pt.x, kp.pt.y));
    weak_only += kp.response < 20.0f;
  }
  EXPECT_GT(weak_only, 0);
}

TEST(Quadtree, IsolatedCandidatesWinOverADenseCluster) {
  std::vector<cv::KeyPoint> candidates;
  for (int i = 0; i < 1000; ++i)
    candidates.push_back(candidate(10.0f + (i % 40) * 0.5f, 10.0f + (i / 40) * 0.5f, 100.0f));
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

// A 20 x 20 lattice of candidates 2.5 px apart with responses that vary
// from point to point.
std::vector<cv::KeyPoint> lattice() {
  std::vector<cv::KeyPoint> out;
  for (int i = 0; i < 400; ++i) {
    out.push_back(candidate(10.0f + (i % 20) * 2.5f, 10.0f + (i / 20) * 2.5f, float((i * 37) % 101)));
  }
  return out;
}

TEST(HintedSelection, WithoutHintsItIsTheQuadtree) {
  const auto candidates = lattice();
  const cv::Rect2f area(0, 0, 70, 70);
  EXPECT_EQ(keep_hinted_then_distribute(candidates, area, 25, {}), distribute_quadtree(candidates, area, 25));
}

TEST(HintedSelection, KeepsTheCandidateAtEachHintThenSpreadsTheRest) {
  const auto candidates = lattice();
  const cv::Rect2f area(0, 0, 70, 70);
  const std::vector<int> plain = distribute_quadtree(candidates, area, 20);
  // Hint at candidates the spread did not pick, 0.3 px off each way (the
  // lattice neighbours are then more than the 2-px radius away).
  std::vector<int> wanted;
  std::vector<cv::Point2f> hints;
  for (int i = 0; i < static_cast<int>(candidates.size()) && wanted.size() < 5; i += 41) {
    if (std::binary_search(plain.begin(), plain.end(), i)) continue;
    wanted.push_back(i);
    hints.push_back(candidates[i].pt + cv::Point2f(0.3f, 0.3f));
  }
  ASSERT_EQ(wanted.size(), 5u);
  const std::vector<int> picked = keep_hinted_then_distribute(candidates, area, 20, hints);
  EXPECT_EQ(picked.size(), 20u);
  EXPECT_TRUE(std::is_sorted(picked.begin(), picked.end()));
  EXPECT_EQ(std::set<int>(picked.begin(), picked.end()).size(), picked.size());
  for (const int i : wanted) EXPECT_TRUE(std::binary_search(picked.begin(), picked.end(), i)) << i;
  // A hint with no candidate within the radius keeps nothing.
  const std::vector<int> far = keep_hinted_then_distribute(candidates, area, 20, {cv::Point2f(65.0f, 65.0f)});
  EXPECT_EQ(far, plain);
}

TEST(HintedSelection, HintsTakeAtMostHalfTheBudget) {
  const auto candidates = lattice();
  std::vector<cv::Point2f> hints;
  for (const auto& kp : candidates) hints.push_back(kp.pt);  // a hint at every candidate
  const std::vector<int> picked =
      keep_hinted_then_distribute(candidates, cv::Rect2f(0, 0, 70, 70), 30, hints);
  EXPECT_EQ(picked.size(), 30u);
  // The first 15 hints are kept (in hint order); the spread adds 15 more.
  int first_fifteen = 0;
  for (int i = 0; i < 15; ++i) first_fifteen += std::binary_search(picked.begin(), picked.end(), i) ? 1 : 0;
  EXPECT_EQ(first_fifteen, 15);
}

TEST(Parabola, VertexAndDegenerateCases) {
  EXPECT_NEAR(*parabola_vertex_offset(4.0, 1.0, 4.0), 0.0, 1e-12);
  // Samples of (x - 0.3)^2 at -1, 0, 1.
  EXPECT_NEAR(*parabola_vertex_offset(1.69, 0.09, 0.49), 0.3, 1e-12);
  EXPECT_FALSE(parabola_vertex_offset(2.0, 2.0, 2.0).has_value());    // flat
  EXPECT_FALSE(parabola_vertex_offset(1.0, 3.0, 1.0).has_value());    // maximum, not minimum
  EXPECT_FALSE(parabola_vertex_offset(10.0, 1.0, -5.0).has_value());  // vertex beyond one sample
}

}  // namespace
}  // namespace sitepose::features::detail
