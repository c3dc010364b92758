// sitepose / KITTI odometry layout (FORMATS.md "sitepose sequence").

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>

#include "detail/image.hpp"
#include "detail/sequences.hpp"
#include "sitepose/io/kitti_calib.hpp"
#include "sitepose/io/labels.hpp"
#include "sitepose/io/trajectory.hpp"

namespace sitepose::io::detail {
namespace {

namespace fs = std::filesystem;

bool is_frame_png(const fs::path& p) {
  const std::string stem = p.stem().string();
  return p.extension() == ".png" && stem.size() == 6 && std::all_of(stem.begin(), stem.end(), [](char c) {
           return std::isdigit(static_cast<unsigned char>(c)) != 0;
         });
}

// Every frame's image must exist and no extra frame images may lie there.
Status check_image_folder(const fs::path& folder, std::size_t n_frames, const std::string& times_path) {
  for (std::size_t i = 0; i < n_frames; ++i) {
    const fs::path p = folder / frame_file_name(i);
    std::error_code ec;
    if (!fs::is_regular_file(p, ec)) {
      return make_error(ErrorCode::kNotFound, "frame " + std::to_string(i) + ": image " + p.string() +
                                                  " does not exist (" + times_path + " lists " +
                                                  std::to_string(n_frames) + " frames)");
    }
  }
  // error_code overloads throughout: an entry that cannot be stat'ed (a
  // symlink loop, a dangling link) is not a frame image, not a crash.
  std::size_t count = 0;
  std::error_code ec;
  for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code entry_ec;
    if (is_frame_png(it->path()) && it->is_regular_file(entry_ec)) ++count;
  }
  if (ec) return make_error(ErrorCode::kIoError, folder.string() + ": cannot list: " + ec.message());
  if (count != n_frames) {
    return make_error(ErrorCode::kInvalidArgument, folder.string() + " holds " + std::to_string(count) +
                                                       " frame images but " + times_path + " has " +
                                                       std::to_string(n_frames) +
                                                       " times; expected one image per frame");
  }
  return ok_status();
}

// Masks are decoded only when a detector asks for them, during the run; so
// that a bad one is bad input at open, not a failure mid-run, every mask's
// PNG header is checked here. A frame with boxes needs its mask.
Status check_mask_folder(const fs::path& folder, const Sequence& seq) {
  std::vector<bool> has_boxes(seq.size(), false);
  for (const LabelBox& b : seq.boxes()) has_boxes[static_cast<std::size_t>(b.frame)] = true;
  for (std::size_t i = 0; i < seq.size(); ++i) {
    const fs::path p = folder / frame_file_name(i);
    std::error_code ec;
    if (!has_boxes[i] && !fs::exists(p, ec)) continue;
    if (Status st = check_instance_mask_header(p.string(), seq.camera().width, seq.camera().height); !st) {
      return make_error(st.error().code, "frame " + std::to_string(i) + ": " + st.error().message +
                                             (has_boxes[i] ? " (labels/boxes.csv has boxes for it)" : ""));
    }
  }
  return ok_status();
}

class SiteposeSequence final : public Sequence {
 public:
  SequenceLayout layout() const override { return SequenceLayout::kSitepose; }
  const std::string& directory() const override { return dir_; }
  std::size_t size() const override { return times_ns_.size(); }
  const StereoCamera& camera() const override { return camera_; }
  std::int64_t time_ns(std::size_t i) const override {
    SITEPOSE_CHECK(i < times_ns_.size());
    return times_ns_[i];
  }

  Expected<StereoFrame> read_frame(std::size_t i) const override {
    if (i >= size()) {
      return make_error(ErrorCode::kInvalidArgument, dir_ + ": frame " + std::to_string(i) +
                                                         " out of range (sequence has " +
                                                         std::to_string(size()) + " frames)");
    }
    const std::string left_path = (fs::path(dir_) / "image_0" / frame_file_name(i)).string();
    const std::string right_path = (fs::path(dir_) / "image_1" / frame_file_name(i)).string();
    StereoFrame frame;
    SITEPOSE_TRY(frame.left, load_gray_image(left_path, i, channel_order_));
    SITEPOSE_TRY(frame.right, load_gray_image(right_path, i, channel_order_));
    SITEPOSE_TRY_STATUS(
        check_image_size(frame.left, camera_.width, camera_.height, left_path, i, "size of frame 0"));
    SITEPOSE_TRY_STATUS(check_image_size(frame.right, camera_.width, camera_.height, right_path, i,
                                         "size of the left image"));
    frame.seq = static_cast<std::int64_t>(i);
    frame.t_left_ns = frame.t_right_ns = times_ns_[i];
    frame.source_id = dir_;
    return frame;
  }

  const std::vector<std::optional<SE3>>& gt_poses() const override { return gt_; }
  bool has_labels() const override { return has_labels_; }
  const std::vector<LabelBox>& boxes() const override { return boxes_; }
  bool has_masks() const override { return has_masks_; }

