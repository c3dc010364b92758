#include "sitepose/views/view_writer.hpp"

#include <cstdio>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "sitepose/views/frame_view.hpp"

namespace sitepose::views {
namespace {

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

Expected<std::size_t> parse_index(const std::string& text, const std::string& whole) {
  if (text.empty() || text.find_first_not_of("0123456789") != std::string::npos || text.size() > 9) {
    return make_error(ErrorCode::kInvalidArgument,
                      "--frames '" + whole + "': expected A:B with frame numbers");
  }
  return static_cast<std::size_t>(std::stoul(text));
}

// A video file or a folder of PNGs.
class FrameSink {
 public:
  static Expected<FrameSink> open(const std::string& out, cv::Size size, double fps) {
    FrameSink sink;
    sink.out_ = out;
    if (ends_with(out, ".avi") || ends_with(out, ".mp4")) {
      const bool avi = ends_with(out, ".avi");
      const int fourcc =
          avi ? cv::VideoWriter::fourcc('M', 'J', 'P', 'G') : cv::VideoWriter::fourcc('m', 'p', '4', 'v');
      const int api = avi ? cv::CAP_OPENCV_MJPEG : cv::CAP_FFMPEG;
      sink.video_ = std::make_unique<cv::VideoWriter>(out, api, fourcc, fps, size, true);
      if (!sink.video_->isOpened()) {
        return make_error(ErrorCode::kIoError, "cannot open " + out + " for writing" +
                                                   (avi ? std::string()
                                                        : " (MPEG-4 needs OpenCV's FFmpeg backend; "
                                                          "use .avi)"));
      }
      return sink;
    }
    std::error_code ec;
    std::filesystem::create_directories(out, ec);
    if (ec) return make_error(ErrorCode::kIoError, "cannot create " + out + ": " + ec.message());
    return sink;
  }

  Status write(const cv::Mat& image, std::size_t index) {
    if (video_) {
      video_->write(image);
      return ok_status();
    }
    char name[32];
    std::snprintf(name, sizeof name, "%06zu.png", index);
    const std::string path = (std::filesystem::path(out_) / name).string();
    if (!cv::imwrite(path, image)) return make_error(ErrorCode::kIoError, "cannot write " + path);
    return ok_status();
  }

  void close() {
    if (video_) video_->release();
  }

 private:
  std::string out_;
  std::unique_ptr<cv::VideoWriter> video_;
};

}  // namespace

Expected<FrameRange> parse_frame_range(const std::string& text) {
  const auto colon = text.find(':');
  if (colon == std::string::npos) {
    return make_error(ErrorCode::kInvalidArgument, "--frames '" + text + "': expected A:B, A: or :B");
  }
  FrameRange range;
  const std::string a = text.substr(0, colon);
  const std::string b = text.substr(colon + 1);
  if (!a.empty()) {
    SITEPOSE_TRY(const std::size_t first, parse_index(a, text));
    range.first = first;
  }
  if (!b.empty()) {
    SITEPOSE_TRY(const std::size_t last, parse_index(b, text));
    range.end = last;
  }
  if (!b.empty() && range.end <= range.first) {
    return make_error(ErrorCode::kInvalidArgument, "--frames '" + text + "': B must be greater than A");
  }
  return range;
}

Expected<ViewResult> write_view(const DebugRecord& record, const ImageSource& images,
                                const std::vector<std::optional<SE3>>& gt, const ViewRequest& request) {
  const std::size_t n = record.frames.size();
  const std::size_t end = request.range.end == 0 ? n : std::min(request.range.end, n);
  if (request.range.first >= end) {
    return make_error(ErrorCode::kInvalidArgument, "--frames: the record has frames 0.." + std::to_string(n) +
                                                       " (exclusive); nothing in the range");
  }
  const TopViewTracks tracks = top_view_tracks(record, gt);
  const double fps = request.fps > 0 ? request.fps : (record.info.fps > 0 ? record.info.fps : 10.0);
  std::optional<FrameSink> sink;
  ViewResult result;
  for (std::size_t i = request.range.first; i < end; ++i) {
    const FrameRecord& f = record.frames[i];
    SITEPOSE_TRY(const ViewImages frame, images(f.seq, f.pixel_mask_used));
    if (record.info.width != 0 &&
        (frame.left.cols != record.info.width || frame.left.rows != record.info.height)) {
      return make_error(ErrorCode::kInvalidArgument,
                        "the images are " + std::to_string(frame.left.cols) + "x" +
                            std::to_string(frame.left.rows) + " but the run's were " +
                            std::to_string(record.info.width) + "x" + std::to_string(record.info.height) +
                            ": not the sequence of this run");
    }
    cv::Mat image = render_frame(frame.left, frame.instance_mask, record, i, tracks);
    if (request.scale != 1.0)
      cv::resize(image, image, cv::Size(), request.scale, request.scale, cv::INTER_AREA);
    if (!sink) {
      SITEPOSE_TRY(FrameSink opened, FrameSink::open(request.out, image.size(), fps));
      sink = std::move(opened);
      result.width = image.cols;
      result.height = image.rows;
    }
    SITEPOSE_TRY_STATUS(sink->write(image, static_cast<std::size_t>(f.seq)));
    ++result.frames;
    if (request.on_frame) request.on_frame(result.frames, end - request.range.first);
  }
  sink->close();
  return result;
}

Expected<ViewResult> write_view(const DebugRecord& record, const io::Sequence& sequence,
                                const ViewRequest& request) {
  const ImageSource images = [&sequence](std::int64_t seq, bool want_mask) -> Expected<ViewImages> {
    if (seq < 0 || static_cast<std::size_t>(seq) >= sequence.size()) {
      return make_error(ErrorCode::kInvalidArgument,
                        "the run has sequence frame " + std::to_string(seq) + " but the sequence has " +
                            std::to_string(sequence.size()) + ": not the sequence of this run");
    }
    SITEPOSE_TRY(StereoFrame frame, sequence.read_frame(static_cast<std::size_t>(seq)));
    ViewImages out{frame.left, {}};
    if (want_mask && sequence.has_masks()) {
      if (auto mask = sequence.read_instance_mask(static_cast<std::size_t>(seq))) out.instance_mask = *mask;
    }
    return out;
  };
  return write_view(record, images, sequence.gt_poses(), request);
}

}  // namespace sitepose::views
