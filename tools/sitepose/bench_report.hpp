#pragma once
// Figures the bench commands print alike.

#include <algorithm>
#include <cstdio>
#include <iterator>
#include <map>
#include <string>

#include "sitepose/mapping/local_mapper.hpp"
#include "sitepose/slam/run_recorder.hpp"
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

// The local mapper's work per keyframe processed and its steps' shares
// (wall time on the thread that ran it: the mapper's own, or the tracking
// thread when inline).
inline void print_mapping_stats(const mapping::MappingStats& m) {
  if (m.keyframes_processed <= 0) {
    std::printf("mapper: no keyframe processed\n");
    return;
  }
  const double n = static_cast<double>(m.keyframes_processed);
  const mapping::MappingStepTimes& t = m.total_steps;
  const double rest = m.total_keyframe_ms - t.new_points_ms - t.fuse_ms - t.local_ba_ms - t.culling_ms;
  std::printf(
      "mapper: %lld keyframes processed, %.1f ms each (new points %.1f, fuse %.1f, local BA %.1f, culling "
      "%.1f, the rest %.1f); local BA on %lld, stopped early %lld\n",
      static_cast<long long>(m.keyframes_processed), m.total_keyframe_ms / n, t.new_points_ms / n,
      t.fuse_ms / n, t.local_ba_ms / n, t.culling_ms / n, rest / n, static_cast<long long>(m.ba_runs),
      static_cast<long long>(m.ba_aborted));
}

// p50 / p99 / mean of every stage the run timed: the tracker's stages in
// pipeline order first, then the others (e.g. the dynamic layer's) by name.
inline void print_stage_table(const std::map<std::string, slam::StageSummary>& stages) {
  std::printf("%-20s %9s %9s %9s\n", "stage", "p50 ms", "p99 ms", "mean ms");
  const auto row = [](const std::string& name, const slam::StageSummary& s) {
    std::printf("%-20s %9.2f %9.2f %9.2f\n", name.c_str(), s.p50_ms, s.p99_ms, s.mean_ms);
  };
  const char* const ordered[] = {"extract_left",    "extract_right",  "stereo_match", "track_motion_model",
                                 "track_local_map", "motion_only_ba", "whole_frame"};
  for (const char* name : ordered) {
    if (const auto it = stages.find(name); it != stages.end()) row(name, it->second);
  }
  for (const auto& [name, summary] : stages) {
    if (std::find(std::begin(ordered), std::end(ordered), name) == std::end(ordered)) row(name, summary);
  }
}

}  // namespace sitepose::cli
