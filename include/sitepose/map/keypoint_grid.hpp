#pragma once
// Cell grid over the keypoints of one image, for the projection searches of
// the tracker and the local mapper (candidates near a predicted pixel).
// Immutable after construction; safe to query from several threads.

#include <Eigen/Core>
#include <vector>

#include "sitepose/map/map_types.hpp"

namespace sitepose::map {

class KeypointGrid {
 public:
  KeypointGrid() = default;
  // uv_px: level-0 pixel of each keypoint; octave: its level.
  KeypointGrid(int width, int height, const std::vector<Eigen::Vector2d>& uv_px,
               const std::vector<int>& octave, int cell_px = 32);

  // Indices of keypoints within radius_px of uv (square window, then exact
  // circle), with octave in [min_level, max_level] (-1 = no bound).
  std::vector<int> query(const Eigen::Vector2d& uv, double radius_px, int min_level = -1,
                         int max_level = -1) const;

 private:
  int cell_px_ = 32;
  int cols_ = 0;
  int rows_ = 0;
  std::vector<std::vector<int>> cells_;
  std::vector<Eigen::Vector2d> uv_px_;
  std::vector<int> octave_;
};

}  // namespace sitepose::map
