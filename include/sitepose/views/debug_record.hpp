#pragma once
// The debug record of a run (`sitepose run --debug-out RUNDIR`): per frame
// what the views draw — keypoints with their pass flags and object, the
// dynamic boxes, each object's verdict and statistic, mar, the pixel-mask
// call, tracking state, inliers, pose, stage times, map size. Compact text,
// no images: the views read the images from the sequence again.
//
// RUNDIR/
//   run.txt      key value lines: version, revision, sequence, mode, detector,
//                width, height, fps
//   config.yaml  the configuration the run used (config::to_yaml)
//   frames.txt   one block per frame (format in debug_record.cpp)
//
// Ownership: a DebugRecordWriter owns its open file; one thread writes.

#include <cstdint>
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sitepose/core/expected.hpp"
#include "sitepose/core/se3.hpp"
#include "sitepose/dynamic/object_types.hpp"
#include "sitepose/slam/frame_report.hpp"

namespace sitepose::views {

struct RunInfo {
  std::string version;
  std::string revision;
  std::string sequence;  // directory the frames came from; "" = simulated in-process
  std::string scenario;  // simulated scenario, when there was one
  std::string mode;
  std::string detector;
  int width = 0;
  int height = 0;
  double fps = 0.0;
};

// One frame of the record as read back.
struct FrameRecord {
  std::int64_t seq = 0;
  std::int64_t t_ns = 0;
  TrackingState state = TrackingState::kLost;
  std::string state_reason;
  SE3 T_world_cam;
  PoseCounters counters;
  slam::FrameTimings timings;
  double mar = 0.0;
  double masked_ratio = 0.0;
  bool pixel_mask_used = false;
  bool pass1_with_known_static = false;
  bool pass2_rejected = false;
  int remasked_by_map_check = 0;
  std::vector<dynamic::ObjectVerdict> objects;
  slam::FrameTrace trace;
};

struct DebugRecord {
  RunInfo info;
  std::string config_yaml;
  std::vector<FrameRecord> frames;
};

// Stage names and their time in `timings`, in the record's column order.
std::vector<std::pair<std::string, double>> stage_times(const slam::FrameTimings& timings);

class DebugRecordWriter {
 public:
  // Creates `dir` (and parents), writes run.txt and config.yaml, opens
  // frames.txt. Errors: kIo naming the path.
  static Expected<std::unique_ptr<DebugRecordWriter>> open(const std::string& dir, const RunInfo& info,
                                                           const std::string& config_yaml);
  ~DebugRecordWriter();
  DebugRecordWriter(const DebugRecordWriter&) = delete;
  DebugRecordWriter& operator=(const DebugRecordWriter&) = delete;

  // Appends one frame (report.trace should be filled: SlamOptions::trace).
  Status write(const slam::FrameReport& report);
  // Flushes and closes frames.txt; errors when any write failed.
  Status close();
  // Wall time spent in write() so far (ms), the record's own cost.
  double write_ms() const { return write_ms_; }
  const std::string& directory() const { return dir_; }

 private:
  DebugRecordWriter(std::string dir, std::FILE* file) : dir_(std::move(dir)), file_(file) {}

  std::string dir_;
  std::FILE* file_ = nullptr;
  std::string buffer_;
  double write_ms_ = 0.0;
  bool failed_ = false;
};

// Reads RUNDIR back. Errors: kNotFound / kInvalidArgument naming the file
// and the line.
Expected<DebugRecord> read_debug_record(const std::string& dir);

}  // namespace sitepose::views
