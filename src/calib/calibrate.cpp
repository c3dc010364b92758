// calibrate_stereo: corner search over the views, then the OpenCV fits.

#include <map>
#include <opencv2/calib3d.hpp>
#include <set>

#include "sitepose/calib/stereo_calibrate.hpp"

namespace sitepose::calib {

namespace {

struct Observations {
  std::vector<std::vector<cv::Point3f>> object;
  std::vector<std::vector<cv::Point2f>> left;
  std::vector<std::vector<cv::Point2f>> right;
  std::vector<std::size_t> view_index;  // into CalibrationReport::views
  cv::Size size;
};

// The corners both cameras see, in the left image's order, with their
// board points.
struct CommonCorners {
  std::vector<cv::Point3f> object;
  std::vector<cv::Point2f> left;
  std::vector<cv::Point2f> right;
};

CommonCorners common_corners(const BoardCorners& left, const BoardCorners& right,
                             const std::vector<cv::Point3f>& board) {
  std::map<int, cv::Point2f> right_by_id;
  for (std::size_t i = 0; i < right.ids.size(); ++i) right_by_id.emplace(right.ids[i], right.points_px[i]);
  CommonCorners common;
  for (std::size_t i = 0; i < left.ids.size(); ++i) {
    const int id = left.ids[i];
    const auto twin = right_by_id.find(id);
    if (twin == right_by_id.end() || id < 0 || static_cast<std::size_t>(id) >= board.size()) continue;
    common.object.push_back(board[static_cast<std::size_t>(id)]);
    common.left.push_back(left.points_px[i]);
    common.right.push_back(twin->second);
  }
  return common;
}

// Why a view with these corners is not used ("" when it is).
std::string why_not_used(const BoardCorners& left, const BoardCorners& right, const CommonCorners& common,
                         const BoardSpec& board, const CalibrateOptions& options) {
  if (left.empty() || right.empty()) {
    return left.empty() && right.empty() ? "board not found in either image"
           : left.empty()                ? "board not found in the left image"
                                         : "board not found in the right image";
  }
  if (board.kind != BoardKind::kCharuco) return "";
  if (static_cast<int>(common.object.size()) < options.min_common_corners) {
    return std::to_string(common.object.size()) + " ChArUco corners seen by both cameras, fewer than " +
           std::to_string(options.min_common_corners);
  }
  // Corners on one line of the board do not fix its pose.
  std::set<float> xs, ys;
  for (const cv::Point3f& p : common.object) {
    xs.insert(p.x);
    ys.insert(p.y);
  }
  if (xs.size() < 2 || ys.size() < 2) return "the ChArUco corners seen by both cameras lie on one line";
  return "";
}

// Corner search in one view; records the result and, when the board is
// found in both images, the observations.
Status observe_view(const CalibrationView& view, const BoardSpec& board,
                    const std::vector<cv::Point3f>& points, const CalibrateOptions& options,
                    Observations& obs, ViewResult& result) {
  result.name = view.name;
  const cv::Size size = view.left.size();
  if (view.right.size() != size) {
    return make_error(ErrorCode::kInvalidArgument,
                      "view " + view.name + ": left and right images differ in size");
  }
  if (obs.size.area() == 0) obs.size = size;
  if (size != obs.size) {
    return make_error(ErrorCode::kInvalidArgument,
                      "view " + view.name + ": " + std::to_string(size.width) + "x" +
                          std::to_string(size.height) + ", the first view was " +
                          std::to_string(obs.size.width) + "x" + std::to_string(obs.size.height));
  }
  const BoardCorners left = find_board_corners(view.left, board);
  const BoardCorners right = find_board_corners(view.right, board);
  CommonCorners common = common_corners(left, right, points);
  result.why_skipped = why_not_used(left, right, common, board, options);
  if (!result.why_skipped.empty()) return ok_status();
  result.used = true;
  obs.object.push_back(std::move(common.object));
  obs.left.push_back(std::move(common.left));
  obs.right.push_back(std::move(common.right));
  return ok_status();
}

Status fit(const Observations& obs, const CalibrateOptions& options, CalibrationReport& report) {
  StereoCalibration& c = report.calibration;
  c.image_size = obs.size;
  const int mono_flags = options.fix_k3 ? cv::CALIB_FIX_K3 : 0;
  std::vector<cv::Mat> rvecs, tvecs;
  try {
    report.rms_left_px =
        cv::calibrateCamera(obs.object, obs.left, obs.size, c.K1, c.D1, rvecs, tvecs, mono_flags);
    report.rms_right_px =
        cv::calibrateCamera(obs.object, obs.right, obs.size, c.K2, c.D2, rvecs, tvecs, mono_flags);
    cv::Mat E, F, per_view;
    c.rms_px =
        cv::stereoCalibrate(obs.object, obs.left, obs.right, c.K1, c.D1, c.K2, c.D2, obs.size, c.R, c.T, E, F,
                            per_view, mono_flags | cv::CALIB_USE_INTRINSIC_GUESS,
                            cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-9));
    for (int i = 0; i < per_view.rows; ++i) {
      ViewResult& v = report.views[obs.view_index[static_cast<std::size_t>(i)]];
      v.rms_left_px = per_view.at<double>(i, 0);
      v.rms_right_px = per_view.at<double>(i, 1);
    }
  } catch (const cv::Exception& e) {
    return make_error(ErrorCode::kRuntime, std::string("OpenCV calibration failed: ") + e.what());
  }
  c.K1.convertTo(c.K1, CV_64F);
  c.K2.convertTo(c.K2, CV_64F);
  c.D1.convertTo(c.D1, CV_64F);
  c.D2.convertTo(c.D2, CV_64F);
  c.T = c.T.reshape(1, 3);
  return compute_rectification(c);
}

}  // namespace

Expected<CalibrationReport> calibrate_stereo(
    std::size_t count, const std::function<Expected<CalibrationView>(std::size_t)>& load,
    const BoardSpec& board, const CalibrateOptions& options) {
  CalibrationReport report;
  Observations obs;
  report.views.resize(count);
  const std::vector<cv::Point3f> points = board_points(board);
  for (std::size_t i = 0; i < count; ++i) {
    SITEPOSE_TRY(const CalibrationView view, load(i));
    SITEPOSE_TRY_STATUS(observe_view(view, board, points, options, obs, report.views[i]));
    if (report.views[i].used) obs.view_index.push_back(i);
    if (options.progress) options.progress(static_cast<int>(i + 1), static_cast<int>(count), report.views[i]);
  }
  report.views_used = static_cast<int>(obs.object.size());
  const int needed = std::max(options.min_views, 3);
  if (report.views_used < needed) {
    return make_error(ErrorCode::kInvalidArgument,
                      "the board (" + std::to_string(board.cols) + "x" + std::to_string(board.rows) +
                          " inner corners) was found in both images of " + std::to_string(report.views_used) +
                          " of " + std::to_string(count) + " views; at least " + std::to_string(needed) +
                          " are needed (check --board, lighting and focus)");
  }
  SITEPOSE_TRY_STATUS(fit(obs, options, report));
  return report;
}

}  // namespace sitepose::calib
