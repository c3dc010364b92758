#include "detail/distribution.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <opencv2/features2d.hpp>
#include <queue>

#include "sitepose/core/expected.hpp"

namespace sitepose::features::detail {

namespace {
// FAST fires only >= 3 px inside its input; non-maximum suppression needs
// the scores one pixel further out.
constexpr int kFastApronPx = 4;
}  // namespace

std::vector<cv::KeyPoint> detect_fast_per_cell(const cv::Mat& level_image, const cv::Rect& area, int cell_px,
                                               int ini_threshold, int min_threshold,
                                               const std::function<bool(float, float)>& is_masked) {
  const cv::Rect roi(area.x - kFastApronPx, area.y - kFastApronPx, area.width + 2 * kFastApronPx,
                     area.height + 2 * kFastApronPx);
  SITEPOSE_CHECK((roi & cv::Rect(0, 0, level_image.cols, level_image.rows)) == roi);
  const int n_cols = std::max(1, static_cast<int>(std::lround(double(area.width) / cell_px)));
  const int n_rows = std::max(1, static_cast<int>(std::lround(double(area.height) / cell_px)));
  // Integer cell edges, so "inside the cell" is exact for integer pixels.
  auto col_edge = [&](int c) {
    return area.x + static_cast<int>(std::lround(double(area.width) * c / n_cols));
  };
  auto row_edge = [&](int r) {
    return area.y + static_cast<int>(std::lround(double(area.height) * r / n_rows));
  };

  std::vector<cv::KeyPoint> found;
  cv::FAST(level_image(roi), found, ini_threshold, true, cv::FastFeatureDetector::TYPE_9_16);
  std::vector<cv::KeyPoint> kept;
  kept.reserve(found.size());
  std::vector<char> served(static_cast<size_t>(n_cols) * n_rows, 0);
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
    if (is_masked(kp.pt.x, kp.pt.y)) continue;
    served[row_of_y[y - area.y] * n_cols + col_of_x[x - area.x]] = 1;
    kept.push_back(kp);
  }

  std::vector<cv::KeyPoint> weak;
  for (int r = 0; r < n_rows; ++r) {
    for (int c = 0; c < n_cols; ++c) {
      if (served[r * n_cols + c]) continue;
      const cv::Rect cell(col_edge(c), row_edge(r), col_edge(c + 1) - col_edge(c),
                          row_edge(r + 1) - row_edge(r));
      if (cell.width <= 0 || cell.height <= 0) continue;
      const cv::Rect cell_roi(cell.x - kFastApronPx, cell.y - kFastApronPx, cell.width + 2 * kFastApronPx,
                              cell.height + 2 * kFastApronPx);
      cv::FAST(level_image(cell_roi), weak, min_threshold, true, cv::FastFeatureDetector::TYPE_9_16);
      for (cv::KeyPoint& kp : weak) {
        kp.pt.x += float(cell_roi.x);
        kp.pt.y += float(cell_roi.y);
        if (!cell.contains(cv::Point(static_cast<int>(kp.pt.x), static_cast<int>(kp.pt.y)))) continue;
        if (is_masked(kp.pt.x, kp.pt.y)) continue;
        kept.push_back(kp);
      }
    }
  }
  return kept;
}

