#include "sitepose/map/keypoint_grid.hpp"

#include <algorithm>
#include <cmath>

namespace sitepose::map {

KeypointGrid::KeypointGrid(int width, int height, const std::vector<Eigen::Vector2d>& uv_px,
                           const std::vector<int>& octave, int cell_px)
    : cell_px_(cell_px),
      cols_(std::max(1, (width + cell_px - 1) / cell_px)),
      rows_(std::max(1, (height + cell_px - 1) / cell_px)),
      cells_(static_cast<std::size_t>(cols_ * rows_)),
      uv_px_(uv_px),
      octave_(octave) {
  for (int i = 0; i < static_cast<int>(uv_px_.size()); ++i) {
    const int cx = std::clamp(static_cast<int>(uv_px_[i].x() / cell_px_), 0, cols_ - 1);
    const int cy = std::clamp(static_cast<int>(uv_px_[i].y() / cell_px_), 0, rows_ - 1);
    cells_[cy * cols_ + cx].push_back(i);
  }
}

std::vector<int> KeypointGrid::query(const Eigen::Vector2d& uv, double radius_px, int min_level,
                                     int max_level) const {
  std::vector<int> result;
  if (cells_.empty()) return result;
  const int x0 = std::max(0, static_cast<int>(std::floor((uv.x() - radius_px) / cell_px_)));
  const int x1 = std::min(cols_ - 1, static_cast<int>(std::floor((uv.x() + radius_px) / cell_px_)));
  const int y0 = std::max(0, static_cast<int>(std::floor((uv.y() - radius_px) / cell_px_)));
  const int y1 = std::min(rows_ - 1, static_cast<int>(std::floor((uv.y() + radius_px) / cell_px_)));
  const double r2 = radius_px * radius_px;
  for (int y = y0; y <= y1; ++y) {
    for (int x = x0; x <= x1; ++x) {
      for (int i : cells_[y * cols_ + x]) {
        if (min_level >= 0 && octave_[i] < min_level) continue;
        if (max_level >= 0 && octave_[i] > max_level) continue;
        if ((uv_px_[i] - uv).squaredNorm() <= r2) result.push_back(i);
      }
    }
  }
  return result;
}

}  // namespace sitepose::map
