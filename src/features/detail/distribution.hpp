#pragma once
// Candidate selection helpers of the ORB extractor (private to features).

#include <functional>
#include <opencv2/core.hpp>
#include <vector>

namespace sitepose::features::detail {

// FAST candidates of one level with a per-cell threshold fallback: FAST at
// ini_threshold over `area` (level pixels, >= 4 px inside the image), then,
// for each grid cell (sides close to cell_px) left without an unmasked
// candidate, FAST at min_threshold on that cell alone. Non-maximum
// suppression is on; the cell is searched with a 4-px apron so suppression
// sees the same neighbours as a whole-image run. Candidates for which
// is_masked(x, y) is true (level pixels) are dropped before a cell counts
// as served, so masked strong corners make a cell fall back.
std::vector<cv::KeyPoint> detect_fast_per_cell(const cv::Mat& level_image, const cv::Rect& area,
                                               int cell_px, int ini_threshold, int min_threshold,
                                               const std::function<bool(float, float)>& is_masked);

// Spreads a selection of at most `target` candidates over `area`: the area
// is cut into near-square root nodes, then the largest node holding more
// than one candidate is split in four (empty children dropped) until there
// are `target` nodes or nothing left to split; each node contributes its
// strongest candidate (ties: lowest index). If the last split overshoots,
// its weakest children are dropped (the spread elsewhere stays). Returns
// indices into `candidates`, sorted.
std::vector<int> distribute_quadtree(const std::vector<cv::KeyPoint>& candidates,
                                     const cv::Rect2f& area, int target);

}  // namespace sitepose::features::detail
