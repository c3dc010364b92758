#pragma once
// Recorded stereo sequences behind one interface (FORMATS.md):
//   * sitepose layout (a superset of KITTI odometry): image_0/, image_1/,
//     calib.txt, times.txt, optional poses.txt, labels/, meta.json;
//   * real KITTI odometry sequences (same reader, GT file given apart);
//   * EuRoC MAV (ASL) layout, rectified on the fly.
// Frames come out rectified, 8-bit gray, left camera = reference frame.
//
// Threads: a Sequence is immutable after open_sequence(); every const member
// may be called concurrently (reads touch only the file system).
// Ownership: open_sequence() hands the caller a unique_ptr.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "sitepose/core/channel_order.hpp"
#include "sitepose/core/expected.hpp"
#include "sitepose/core/se3.hpp"
#include "sitepose/core/stereo_camera.hpp"
#include "sitepose/core/stereo_frame.hpp"
#include "sitepose/io/labels.hpp"

namespace sitepose::io {

enum class SequenceLayout {
  kSitepose,  // image_0/ image_1/ calib.txt times.txt (KITTI odometry included)
  kEuroc,     // mav0/cam0 mav0/cam1 (unrectified, rectified by the reader)
};

const char* to_string(SequenceLayout layout);

struct SequenceOptions {
  // Ground truth kept outside the sequence folder. sitepose/KITTI layout: a
  // KITTI poses file (e.g. dataset/poses/00.txt), one line per frame; it
  // replaces <seq>/poses.txt. EuRoC: a state_groundtruth_estimate0-style
  // data.csv replacing mav0/state_groundtruth_estimate0/data.csv.
  // Empty = the layout's own file when present, else no GT.
  std::string gt_path;
  // EuRoC: GT is interpolated between two samples only when they are at most
  // this far apart; frames in longer GT dropouts get no GT. 50 ms = 10
  // samples of the 200 Hz EuRoC estimate.
  std::int64_t euroc_max_gt_gap_ns = 50'000'000;
  // Colour images are made gray with this channel order (camera.channel_order,
  // ORB-SLAM2's Camera.RGB); gray images are kept as they are.
  ChannelOrder channel_order = ChannelOrder::kBgr;
};

class Sequence {
 public:
  virtual ~Sequence() = default;

  virtual SequenceLayout layout() const = 0;
  // The folder given to open_sequence(); also the frames' source_id.
  virtual const std::string& directory() const = 0;

  // Number of stereo frames (pairs).
  virtual std::size_t size() const = 0;
  // Rectified stereo camera; width/height are the images' size.
  virtual const StereoCamera& camera() const = 0;
  // Capture time of frame i (left image), ns. i < size() (checked).
  virtual std::int64_t time_ns(std::size_t i) const = 0;
  // Loads frame i: rectified CV_8UC1 left/right, seq = i. Errors name the
  // frame index and the file (missing, undecodable, wrong size or depth);
  // i >= size() is kInvalidArgument.
  virtual Expected<StereoFrame> read_frame(std::size_t i) const = 0;

  // Ground truth T_world_cam of the LEFT rectified camera, one entry per
  // frame (size() entries); nullopt where the frame has none.
  virtual const std::vector<std::optional<SE3>>& gt_poses() const = 0;
  bool has_gt() const;

  // labels/boxes.csv (sitepose layout only); parsed and checked at open.
  // The defaults are those of a layout without labels.
  virtual bool has_labels() const { return false; }
  // All boxes, sorted by (frame, instance); empty without labels.
  virtual const std::vector<LabelBox>& boxes() const;
  std::vector<LabelBox> boxes_for_frame(std::size_t i) const;

  // labels/masks/ present (sitepose layout only).
  virtual bool has_masks() const { return false; }
  // labels/masks/NNNNNN.png of frame i as CV_16UC1 of the camera's size;
  // kNotFound naming frame and file when missing, kUnsupported without masks.
  virtual Expected<cv::Mat> read_instance_mask(std::size_t i) const = 0;

  // <seq>/meta.json when present (free-form, not parsed here).
  virtual std::optional<std::string> meta_json_path() const { return std::nullopt; }

  // EuRoC: cam0/cam1 images without an exact-timestamp partner (dropped);
  // 0 for the other layouts.
  virtual std::size_t unpaired_images() const { return 0; }
};

// Mean frame rate (Hz) of the first `frames` frames (0 = all) from their
// time stamps; 0 when there are fewer than 2 or time does not advance.
double mean_frame_rate_hz(const Sequence& sequence, std::size_t frames = 0);

// Detects the layout of `dir` and opens it:
//   <dir>/image_0/            -> sitepose / KITTI odometry layout
//   <dir>/mav0/cam0/ or <dir>/cam0/data.csv -> EuRoC (dir = dataset or mav0)
// Everything cheap is checked here so a run fails before its first frame:
// calibration, frame counts, presence of every image, image size of frame 0,
// GT and labels. Errors name the file, the line and what was expected.
Expected<std::unique_ptr<Sequence>> open_sequence(const std::string& dir,
                                                  const SequenceOptions& options = {});

}  // namespace sitepose::io