  Expected<cv::Mat> read_instance_mask(std::size_t i) const override {
    if (!has_masks_) {
      return make_error(ErrorCode::kUnsupported, dir_ + ": no labels/masks/ folder");
    }
    if (i >= size()) {
      return make_error(ErrorCode::kInvalidArgument, dir_ + ": mask of frame " + std::to_string(i) +
                                                         " out of range (sequence has " +
                                                         std::to_string(size()) + " frames)");
    }
    const std::string path = (fs::path(dir_) / "labels" / "masks" / frame_file_name(i)).string();
    auto mask = io::read_instance_mask(path);
    if (!mask) {
      return make_error(mask.error().code, "frame " + std::to_string(i) + ": " + mask.error().message);
    }
    SITEPOSE_TRY_STATUS(check_image_size(*mask, camera_.width, camera_.height, path, i, "camera size"));
    return mask;
  }

  std::optional<std::string> meta_json_path() const override { return meta_path_; }

  static Expected<std::unique_ptr<Sequence>> open(const std::string& dir, const SequenceOptions& options);

 private:
  std::string dir_;
  StereoCamera camera_;
  std::vector<std::int64_t> times_ns_;
  std::vector<std::optional<SE3>> gt_;
  bool has_labels_ = false;
  std::vector<LabelBox> boxes_;
  bool has_masks_ = false;
  std::optional<std::string> meta_path_;
  ChannelOrder channel_order_ = ChannelOrder::kBgr;
};

Expected<std::unique_ptr<Sequence>> SiteposeSequence::open(const std::string& dir,
                                                           const SequenceOptions& options) {
  auto seq = std::make_unique<SiteposeSequence>();
  seq->dir_ = dir;
  seq->channel_order_ = options.channel_order;
  const fs::path root(dir);
  std::error_code ec;

  SITEPOSE_TRY(seq->camera_, read_kitti_calib((root / "calib.txt").string()));
  const std::string times_path = (root / "times.txt").string();
  SITEPOSE_TRY(const std::vector<double> times_s, read_times(times_path));
  if (times_s.empty()) {
    return make_error(ErrorCode::kInvalidArgument, times_path + ": expected at least one frame time");
  }
  seq->times_ns_.reserve(times_s.size());
  for (double t : times_s) seq->times_ns_.push_back(std::llround(t * 1e9));
  const std::size_t n = times_s.size();

  if (!fs::is_directory(root / "image_1", ec)) {
    return make_error(ErrorCode::kNotFound,
                      (root / "image_1").string() + ": right image folder does not exist");
  }
  SITEPOSE_TRY_STATUS(check_image_folder(root / "image_0", n, times_path));
  SITEPOSE_TRY_STATUS(check_image_folder(root / "image_1", n, times_path));

  // Image size comes from frame 0; the calibration must fit inside it.
  const std::string first_left = (root / "image_0" / frame_file_name(0)).string();
  const std::string first_right = (root / "image_1" / frame_file_name(0)).string();
  SITEPOSE_TRY(const cv::Mat left0, load_gray_image(first_left, 0, options.channel_order));
  SITEPOSE_TRY(const cv::Mat right0, load_gray_image(first_right, 0, options.channel_order));
  SITEPOSE_TRY_STATUS(
      check_image_size(right0, left0.cols, left0.rows, first_right, 0, "size of the left image"));
  seq->camera_.width = left0.cols;
  seq->camera_.height = left0.rows;
  if (Status valid = seq->camera_.validate(); !valid) {
    return make_error(ErrorCode::kInvalidArgument,
                      (root / "calib.txt").string() + " with images of " + std::to_string(left0.cols) + "x" +
                          std::to_string(left0.rows) + ": " + valid.error().message);
  }

  // Ground truth: the explicit file wins over <seq>/poses.txt.
  std::string gt_path = options.gt_path;
  if (gt_path.empty() && fs::is_regular_file(root / "poses.txt", ec)) gt_path = (root / "poses.txt").string();
  seq->gt_.assign(n, std::nullopt);
  if (!gt_path.empty()) {
    SITEPOSE_TRY(const std::vector<SE3> poses, read_kitti_poses(gt_path));
    if (poses.size() != n) {
      return make_error(ErrorCode::kInvalidArgument,
                        gt_path + " has " + std::to_string(poses.size()) + " poses but " + times_path +
                            " has " + std::to_string(n) + " times; expected one pose per frame");
    }
    for (std::size_t i = 0; i < n; ++i) seq->gt_[i] = poses[i];
  }

  const fs::path boxes_path = root / "labels" / "boxes.csv";
  if (fs::is_regular_file(boxes_path, ec)) {
    SITEPOSE_TRY(seq->boxes_, read_boxes_csv(boxes_path.string(), n));
    seq->has_labels_ = true;
  }
  seq->has_masks_ = fs::is_directory(root / "labels" / "masks", ec);
  if (seq->has_masks_) SITEPOSE_TRY_STATUS(check_mask_folder(root / "labels" / "masks", *seq));
  if (fs::is_regular_file(root / "meta.json", ec)) seq->meta_path_ = (root / "meta.json").string();
  return std::unique_ptr<Sequence>(std::move(seq));
}

}  // namespace

Expected<std::unique_ptr<Sequence>> open_sitepose_sequence(const std::string& dir,
                                                           const SequenceOptions& options) {
  return SiteposeSequence::open(dir, options);
}

}  // namespace sitepose::io::detail
