#pragma once
// `sitepose view`: the annotated frames of a run (frame_view.hpp) for a
// range of frames, into a video (cv::VideoWriter: .avi as Motion-JPEG, which
// every OpenCV build writes; .mp4 as MPEG-4 part 2 through FFmpeg) or a
// folder of PNGs.

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "sitepose/core/expected.hpp"
#include "sitepose/io/sequence.hpp"
#include "sitepose/views/debug_record.hpp"

namespace sitepose::views {

struct FrameRange {
  std::size_t first = 0;
  std::size_t end = 0;  // one past the last; 0 = to the end of the record
};

// "A:B" (frames A..B-1), "A:" or ":B"; record indices. kInvalidArgument
// naming the text otherwise.
Expected<FrameRange> parse_frame_range(const std::string& text);

struct ViewRequest {
  std::string out;  // *.avi, *.mp4, or a folder for NNNNNN.png
  FrameRange range;
  double fps = 0.0;    // 0 = the run's frame rate (10 when unknown)
  double scale = 1.0;  // output size / drawn size (smaller files)
  // Called after each written frame: (frames done, frames in all).
  std::function<void(std::size_t, std::size_t)> on_frame;
};

struct ViewResult {
  std::size_t frames = 0;
  int width = 0;
  int height = 0;
};

// The images of one frame the view draws over.
struct ViewImages {
  cv::Mat left;           // CV_8UC1, the run's size
  cv::Mat instance_mask;  // CV_16UC1 or empty
};
// Images of sequence frame `seq`; the mask is wanted only where the run
// used a pixel mask.
using ImageSource = std::function<Expected<ViewImages>(std::int64_t seq, bool want_mask)>;

// Errors: bad range or output (kInvalidArgument), images that do not match
// the record (size), the image source's errors, writer failures (kIoError).
// gt: per sequence frame, may be empty.
Expected<ViewResult> write_view(const DebugRecord& record, const ImageSource& images,
                                const std::vector<std::optional<SE3>>& gt, const ViewRequest& request);

// The same from the sequence the run tracked (its images, masks and GT).
Expected<ViewResult> write_view(const DebugRecord& record, const io::Sequence& sequence,
                                const ViewRequest& request);

}  // namespace sitepose::views
