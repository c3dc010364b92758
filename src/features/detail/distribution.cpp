#include "detail/distribution.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <opencv2/features2d.hpp>
#include <queue>
#include <span>

#include "sitepose/core/expected.hpp"

namespace sitepose::features::detail {

namespace {
// FAST fires only >= 3 px inside its input; non-maximum suppression needs
// the scores one pixel further out.
constexpr int kFastApronPx = 4;

// The ladder's later rungs in one cell: FAST at thresholds[1], [2], ...
// on the cell with its apron, until each side in `wanted` has a candidate
// there; appends them to kept[side]. `wanted` is the caller's scratch.
void fall_back_in_cell(const cv::Mat& level_image, const cv::Rect& cell, std::span<const int> thresholds,
                       const CandidateSides& sides, std::vector<char>& wanted,
                       std::vector<std::vector<cv::KeyPoint>>& kept) {
  const auto none_wanted = [&] { return std::find(wanted.begin(), wanted.end(), 1) == wanted.end(); };
  if (none_wanted()) return;  // most cells: served by the first pass
  const cv::Rect cell_roi(cell.x - kFastApronPx, cell.y - kFastApronPx, cell.width + 2 * kFastApronPx,
                          cell.height + 2 * kFastApronPx);
  std::vector<cv::KeyPoint> found;
  std::vector<char> got(wanted.size());
  for (std::size_t step = 1; step < thresholds.size() && !none_wanted(); ++step) {
    cv::FAST(level_image(cell_roi), found, thresholds[step], true, cv::FastFeatureDetector::TYPE_9_16);
    std::fill(got.begin(), got.end(), 0);
    for (cv::KeyPoint& kp : found) {
      kp.pt.x += float(cell_roi.x);
      kp.pt.y += float(cell_roi.y);
      if (!cell.contains(cv::Point(static_cast<int>(kp.pt.x), static_cast<int>(kp.pt.y)))) continue;
      const int side = sides.side_of(kp.pt.x, kp.pt.y);
      if (side < 0 || !wanted[side]) continue;
      kept[side].push_back(kp);
      got[side] = 1;
    }
    for (std::size_t side = 0; side < wanted.size(); ++side) {
      if (got[side] != 0) wanted[side] = 0;
    }
  }
}

}  // namespace

std::vector<std::vector<cv::KeyPoint>> detect_fast_per_cell(const cv::Mat& level_image, const cv::Rect& area,
                                                            int cell_px, std::span<const int> thresholds,
                                                            const CandidateSides& sides) {
  SITEPOSE_CHECK(sides.n_sides >= 1 && sides.side_of && sides.may_hold);
  SITEPOSE_CHECK(!thresholds.empty() && std::is_sorted(thresholds.rbegin(), thresholds.rend()) &&
                 std::adjacent_find(thresholds.begin(), thresholds.end()) == thresholds.end());
  const cv::Rect roi(area.x - kFastApronPx, area.y - kFastApronPx, area.width + 2 * kFastApronPx,
                     area.height + 2 * kFastApronPx);
  SITEPOSE_CHECK((roi & cv::Rect(0, 0, level_image.cols, level_image.rows)) == roi);
  const int n_cols = std::max(1, static_cast<int>(std::lround(double(area.width) / cell_px)));
  const int n_rows = std::max(1, static_cast<int>(std::lround(double(area.height) / cell_px)));
  const int n_cells = n_cols * n_rows;
  // Integer cell edges, so "inside the cell" is exact for integer pixels.
  auto col_edge = [&](int c) {
    return area.x + static_cast<int>(std::lround(double(area.width) * c / n_cols));
  };
  auto row_edge = [&](int r) {
    return area.y + static_cast<int>(std::lround(double(area.height) * r / n_rows));
  };

  std::vector<cv::KeyPoint> found;
  cv::FAST(level_image(roi), found, thresholds.front(), true, cv::FastFeatureDetector::TYPE_9_16);
  std::vector<std::vector<cv::KeyPoint>> kept(sides.n_sides);
  // served[side * n_cells + cell]
  std::vector<char> served(static_cast<size_t>(sides.n_sides) * n_cells, 0);
  std::vector<int> col_of_x(area.width);
  for (int c = 0; c < n_cols; ++c) {
    for (int x = col_edge(c); x < col_edge(c + 1); ++x) col_of_x[x - area.x] = c;
  }
  std::vector<int> row_of_y(area.height);
  for (int r = 0; r < n_rows; ++r) {
    for (int y = row_edge(r); y < row_edge(r + 1); ++y) row_of_y[y - area.y] = r;
  }
  for (cv::KeyPoint& kp : found) {
    kp.pt.x += float(roi.x);
    kp.pt.y += float(roi.y);
    const int x = static_cast<int>(kp.pt.x);
    const int y = static_cast<int>(kp.pt.y);
    if (x < area.x || y < area.y || x >= area.br().x || y >= area.br().y) continue;
    const int side = sides.side_of(kp.pt.x, kp.pt.y);
    if (side < 0) continue;
    served[static_cast<size_t>(side) * n_cells + row_of_y[y - area.y] * n_cols + col_of_x[x - area.x]] = 1;
    kept[side].push_back(kp);
  }

  std::vector<char> wanted(sides.n_sides);
  for (int r = 0; r < n_rows; ++r) {
    for (int c = 0; c < n_cols; ++c) {
      const cv::Rect cell(col_edge(c), row_edge(r), col_edge(c + 1) - col_edge(c),
                          row_edge(r + 1) - row_edge(r));
      if (cell.width <= 0 || cell.height <= 0) continue;
      for (int side = 0; side < sides.n_sides; ++side) {
        wanted[side] =
            !served[static_cast<size_t>(side) * n_cells + r * n_cols + c] && sides.may_hold(cell, side);
      }
      fall_back_in_cell(level_image, cell, thresholds, sides, wanted, kept);
    }
  }
  return kept;
}

namespace {

// A quadtree node: a rectangle and its candidates, the range
// [begin, end) of QuadTree::members (which splits reorder in place, so no
// node allocates).
struct Node {
  float x0, y0, x1, y1;
  int begin, end;
  int size() const { return end - begin; }
  float area() const { return (x1 - x0) * (y1 - y0); }
};

class QuadTree {
 public:
  explicit QuadTree(const std::vector<cv::KeyPoint>& candidates) : candidates_(candidates) {}

