#pragma once
// Picture of an evaluation: top view of ground truth vs the aligned
// estimate coloured by ATE (with a colour bar in metres), and ATE over time.
// render_eval_plot only draws; write_eval_plot also writes the PNG file (for
// the command line, which is the one caller that does file I/O).

#include <string>

#include <opencv2/core.hpp>

#include "sitepose/core/expected.hpp"
#include "sitepose/eval/evaluate.hpp"
#include "sitepose/io/trajectory.hpp"

namespace sitepose::experiments {

struct PlotOptions {
  int width_px = 1600;
  int height_px = 800;
};

// Top view: the two world axes along which the ground truth extends most,
// drawn with equal scale (for the usual camera frame, y down, that is x-z:
// looking down). Returns an 8-bit BGR image. Fails (kInvalidArgument) when
// the result has no poses or the size is below 800x400.
Expected<cv::Mat> render_eval_plot(const io::Trajectory& gt, const eval::EvalResult& result,
                                   const PlotOptions& options = {});

// Renders and writes a PNG. Fails with kInvalidArgument when `path` does not
// end in ".png" (or rendering fails), kIoError when the file cannot be
// written; the message names the path.
Status write_eval_plot(const std::string& path, const io::Trajectory& gt, const eval::EvalResult& result,
                       const PlotOptions& options = {});

}  // namespace sitepose::experiments
