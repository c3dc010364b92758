#include "sitepose/io/sequence.hpp"

#include <algorithm>
#include <filesystem>

#include "detail/sequences.hpp"

namespace sitepose::io {

const char* to_string(SequenceLayout layout) {
  switch (layout) {
    case SequenceLayout::kSitepose: return "sitepose";
    case SequenceLayout::kEuroc: return "euroc";
  }
  return "unknown";
}

double mean_frame_rate_hz(const Sequence& sequence, std::size_t frames) {
  const std::size_t n = frames > 0 ? std::min(frames, sequence.size()) : sequence.size();
  if (n < 2) return 0.0;
  const double span_s = static_cast<double>(sequence.time_ns(n - 1) - sequence.time_ns(0)) * 1e-9;
  return span_s > 0.0 ? static_cast<double>(n - 1) / span_s : 0.0;
}

bool Sequence::has_gt() const {
  const auto& gt = gt_poses();
  return std::any_of(gt.begin(), gt.end(), [](const std::optional<SE3>& p) { return p.has_value(); });
}

const std::vector<LabelBox>& Sequence::boxes() const {
  static const std::vector<LabelBox> kNoBoxes;
  return kNoBoxes;
}

std::vector<LabelBox> Sequence::boxes_for_frame(std::size_t i) const {
  const std::vector<LabelBox>& all = boxes();
  const int frame = static_cast<int>(i);
  const auto first =
      std::lower_bound(all.begin(), all.end(), frame, [](const LabelBox& b, int f) { return b.frame < f; });
  const auto last =
      std::upper_bound(first, all.end(), frame, [](int f, const LabelBox& b) { return f < b.frame; });
  return {first, last};
}

Expected<std::unique_ptr<Sequence>> open_sequence(const std::string& dir, const SequenceOptions& options) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    return make_error(ErrorCode::kNotFound, dir + ": sequence folder does not exist");
  }
  const fs::path root(dir);
  if (fs::is_directory(root / "image_0", ec)) return detail::open_sitepose_sequence(dir, options);
  if (fs::is_directory(root / "mav0" / "cam0", ec)) {
    return detail::open_euroc_sequence(dir, (root / "mav0").string(), options);
  }
  if (fs::is_regular_file(root / "cam0" / "data.csv", ec)) {
    return detail::open_euroc_sequence(dir, dir, options);
  }
  return make_error(ErrorCode::kInvalidArgument,
                    dir +
                        ": not a sequence: expected image_0/ (sitepose or KITTI odometry layout) "
                        "or mav0/cam0/ (EuRoC layout)");
}

}  // namespace sitepose::io