  // Near-square root nodes side by side over `area`, so that splits in four
  // keep cells near-square; each candidate joins the root that holds its x.
  // Returns the number of roots (node ids 0 .. n - 1, empty ones included).
  int add_roots(const cv::Rect2f& area);
  // Splits node `id` in four at its centre; appends the non-empty children
  // (in order top-left, top-right, bottom-left, bottom-right) and returns
  // their ids through `children`.
  void split(int id, std::vector<int>& children);
  // The member with the strongest response (the lowest index among equals).
  int strongest_member(int id) const;

  const Node& node(int id) const { return nodes_[id]; }

 private:
  const std::vector<cv::KeyPoint>& candidates_;
  std::vector<Node> nodes_;
  std::vector<int> members_;
  std::vector<int> scratch_;
};

int QuadTree::add_roots(const cv::Rect2f& area) {
  const int n_roots = std::max(1, static_cast<int>(std::lround(area.width / std::max(area.height, 1.0f))));
  const float root_w = area.width / n_roots;
  const int n = static_cast<int>(candidates_.size());
  // Counting sort by root: members_ holds each root's candidates in one range.
  std::vector<int> root_of(n);
  std::vector<int> count(n_roots + 1, 0);
  for (int i = 0; i < n; ++i) {
    root_of[i] = std::clamp(static_cast<int>((candidates_[i].pt.x - area.x) / root_w), 0, n_roots - 1);
    ++count[root_of[i] + 1];
  }
  std::partial_sum(count.begin(), count.end(), count.begin());
  for (int r = 0; r < n_roots; ++r) {
    nodes_.push_back({area.x + r * root_w, area.y, area.x + (r + 1) * root_w, area.y + area.height, count[r],
                      count[r + 1]});
  }
  members_.resize(n);
  for (int i = 0; i < n; ++i) members_[count[root_of[i]]++] = i;
  return n_roots;
}

void QuadTree::split(int id, std::vector<int>& children) {
  const Node parent = nodes_[id];
  const float xm = 0.5f * (parent.x0 + parent.x1);
  const float ym = 0.5f * (parent.y0 + parent.y1);
  const Node quadrants[4] = {{parent.x0, parent.y0, xm, ym, 0, 0},
                             {xm, parent.y0, parent.x1, ym, 0, 0},
                             {parent.x0, ym, xm, parent.y1, 0, 0},
                             {xm, ym, parent.x1, parent.y1, 0, 0}};
  auto quadrant_of = [&](int m) {
    const cv::Point2f& p = candidates_[m].pt;
    return (p.x < xm ? 0 : 1) + (p.y < ym ? 0 : 2);
  };
  int start[5] = {0, 0, 0, 0, 0};
  for (int k = parent.begin; k < parent.end; ++k) ++start[quadrant_of(members_[k]) + 1];
  for (int q = 0; q < 4; ++q) start[q + 1] += start[q];
  scratch_.resize(parent.size());
  int fill[4] = {start[0], start[1], start[2], start[3]};
  for (int k = parent.begin; k < parent.end; ++k) scratch_[fill[quadrant_of(members_[k])]++] = members_[k];
  std::copy(scratch_.begin(), scratch_.end(), members_.begin() + parent.begin);
  children.clear();
  for (int q = 0; q < 4; ++q) {
    if (start[q + 1] == start[q]) continue;
    Node child = quadrants[q];
    child.begin = parent.begin + start[q];
    child.end = parent.begin + start[q + 1];
    nodes_.push_back(child);
    children.push_back(static_cast<int>(nodes_.size()) - 1);
  }
}

int QuadTree::strongest_member(int id) const {
  const Node& n = nodes_[id];
  int best = members_[n.begin];
  for (int k = n.begin + 1; k < n.end; ++k) {
    const int m = members_[k];
    if (candidates_[m].response > candidates_[best].response ||
        (candidates_[m].response == candidates_[best].response && m < best)) {
      best = m;
    }
  }
  return best;
}

// The strongest member of each final node, ascending. The last split may
// overshoot the target by up to three nodes: the weakest `overshoot` of its
// children are left out, so the spread elsewhere is untouched.
std::vector<int> strongest_of_final_nodes(const QuadTree& tree, const std::vector<int>& final_nodes,
                                          std::vector<int> last_children, int overshoot,
                                          const std::vector<cv::KeyPoint>& candidates) {
  std::vector<int> dropped;
  if (overshoot > 0) {
    std::sort(last_children.begin(), last_children.end(), [&](int a, int b) {
      return candidates[tree.strongest_member(a)].response < candidates[tree.strongest_member(b)].response;
    });
    dropped.assign(last_children.begin(), last_children.begin() + overshoot);
  }
  std::vector<int> picked;
  picked.reserve(final_nodes.size());
  for (const int id : final_nodes) {
    if (std::find(dropped.begin(), dropped.end(), id) == dropped.end())
      picked.push_back(tree.strongest_member(id));
  }
  std::sort(picked.begin(), picked.end());
  return picked;
}

}  // namespace

std::vector<int> distribute_quadtree(const std::vector<cv::KeyPoint>& candidates, const cv::Rect2f& area,
                                     int target) {
  std::vector<int> picked;
  if (target <= 0 || candidates.empty()) return picked;
  if (static_cast<int>(candidates.size()) <= target) {
    picked.resize(candidates.size());
    std::iota(picked.begin(), picked.end(), 0);
    return picked;
  }

  QuadTree tree(candidates);
  const int n_roots = tree.add_roots(area);

  // Largest node first, so cells shrink evenly over the image (spatial
  // spread); among equal sizes the more crowded one, then creation order.
  auto larger_first = [&tree](int a, int b) {
    const float area_a = tree.node(a).area();
    const float area_b = tree.node(b).area();
    if (area_a != area_b) return area_a < area_b;
    if (tree.node(a).size() != tree.node(b).size()) return tree.node(a).size() < tree.node(b).size();
    return a > b;
  };
  std::priority_queue<int, std::vector<int>, decltype(larger_first)> splittable(larger_first);
  std::vector<int> final_nodes;
  int n_nodes = 0;
  // A node narrower than a pixel cannot separate candidates any more.
  auto enqueue = [&](int id) {
    const Node& n = tree.node(id);
    if (n.size() > 1 && n.x1 - n.x0 > 1.0f && n.y1 - n.y0 > 1.0f) {
      splittable.push(id);
    } else {
      final_nodes.push_back(id);
    }
  };
  for (int r = 0; r < n_roots; ++r) {
    if (tree.node(r).size() == 0) continue;
    ++n_nodes;
    enqueue(r);
  }

  std::vector<int> last_children;
  while (n_nodes < target && !splittable.empty()) {
    const int id = splittable.top();
    splittable.pop();
    tree.split(id, last_children);
    n_nodes += static_cast<int>(last_children.size()) - 1;
    for (const int child : last_children) enqueue(child);
  }
  while (!splittable.empty()) {
    final_nodes.push_back(splittable.top());
    splittable.pop();
  }

  return strongest_of_final_nodes(tree, final_nodes, std::move(last_children), n_nodes - target, candidates);
}

std::vector<int> keep_hinted_then_distribute(const std::vector<cv::KeyPoint>& candidates,
                                             const cv::Rect2f& area, int target,
                                             const std::vector<cv::Point2f>& hints) {
  if (hints.empty() || candidates.empty() || target <= 0)
    return distribute_quadtree(candidates, area, target);
  // Candidates bucketed by cells of twice the hint radius: a hint looks at
  // the 3 x 3 cells around its own (cells of one radius would do too, at
  // four times the cells to clear each level and frame).
  const float cell = 2.0f * kHintRadiusPx;
  const int n_cols = std::max(1, static_cast<int>(std::ceil(area.width / cell)) + 1);
  const int n_rows = std::max(1, static_cast<int>(std::ceil(area.height / cell)) + 1);
  auto cell_of = [&](const cv::Point2f& p, int& c, int& r) {
    c = static_cast<int>(std::floor((p.x - area.x) / cell));
    r = static_cast<int>(std::floor((p.y - area.y) / cell));
    return c >= 0 && r >= 0 && c < n_cols && r < n_rows;
  };
  std::vector<int> first(static_cast<size_t>(n_cols) * n_rows, -1);
  std::vector<int> next(candidates.size(), -1);
  for (int i = static_cast<int>(candidates.size()) - 1; i >= 0; --i) {
    int c = 0;
    int r = 0;
    if (!cell_of(candidates[i].pt, c, r)) continue;
    next[i] = first[r * n_cols + c];
    first[r * n_cols + c] = i;
  }
  const int max_kept = target / 2;
  std::vector<char> taken(candidates.size(), 0);
  std::vector<int> kept;
  for (const cv::Point2f& hint : hints) {
    if (static_cast<int>(kept.size()) >= max_kept) break;
    int hc = 0;
    int hr = 0;
    cell_of(hint, hc, hr);
    int best = -1;
    for (int r = hr - 1; r <= hr + 1; ++r) {
      for (int c = hc - 1; c <= hc + 1; ++c) {
        if (r < 0 || c < 0 || r >= n_rows || c >= n_cols) continue;
        for (int i = first[r * n_cols + c]; i >= 0; i = next[i]) {
          if (taken[i]) continue;
          const cv::Point2f d = candidates[i].pt - hint;
          if (d.x * d.x + d.y * d.y > kHintRadiusPx * kHintRadiusPx) continue;
          if (best < 0 || candidates[i].response > candidates[best].response ||
              (candidates[i].response == candidates[best].response && i < best)) {
            best = i;
          }
        }
      }
    }
    if (best < 0) continue;
    taken[best] = 1;
    kept.push_back(best);
  }
  std::vector<cv::KeyPoint> rest;
  std::vector<int> rest_index;
  rest.reserve(candidates.size() - kept.size());
  for (int i = 0; i < static_cast<int>(candidates.size()); ++i) {
    if (taken[i]) continue;
    rest.push_back(candidates[i]);
    rest_index.push_back(i);
  }
  std::vector<int> picked = kept;
  for (const int j : distribute_quadtree(rest, area, target - static_cast<int>(kept.size()))) {
    picked.push_back(rest_index[j]);
  }
  std::sort(picked.begin(), picked.end());
  return picked;
}

}  // namespace sitepose::features::detail
