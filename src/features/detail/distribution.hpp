#pragma once
// Candidate selection helpers of the ORB extractor (private to features).

#include <functional>
#include <opencv2/core.hpp>
#include <span>
#include <vector>

namespace sitepose::features::detail {

// How candidates are split between the sides of a mask: side_of(x, y)
// (level pixels) is the side of a candidate in [0, n_sides), or -1 to drop
// it; may_hold(cell, side) is false only where the cell (level pixels)
// certainly holds no pixel of that side, which spares the fallback search
// there (the result is the same: it could only find dropped candidates).
struct CandidateSides {
  int n_sides = 1;
  std::function<int(float, float)> side_of;
  std::function<bool(const cv::Rect&, int)> may_hold;
};

// FAST candidates of one level with a per-cell threshold ladder, per side:
// FAST at thresholds[0] over `area` (level pixels, >= 4 px inside the
// image), then, for each grid cell (sides close to cell_px) left without a
// candidate of a side, FAST at thresholds[1] on that cell alone for that
// side, then at thresholds[2] for the sides still without one, and so on
// (thresholds strictly descending). Non-maximum suppression is on; the cell
// is searched with a 4-px apron so suppression sees the same neighbours as a
// whole-image run. A side is judged on its own candidates only, so masked
// strong corners make an unmasked cell fall back. out[side] holds the side's
// candidates, the whole-area ones first in FAST's order, then the fallback
// ones cell by cell (row-major), so each side gets what a run for that side
// alone gets. ORB-SLAM2's rule is the ladder {iniThFAST, minThFAST}.
std::vector<std::vector<cv::KeyPoint>> detect_fast_per_cell(const cv::Mat& level_image, const cv::Rect& area,
                                                            int cell_px, std::span<const int> thresholds,
                                                            const CandidateSides& sides);

// Spreads a selection of at most `target` candidates over `area`: the area
// is cut into near-square root nodes, then the largest node holding more
// than one candidate is split in four (empty children dropped) until there
// are `target` nodes or nothing left to split; each node contributes its
// strongest candidate (ties: lowest index). If the last split overshoots,
// its weakest children are dropped (the spread elsewhere stays). Returns
// indices into `candidates`, sorted.
std::vector<int> distribute_quadtree(const std::vector<cv::KeyPoint>& candidates, const cv::Rect2f& area,
                                     int target);

// First, for each hint (level pixels, in order), the strongest candidate
// within kHintRadiusPx not taken yet, up to half of `target`; then
// distribute_quadtree over the other candidates for the rest of `target`.
// Returns indices into `candidates`, sorted. Without hints it is
// distribute_quadtree.
inline constexpr float kHintRadiusPx = 2.0f;
std::vector<int> keep_hinted_then_distribute(const std::vector<cv::KeyPoint>& candidates,
                                             const cv::Rect2f& area, int target,
                                             const std::vector<cv::Point2f>& hints);

}  // namespace sitepose::features::detail
