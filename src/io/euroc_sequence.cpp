// EuRoC MAV (ASL) layout (FORMATS.md "EuRoC MAV (ASL) layout"): unrectified
// cam0/cam1, rectified here once per sequence, GT moved to the rectified
// left camera.

#include <filesystem>
#include <opencv2/imgproc.hpp>
#include <unordered_map>

#include "detail/image.hpp"
#include "detail/sequences.hpp"
#include "sitepose/core/log.hpp"
#include "sitepose/io/euroc.hpp"

namespace sitepose::io::detail {
namespace {

namespace fs = std::filesystem;

struct StereoEntry {
  std::int64_t t_ns = 0;
  std::string left_path;
  std::string right_path;
};

class EurocSequence final : public Sequence {
 public:
  SequenceLayout layout() const override { return SequenceLayout::kEuroc; }
  const std::string& directory() const override { return dir_; }
  std::size_t size() const override { return entries_.size(); }
  const StereoCamera& camera() const override { return rect_.camera; }
  std::int64_t time_ns(std::size_t i) const override {
    SITEPOSE_CHECK(i < entries_.size());
    return entries_[i].t_ns;
  }

  Expected<StereoFrame> read_frame(std::size_t i) const override {
    if (i >= size()) {
      return make_error(ErrorCode::kInvalidArgument, dir_ + ": frame " + std::to_string(i) +
                                                         " out of range (sequence has " +
                                                         std::to_string(size()) + " frames)");
    }
    const StereoEntry& e = entries_[i];
    SITEPOSE_TRY(const cv::Mat raw_left, load_gray_image(e.left_path, i, channel_order_));
    SITEPOSE_TRY(const cv::Mat raw_right, load_gray_image(e.right_path, i, channel_order_));
    const StereoCamera& cam = rect_.camera;
    SITEPOSE_TRY_STATUS(
        check_image_size(raw_left, cam.width, cam.height, e.left_path, i, "cam0 sensor.yaml resolution"));
    SITEPOSE_TRY_STATUS(
        check_image_size(raw_right, cam.width, cam.height, e.right_path, i, "cam1 sensor.yaml resolution"));
    StereoFrame frame;
    cv::remap(raw_left, frame.left, rect_.map0_a, rect_.map0_b, cv::INTER_LINEAR);
    cv::remap(raw_right, frame.right, rect_.map1_a, rect_.map1_b, cv::INTER_LINEAR);
    frame.seq = static_cast<std::int64_t>(i);
    frame.t_left_ns = frame.t_right_ns = e.t_ns;  // paired by exact timestamp
    frame.source_id = dir_;
    return frame;
  }

  const std::vector<std::optional<SE3>>& gt_poses() const override { return gt_; }
  Expected<cv::Mat> read_instance_mask(std::size_t) const override {
    return make_error(ErrorCode::kUnsupported, dir_ + ": EuRoC sequences carry no instance masks");
  }
  std::size_t unpaired_images() const override { return unpaired_; }

  static Expected<std::unique_ptr<Sequence>> open(const std::string& dir, const std::string& mav0,
                                                  const SequenceOptions& options);

 private:
  std::string dir_;
  EurocRectification rect_;
  std::vector<StereoEntry> entries_;
  std::vector<std::optional<SE3>> gt_;
  std::size_t unpaired_ = 0;
  ChannelOrder channel_order_ = ChannelOrder::kBgr;
};

Expected<std::unique_ptr<Sequence>> EurocSequence::open(const std::string& dir, const std::string& mav0,
                                                        const SequenceOptions& options) {
  auto seq = std::make_unique<EurocSequence>();
  seq->dir_ = dir;
  seq->channel_order_ = options.channel_order;
  const fs::path root(mav0);
  SITEPOSE_TRY(const EurocCameraSensor cam0,
               read_euroc_sensor_yaml((root / "cam0" / "sensor.yaml").string()));
  SITEPOSE_TRY(const EurocCameraSensor cam1,
               read_euroc_sensor_yaml((root / "cam1" / "sensor.yaml").string()));
  SITEPOSE_TRY(seq->rect_, make_euroc_rectification(cam0, cam1));

  SITEPOSE_TRY(const std::vector<EurocImageEntry> left,
               read_euroc_image_list((root / "cam0" / "data.csv").string()));
  SITEPOSE_TRY(const std::vector<EurocImageEntry> right,
               read_euroc_image_list((root / "cam1" / "data.csv").string()));
  std::unordered_map<std::int64_t, const EurocImageEntry*> right_by_time;
  for (const EurocImageEntry& e : right) right_by_time.emplace(e.t_ns, &e);
  for (const EurocImageEntry& l : left) {
    const auto it = right_by_time.find(l.t_ns);
    if (it == right_by_time.end()) continue;
    seq->entries_.push_back({l.t_ns, (root / "cam0" / "data" / l.file_name).string(),
                             (root / "cam1" / "data" / it->second->file_name).string()});
  }
  seq->unpaired_ = (left.size() - seq->entries_.size()) + (right.size() - seq->entries_.size());
  if (seq->entries_.empty()) {
    return make_error(ErrorCode::kInvalidArgument,
                      mav0 + ": no cam0/cam1 image pair with equal timestamps (cam0 " +
                          std::to_string(left.size()) + " images, cam1 " + std::to_string(right.size()) +
                          ")");
  }
  if (seq->unpaired_ > 0) {
    spdlog::warn(
        "seq={} EuRoC: {} of {} cam0 and {} cam1 images have no partner with the same timestamp; dropped",
        dir, seq->unpaired_, left.size(), right.size());
  }
  for (std::size_t i = 0; i < seq->entries_.size(); ++i) {
    for (const std::string* p : {&seq->entries_[i].left_path, &seq->entries_[i].right_path}) {
      std::error_code ec;
      if (!fs::is_regular_file(*p, ec)) {
        return make_error(ErrorCode::kNotFound,
                          "frame " + std::to_string(i) + ": image " + *p + " does not exist");
      }
    }
  }

  std::vector<std::int64_t> times_ns;
  times_ns.reserve(seq->entries_.size());
  for (const StereoEntry& e : seq->entries_) times_ns.push_back(e.t_ns);
  std::string gt_path = options.gt_path;
  const fs::path default_gt = root / "state_groundtruth_estimate0" / "data.csv";
  std::error_code ec;
  if (gt_path.empty() && fs::is_regular_file(default_gt, ec)) gt_path = default_gt.string();
  if (gt_path.empty()) {
    seq->gt_.assign(times_ns.size(), std::nullopt);
  } else {
    SITEPOSE_TRY(const std::vector<EurocGtSample> samples, read_euroc_groundtruth(gt_path));
    // T_world_rect = T_world_body * T_body_cam0 * T_cam0_rect.
    seq->gt_ = euroc_gt_at_times(samples, times_ns, cam0.T_body_cam * seq->rect_.T_cam0_rect,
                                 options.euroc_max_gt_gap_ns);
  }
  return std::unique_ptr<Sequence>(std::move(seq));
}

}  // namespace

Expected<std::unique_ptr<Sequence>> open_euroc_sequence(const std::string& dir, const std::string& mav0_dir,
                                                        const SequenceOptions& options) {
  return EurocSequence::open(dir, mav0_dir, options);
}

}  // namespace sitepose::io::detail
