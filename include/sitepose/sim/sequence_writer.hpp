#pragma once
// Writes a simulated sequence in the sitepose layout (FORMATS.md):
//   image_0/NNNNNN.png, image_1/NNNNNN.png   8-bit gray
//   calib.txt     P0, P1 (rectified pair); with distorted output also
//                 D0, D1: k1 k2 p1 p2 (images are then NOT rectified)
//   times.txt     seconds, one line per frame
//   poses.txt     T_world_cam of the left camera, world = left camera at frame 0
//   poses_tum.txt the same poses as TUM (t x y z qx qy qz qw)
//   labels/boxes.csv      frame,instance,class,x,y,w,h,moving (visible objects)
//   labels/masks/NNNNNN.png  CV_16UC1 instance ids of the left image
//   labels/parts.csv      frame,instance,part,name,x,y,w,h,moving (visible
//                         parts of articulated machines), and
//   labels/parts/NNNNNN.png  CV_8UC1 part ids (PartTruth::part) of the left
//                         image; both only when the scenario has articulated
//                         machines (other sequences are unchanged)
//   meta.json     scenario, seed, fps, frames, camera, T_site_world,
//                 per-frame occlusion ratios and exposure gains
// The sequence is written into a hidden folder beside the output and moved
// in when complete: an interrupted or failed run leaves no half sequence.
// Runs on the calling thread (rendering uses OpenCV's pool).

#include <functional>
#include <string>
#include <vector>

#include "sitepose/core/expected.hpp"
#include "sitepose/sim/simulator.hpp"

namespace sitepose::sim {

struct WriteOptions {
  // Write into a non-empty folder; the files of a sequence already there
  // (image_0, image_1, labels, calib.txt, times.txt, poses.txt, meta.json)
  // are removed first so no stale frame survives. Other files are kept.
  bool force = false;
  // Called after each frame with (frames done, total).
  std::function<void(int, int)> progress;
  // Polled before each frame; true ends the sequence there: the frames done
  // are written as a complete, shorter sequence (meta.json "partial": true).
  std::function<bool()> stop;
};

struct WriteSummary {
  int frames = 0;
  bool partial = false;  // stopped by WriteOptions::stop before the last frame
  double max_occlusion_ratio = 0.0;
  double mean_occlusion_ratio = 0.0;
  double seconds = 0.0;  // wall time of rendering and writing
};

// Ok when write_sequence may write to `dir`: absent, an empty folder, or a
// folder with a sequence and `force`; kInvalidArgument naming it otherwise.
// For a check before a long set-up (write_sequence checks again).
Status check_sequence_output(const std::string& dir, bool force);

// Errors: kInvalidArgument when `dir` is non-empty without force (naming
// it), kIoError naming the file that could not be written.
Expected<WriteSummary> write_sequence(const Simulator& sim, const std::string& dir,
                                      const WriteOptions& options = {});

}  // namespace sitepose::sim
