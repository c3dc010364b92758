#pragma once
// A frame after feature extraction: everything the two tracking passes need,
// computed once (ARCHITECTURE.md "Inside the track stage"). Immutable after
// Tracker::prepare(); both passes read it.

#include <cstdint>
#include <vector>

#include "sitepose/features/stereo_extractor.hpp"
#include "sitepose/map/keypoint_grid.hpp"

namespace sitepose::tracking {

struct PrepareTimings {
  double extract_left_ms = 0.0;
  double extract_right_ms = 0.0;
  double stereo_match_ms = 0.0;
  double mask_overrun_ms = 0.0;  // features::StereoTimings::mask_overrun_ms
  double total_ms = 0.0;
};

struct PreparedFrame {
  std::int64_t seq = 0;
  std::int64_t t_ns = 0;
  features::StereoFeatures features;  // left keypoints with stereo depth
  // Detector instance under each left keypoint (0 = background), from the
  // instance label image given to prepare().
  std::vector<std::uint16_t> instance;
  std::vector<Eigen::Vector2d> uv_px;  // keypoint positions, level 0
  std::vector<int> octave;
  map::KeypointGrid grid;
  PrepareTimings timings;

  int size() const { return static_cast<int>(uv_px.size()); }
  // Whether keypoint k has a stereo depth of its own under close_depth_m
  // (Tracker::close_depth_m): a close point, one that fixes the position.
  bool has_close_depth(int k, double close_depth_m) const {
    const double depth_m = features.depth_m[k];
    return depth_m > 0.0 && depth_m < close_depth_m;
  }
};

}  // namespace sitepose::tracking
