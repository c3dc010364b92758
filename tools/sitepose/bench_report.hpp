#pragma once
// Figures the bench commands print alike.

#include <cstdio>

#include "sitepose/tracking/tracker.hpp"

namespace sitepose::cli {

// Keyframes per frame and the close-point repeatability (share of the last
// frame's matched close points matched again) of a run.
inline void print_tracker_counters(const tracking::TrackerCounters& c) {
  std::printf("keyframes created %d in %d frames (%.3f per frame, 1 in %.1f)\n", c.keyframes_created,
              c.frames, c.frames > 0 ? double(c.keyframes_created) / c.frames : 0.0,
              c.keyframes_created > 0 ? double(c.frames) / c.keyframes_created : 0.0);
  std::printf(
      "close-point repeatability %.3f (%ld of %ld close points matched again in the next frame)\n",
      c.close_points_previous > 0 ? double(c.close_points_rematched) / double(c.close_points_previous) : 0.0,
      c.close_points_rematched, c.close_points_previous);
}

}  // namespace sitepose::cli
