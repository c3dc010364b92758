#include "sitepose/experiments/vocabulary_training.hpp"

#include <algorithm>

#include "sitepose/features/orb_extractor.hpp"

namespace sitepose::experiments {

Expected<std::vector<cv::Mat>> left_image_descriptors(const LabelledSource& source,
                                                      const config::OrbConfig& orb, int every,
                                                      int max_frames) {
  if (every < 1) return make_error(ErrorCode::kInvalidArgument, "every must be >= 1");
  SITEPOSE_TRY(features::OrbExtractor extractor, features::OrbExtractor::create(orb));
  std::vector<cv::Mat> images;
  for (int i = 0; i < source.size(); i += every) {
    if (max_frames > 0 && static_cast<int>(images.size()) >= max_frames) break;
    SITEPOSE_TRY(const LabelledFrame frame, source.read(i));
    SITEPOSE_TRY(features::OrbFeatures features, extractor.extract(frame.frame.left));
    images.push_back(features.descriptors);
  }
  return images;
}

}  // namespace sitepose::experiments
