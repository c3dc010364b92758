#pragma once
// Frames with their object labels and ground truth, from the simulator
// (rendered in-process, nothing written, or written to a sequence folder
// first: open_ablation_source) or from a sitepose sequence with labels/
// (boxes.csv, masks). The regression tests, `sitepose ablate ...` and
// `sitepose bench dynamic` run the dynamic layer on these.
//
// The labels play the `labels` detector of the paper's protocol (boxes and
// masks computed beforehand); ground-truth `moving` flags score the motion
// states. Threads: read() is const but not meant for concurrent use.

#include <map>
#include <memory>
#include <optional>
#include <string>

#include "sitepose/core/expected.hpp"
#include "sitepose/core/se3.hpp"
#include "sitepose/core/stereo_camera.hpp"
#include "sitepose/core/stereo_frame.hpp"
#include "sitepose/dynamic/object_types.hpp"

namespace sitepose::experiments {

struct LabelledFrame {
  StereoFrame frame;
  dynamic::FrameObjects objects;         // every labelled object (classes unfiltered)
  cv::Mat instance_mask;                 // CV_16UC1 or empty (segment() returns it)
  std::optional<SE3> T_world_cam_gt;     // left camera, sequence world frame
  std::map<std::uint16_t, bool> moving;  // ground truth per instance, where known
};

class LabelledSource {
 public:
  virtual ~LabelledSource() = default;
  virtual const std::string& name() const = 0;
  virtual int size() const = 0;
  virtual double fps() const = 0;
  virtual const StereoCamera& camera() const = 0;
  // Frame i (0 <= i < size()); objects.segment returns this frame's mask
  // (it captures the returned frame's data by value).
  virtual Expected<LabelledFrame> read(int i) const = 0;
};

// Renders `scenario` (name or YAML path) in-process; `frames` > 0 limits the
// length; width and height, when set, render at that size (same field of
// view); fps, when set, at that frame rate (same motion in time).
// kUnsupported for scenarios rendering distorted images.
Expected<std::unique_ptr<LabelledSource>> open_simulated(const std::string& scenario, int frames = 0,
                                                         std::optional<int> seed = std::nullopt,
                                                         std::optional<int> width = std::nullopt,
                                                         std::optional<int> height = std::nullopt,
                                                         std::optional<double> fps = std::nullopt);

// A sitepose sequence; boxes and masks from labels/ (kInvalidArgument when
// the sequence has no labels/boxes.csv and `require_labels`; without it such
// a sequence gives frames without objects, enough for mode none). fps from
// times.txt.
Expected<std::unique_ptr<LabelledSource>> open_labelled_sequence(const std::string& directory,
                                                                 bool require_labels = true);

// Keeps every frame of `source` in memory after the first read (tests and
// ablations run several modes on the same frames).
std::unique_ptr<LabelledSource> cache_frames(std::unique_ptr<LabelledSource> source);

// A frame rate is for rendering a scenario: with a recorded sequence it is
// refused (kInvalidArgument naming --fps), which keeps its own.
Status check_fps_for_source(bool from_sequence, std::optional<double> fps);

// Exactly one of `sequence` and `scenario` must be non-empty. A scenario is
// simulated (frames > 0 limits it) into `temp_dir`/<scenario>, which must
// be empty or absent, and read back like any sequence; the frames are then
// kept in memory (cache_frames) because ablations run several times.
// Errors: kInvalidArgument naming the flags when both or none are given,
// or fps with a sequence.
struct SourceRequest {
  std::string sequence;
  std::string scenario;
  int frames = 0;
  std::optional<double> fps{};  // render the scenario at this rate (unset = its own); not with `sequence`
  std::string temp_dir;         // where a scenario is written; empty = a fresh folder under /tmp
};
Expected<std::unique_ptr<LabelledSource>> open_ablation_source(const SourceRequest& request,
                                                               std::string* written_dir = nullptr);

}  // namespace sitepose::experiments