namespace {

struct Node {
  float x0, y0, x1, y1;
  std::vector<int> members;
  float area() const { return (x1 - x0) * (y1 - y0); }
};

// Near-square root nodes side by side over `area`, so that splits in four
// keep cells near-square; each candidate joins the root that holds its x.
std::vector<Node> root_nodes(const std::vector<cv::KeyPoint>& candidates, const cv::Rect2f& area) {
  const int n_roots = std::max(1, static_cast<int>(std::lround(area.width / std::max(area.height, 1.0f))));
  const float root_w = area.width / n_roots;
  std::vector<Node> nodes;
  nodes.reserve(static_cast<std::size_t>(n_roots));
  for (int r = 0; r < n_roots; ++r) {
    nodes.push_back({area.x + r * root_w, area.y, area.x + (r + 1) * root_w, area.y + area.height, {}});
  }
  for (int i = 0; i < static_cast<int>(candidates.size()); ++i) {
    const float x = candidates[i].pt.x;
    const int r = std::clamp(static_cast<int>((x - area.x) / root_w), 0, n_roots - 1);
    nodes[r].members.push_back(i);
  }
  return nodes;
}

// The member with the strongest response (the lowest index among equals).
int strongest_member(const Node& node, const std::vector<cv::KeyPoint>& candidates) {
  int best = node.members.front();
  for (const int m : node.members) {
    if (candidates[m].response > candidates[best].response ||
        (candidates[m].response == candidates[best].response && m < best)) {
      best = m;
    }
  }
  return best;
}

// The strongest member of each final node, ascending. The last split may
// overshoot the target by up to three nodes: the weakest `overshoot` of its
// children are left out, so the spread elsewhere is untouched.
std::vector<int> strongest_of_final_nodes(const std::vector<Node>& nodes, const std::vector<int>& final_nodes,
                                          std::vector<int> last_children, int overshoot,
                                          const std::vector<cv::KeyPoint>& candidates) {
  std::vector<char> dropped(nodes.size(), 0);
  if (overshoot > 0) {
    std::sort(last_children.begin(), last_children.end(), [&](int a, int b) {
      return candidates[strongest_member(nodes[a], candidates)].response <
             candidates[strongest_member(nodes[b], candidates)].response;
    });
    for (int k = 0; k < overshoot; ++k) dropped[last_children[k]] = 1;
  }
  std::vector<int> picked;
  picked.reserve(final_nodes.size());
  for (const int id : final_nodes) {
    if (!dropped[id]) picked.push_back(strongest_member(nodes[id], candidates));
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

  std::vector<Node> nodes = root_nodes(candidates, area);
  const int n_roots = static_cast<int>(nodes.size());

  // Largest node first, so cells shrink evenly over the image (spatial
  // spread); among equal sizes the more crowded one, then creation order.
  auto larger_first = [&nodes](int a, int b) {
    const float area_a = nodes[a].area();
    const float area_b = nodes[b].area();
    if (area_a != area_b) return area_a < area_b;
    if (nodes[a].members.size() != nodes[b].members.size()) {
      return nodes[a].members.size() < nodes[b].members.size();
    }
    return a > b;
  };
  std::priority_queue<int, std::vector<int>, decltype(larger_first)> splittable(larger_first);
  std::vector<int> final_nodes;
  int n_nodes = 0;
  // A node narrower than a pixel cannot separate candidates any more.
  auto enqueue = [&](int id) {
    const Node& n = nodes[id];
    if (n.members.size() > 1 && n.x1 - n.x0 > 1.0f && n.y1 - n.y0 > 1.0f) {
      splittable.push(id);
    } else {
      final_nodes.push_back(id);
    }
  };
  for (int r = 0; r < n_roots; ++r) {
    if (nodes[r].members.empty()) continue;
    ++n_nodes;
    enqueue(r);
  }

  std::vector<int> last_children;
  while (n_nodes < target && !splittable.empty()) {
    const int id = splittable.top();
    splittable.pop();
    const Node parent = std::move(nodes[id]);
    const float xm = 0.5f * (parent.x0 + parent.x1);
    const float ym = 0.5f * (parent.y0 + parent.y1);
    Node children[4] = {{parent.x0, parent.y0, xm, ym, {}},
                        {xm, parent.y0, parent.x1, ym, {}},
                        {parent.x0, ym, xm, parent.y1, {}},
                        {xm, ym, parent.x1, parent.y1, {}}};
    for (const int m : parent.members) {
      const cv::Point2f& p = candidates[m].pt;
      children[(p.x < xm ? 0 : 1) + (p.y < ym ? 0 : 2)].members.push_back(m);
    }
    --n_nodes;
    last_children.clear();
    for (Node& child : children) {
      if (child.members.empty()) continue;
      ++n_nodes;
      nodes.push_back(std::move(child));
      last_children.push_back(static_cast<int>(nodes.size()) - 1);
      enqueue(last_children.back());
    }
  }
  while (!splittable.empty()) {
    final_nodes.push_back(splittable.top());
    splittable.pop();
  }

  return strongest_of_final_nodes(nodes, final_nodes, std::move(last_children), n_nodes - target, candidates);
}

}  // namespace sitepose::features::detail
