#pragma once
// Training images for a place-recognition vocabulary (placerec): the ORB
// descriptors of the left images of a labelled source, one matrix per
// frame used. `sitepose vocab train` and the tests that make their own
// small vocabulary both read frames this way.

#include <vector>

#include <opencv2/core.hpp>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/core/expected.hpp"
#include "sitepose/experiments/labelled_source.hpp"

namespace sitepose::experiments {

// Frames 0, every, 2 every, ... of `source` (at most max_frames of them
// when > 0), extracted with `orb`'s settings.
Expected<std::vector<cv::Mat>> left_image_descriptors(const LabelledSource& source,
                                                      const config::OrbConfig& orb, int every = 1,
                                                      int max_frames = 0);

}  // namespace sitepose::experiments
