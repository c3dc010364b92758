#include "sitepose/views/frame_view.hpp"

#include "sitepose/dynamic/object_types.hpp"

#include <algorithm>
#include <cstdio>
#include <map>

#include <opencv2/imgproc.hpp>

namespace sitepose::views {
namespace {

using dynamic::MotionState;

cv::Scalar state_colour(MotionState state) {
  switch (state) {
    case MotionState::kStatic: return Palette::static_unmasked();
    case MotionState::kMoving: return Palette::moving();
    case MotionState::kUnknown: break;
  }
  return Palette::unknown_object();
}

cv::Scalar keypoint_colour(const slam::KeypointTrace& k, const std::map<std::uint16_t, MotionState>& states,
                           bool final_pass2) {
  const bool usable = final_pass2 ? (k.flags & slam::KeypointTrace::kUsablePass2) != 0
                                  : (k.flags & slam::KeypointTrace::kUsablePass1) != 0;
  if (k.instance == 0) return usable ? Palette::background_inlier() : Palette::background_unused();
  const auto it = states.find(k.instance);
  if (it != states.end() && it->second == MotionState::kMoving) return Palette::moving_keypoint();
  return usable ? Palette::static_unmasked() : Palette::masked();
}

void put_text(cv::Mat& image, const std::string& text, cv::Point at, double scale, const cv::Scalar& colour) {
  cv::putText(image, text, at, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(0, 0, 0), 3, cv::LINE_AA);
  cv::putText(image, text, at, cv::FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv::LINE_AA);
}

void draw_pixel_mask(cv::Mat& image, const cv::Mat& mask, const std::map<std::uint16_t, MotionState>& states,
                     const std::vector<dynamic::ObjectBox>& boxes) {
  for (const auto& b : boxes) {
    const auto it = states.find(b.instance);
    const cv::Scalar colour = state_colour(it == states.end() ? MotionState::kUnknown : it->second);
    cv::Mat hit;
    cv::compare(mask, cv::Scalar(b.instance), hit, cv::CMP_EQ);
    cv::Mat tint(image.size(), image.type(), colour);
    cv::Mat blended;
    cv::addWeighted(image, 0.7, tint, 0.3, 0.0, blended);
    blended.copyTo(image, hit);
  }
}

void draw_objects(cv::Mat& image, const FrameRecord& f, const std::map<std::uint16_t, MotionState>& states,
                  double scale) {
  const int below_status_bar = static_cast<int>(60 * scale);
  for (const auto& b : f.trace.boxes) {
    const auto it = std::find_if(f.objects.begin(), f.objects.end(),
                                 [&](const auto& v) { return v.instance == b.instance; });
    const MotionState state = it == f.objects.end() ? MotionState::kUnknown : it->state;
    const cv::Scalar colour = state_colour(states.count(b.instance) ? states.at(b.instance) : state);
    cv::rectangle(image, b.box, colour, 2);
    char label[160];
    if (it != f.objects.end()) {
      std::snprintf(label, sizeof label, "#%u %s %s s=%.3g n=%d", unsigned{b.instance}, b.class_name.c_str(),
                    dynamic::to_string(state), it->score, it->points);
    } else {
      std::snprintf(label, sizeof label, "#%u %s", unsigned{b.instance}, b.class_name.c_str());
    }
    put_text(image, label, {b.box.x + 4, std::max(below_status_bar, b.box.y - 4)}, 0.5 * scale, colour);
  }
}

void draw_status(cv::Mat& image, const FrameRecord& f, double scale) {
  char line1[200];
  char line2[200];
  std::snprintf(line1, sizeof line1, "frame %lld  %s  inliers %d / %d (pass 1 / final)  keypoints %zu",
                static_cast<long long>(f.seq), to_string(f.state), f.counters.features_used_pass1,
                f.counters.features_used, f.trace.keypoints.size());
  std::snprintf(line2, sizeof line2,
                "mar %.2f  masked %.2f  pixel mask %s  pass 2 %s  keyframes %zu  points %zu", f.mar,
                f.masked_ratio, f.pixel_mask_used ? "YES" : "no",
                f.trace.pass2_used ? "used" : (f.trace.pass2_ran ? "rejected" : "-"),
                f.trace.keyframes_in_map, f.trace.points_in_map);
  const int bar = static_cast<int>(44 * scale);
  cv::Mat top = image(cv::Rect(0, 0, image.cols, std::min(bar, image.rows)));
  top *= 0.4;
  const cv::Scalar state_col = f.state == TrackingState::kOk           ? Palette::background_inlier()
                               : f.state == TrackingState::kRecovering ? Palette::unknown_object()
                                                                       : Palette::masked();
  put_text(image, line1, {6, static_cast<int>(18 * scale)}, 0.5 * scale, state_col);
  put_text(image, line2, {6, static_cast<int>(38 * scale)}, 0.5 * scale, cv::Scalar(255, 255, 255));
}

std::optional<cv::Point2d> top_point(const SE3& origin_inv, const SE3& pose) {
  const Eigen::Vector3d p = (origin_inv * pose).translation();
  return cv::Point2d(p.x(), p.z());
}

}  // namespace

cv::Rect2d bounds_of(const std::vector<cv::Point2d>& points) {
  if (points.empty()) return {};
  cv::Point2d lo = points.front();
  cv::Point2d hi = points.front();
  for (const auto& p : points) {
    lo.x = std::min(lo.x, p.x);
    lo.y = std::min(lo.y, p.y);
    hi.x = std::max(hi.x, p.x);
    hi.y = std::max(hi.y, p.y);
  }
  return {lo, hi};
}

TopViewTracks top_view_tracks(const DebugRecord& record, const std::vector<std::optional<SE3>>& gt) {
  TopViewTracks tracks;
  const std::size_t n = record.frames.size();
  tracks.estimate.resize(n);
  tracks.ground_truth.resize(n);
  auto gt_of = [&](std::size_t i) -> const std::optional<SE3>* {
    const auto seq = static_cast<std::size_t>(record.frames[i].seq);
    return seq < gt.size() && gt[seq] ? &gt[seq] : nullptr;
  };
  std::optional<SE3> est_origin;
  std::optional<SE3> gt_origin;
  for (std::size_t i = 0; i < n && !est_origin; ++i) {
    if (record.frames[i].state == TrackingState::kLost) continue;
    est_origin = record.frames[i].T_world_cam.inverse();
    if (const auto* g = gt_of(i)) gt_origin = (*g)->inverse();
  }
  for (std::size_t i = 0; i < n && !gt_origin; ++i) {
    if (const auto* g = gt_of(i)) gt_origin = (*g)->inverse();
  }
  std::vector<cv::Point2d> all{{0.0, 0.0}};
  for (std::size_t i = 0; i < n; ++i) {
    if (est_origin && record.frames[i].state != TrackingState::kLost) {
      tracks.estimate[i] = top_point(*est_origin, record.frames[i].T_world_cam);
      all.push_back(*tracks.estimate[i]);
    }
    if (const auto* g = gt_of(i); g && gt_origin) {
      tracks.ground_truth[i] = top_point(*gt_origin, **g);
      all.push_back(*tracks.ground_truth[i]);
    }
  }
  const cv::Rect2d b = bounds_of(all);
  const double side = std::max({b.width, b.height, 1.0}) * 1.15;
  const cv::Point2d centre(b.x + b.width / 2, b.y + b.height / 2);
  tracks.bounds = cv::Rect2d(centre.x - side / 2, centre.y - side / 2, side, side);
  return tracks;
}

cv::Mat render_top_view(const TopViewTracks& tracks, std::size_t index, int size) {
  cv::Mat panel(size, size, CV_8UC3, cv::Scalar(30, 30, 30));
  const double scale = size / tracks.bounds.width;
  auto px = [&](const cv::Point2d& p) {
    return cv::Point(static_cast<int>((p.x - tracks.bounds.x) * scale),
                     static_cast<int>(size - (p.y - tracks.bounds.y) * scale));
  };
  auto draw = [&](const std::vector<std::optional<cv::Point2d>>& track, const cv::Scalar& colour, int width) {
    std::optional<cv::Point> last;
    for (std::size_t i = 0; i <= index && i < track.size(); ++i) {
      if (!track[i]) {
        last.reset();
        continue;
      }
      const cv::Point p = px(*track[i]);
      if (last) cv::line(panel, *last, p, colour, width, cv::LINE_AA);
      last = p;
    }
    if (last) cv::circle(panel, *last, 5, colour, cv::FILLED, cv::LINE_AA);
  };
  draw(tracks.ground_truth, cv::Scalar(200, 200, 200), 5);
  draw(tracks.estimate, Palette::background_inlier(), 2);
  const double text = std::max(0.4, size / 900.0);
  put_text(panel, "top view (x right, z forward of frame 0)", {8, 20}, text, cv::Scalar(255, 255, 255));
  put_text(panel, "estimate", {8, 42}, text, Palette::background_inlier());
  put_text(panel, "ground truth", {8, 62}, text, cv::Scalar(200, 200, 200));
  const std::pair<const char*, cv::Scalar> legend[] = {
      {"keypoints: background used", Palette::background_inlier()},
      {"background not used", Palette::background_unused()},
      {"object static, used (pass 2)", Palette::static_unmasked()},
      {"masked", Palette::masked()},
      {"object moving", Palette::moving_keypoint()}};
  int y = size - 30 - static_cast<int>(std::size(legend)) * 20;
  for (const auto& [name, colour] : legend) put_text(panel, name, {8, y += 20}, text, colour);
  char grid[64];
  std::snprintf(grid, sizeof grid, "panel %.1f m wide", tracks.bounds.width);
  put_text(panel, grid, {8, size - 10}, text, cv::Scalar(255, 255, 255));
  return panel;
}

cv::Mat render_frame(const cv::Mat& left, const cv::Mat& instance_mask, const DebugRecord& record,
                     std::size_t index, const TopViewTracks& tracks) {
  const FrameRecord& f = record.frames.at(index);
  cv::Mat image;
  cv::cvtColor(left, image, cv::COLOR_GRAY2BGR);
  std::map<std::uint16_t, MotionState> states;
  for (const auto& v : f.objects) states[v.instance] = v.state;
  if (f.pixel_mask_used && !instance_mask.empty() && instance_mask.size() == left.size()) {
    draw_pixel_mask(image, instance_mask, states, f.trace.boxes);
  }
  const double scale = std::max(0.6, left.cols / 960.0);
  for (const auto& k : f.trace.keypoints) {
    const cv::Point p(cvRound(k.u_px), cvRound(k.v_px));
    const bool inlier = (k.flags & (f.trace.pass2_used ? slam::KeypointTrace::kInlierPass2
                                                       : slam::KeypointTrace::kInlierPass1)) != 0;
    const cv::Scalar colour = keypoint_colour(k, states, f.trace.pass2_used);
    cv::circle(image, p, inlier ? 3 : 2, colour, inlier ? cv::FILLED : 1, cv::LINE_AA);
  }
  draw_objects(image, f, states, scale);
  draw_status(image, f, scale);
  cv::Mat out(left.rows, left.cols + left.rows, CV_8UC3);
  image.copyTo(out(cv::Rect(0, 0, left.cols, left.rows)));
  render_top_view(tracks, index, left.rows).copyTo(out(cv::Rect(left.cols, 0, left.rows, left.rows)));
  return out;
}

}  // namespace sitepose::views
