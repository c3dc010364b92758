#pragma once
// Candidate selection helpers of the ORB extractor (private to features).

#include <opencv2/core.hpp>
#include <vector>

namespace sitepose::features::detail {

// Per-cell FAST threshold with fallback. `candidates` come from one FAST pass
// at the minimum threshold with non-maximum suppression; a cell keeps those
// whose score reaches `ini_threshold` and, when none does, all of them. This
// equals running FAST per cell at ini_threshold and again at the minimum
// when the first run finds nothing: OpenCV's FAST score (the largest
// threshold at which the pixel is still a corner) does not depend on the
// threshold used, and suppression only compares scores, so weaker
// neighbours cannot suppress a corner that passes the higher threshold.
// Cells tile `area` (level pixels) with sides close to cell_px.
std::vector<cv::KeyPoint> apply_cell_thresholds(const std::vector<cv::KeyPoint>& candidates,
                                                 const cv::Rect& area, int cell_px,
                                                 int ini_threshold);

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
