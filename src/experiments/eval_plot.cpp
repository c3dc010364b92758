#include "sitepose/experiments/eval_plot.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace sitepose::experiments {
namespace {

const cv::Scalar kWhite(255, 255, 255);
const cv::Scalar kBlack(0, 0, 0);
const cv::Scalar kGridGray(225, 225, 225);
// Ground truth is drawn wide and light under the estimate, so it shows as a
// halo where they agree and as a separate path where they do not.
const cv::Scalar kGtGray(175, 175, 175);
constexpr int kGtThickness = 6;
const cv::Scalar kRmseRed(40, 40, 210);
const cv::Scalar kSeriesBlue(160, 90, 20);
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr double kTickScale = 0.45;
constexpr double kLabelScale = 0.55;
constexpr double kTitleScale = 0.6;
// Segments are not drawn across tracking gaps longer than this many frames.
constexpr std::size_t kMaxSegmentGapFrames = 5;

struct Ticks {
  std::vector<double> values;
  int decimals = 0;
};

// "Nice" ticks (1, 2, 5 x 10^k) covering [lo, hi], about `target` of them.
Ticks nice_ticks(double lo, double hi, int target) {
  Ticks ticks;
  const double span = std::max(hi - lo, 1e-9);
  const double raw = span / std::max(target, 1);
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = mag;
  for (const double m : {1.0, 2.0, 5.0, 10.0}) {
    step = m * mag;
    if (step >= raw) break;
  }
  ticks.decimals = std::max(0, static_cast<int>(-std::floor(std::log10(step) + 1e-9)));
  for (double v = std::ceil(lo / step - 1e-9) * step; v <= hi + 1e-9 * span; v += step) {
    ticks.values.push_back(std::abs(v) < 1e-12 * span ? 0.0 : v);
  }
  return ticks;
}

// Smallest nice number (1, 2, 2.5, 5 x 10^k) >= v.
double nice_ceil(double v) {
  if (!(v > 0.0)) return 1e-3;
  const double mag = std::pow(10.0, std::floor(std::log10(v)));
  for (const double m : {1.0, 2.0, 2.5, 5.0, 10.0}) {
    if (m * mag >= v * (1.0 - 1e-12)) return m * mag;
  }
  return 10.0 * mag;
}

void put_text(cv::Mat& img, const std::string& text, cv::Point org, double scale,
              const cv::Scalar& colour = kBlack) {
  cv::putText(img, text, org, kFont, scale, colour, 1, cv::LINE_AA);
}

// Text centred on `centre` (horizontally) with its baseline at centre.y.
void put_text_centred(cv::Mat& img, const std::string& text, cv::Point centre, double scale) {
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text, kFont, scale, 1, &baseline);
  put_text(img, text, {centre.x - size.width / 2, centre.y}, scale);
}

// Text right-aligned at x_right, vertically centred on y.
void put_text_right(cv::Mat& img, const std::string& text, int x_right, int y, double scale) {
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text, kFont, scale, 1, &baseline);
  put_text(img, text, {x_right - size.width, y + size.height / 2}, scale);
}

// Text rotated by 90 degrees (reading bottom to top), centred on `centre`.
void put_text_vertical(cv::Mat& img, const std::string& text, cv::Point centre, double scale) {
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text, kFont, scale, 1, &baseline);
  cv::Mat patch(size.height + baseline + 4, size.width + 4, CV_8UC3, kWhite);
  put_text(patch, text, {2, size.height + 2}, scale);
  cv::Mat rotated;
  cv::rotate(patch, rotated, cv::ROTATE_90_COUNTERCLOCKWISE);
  const cv::Rect roi(centre.x - rotated.cols / 2, centre.y - rotated.rows / 2, rotated.cols,
                     rotated.rows);
  if ((roi & cv::Rect(0, 0, img.cols, img.rows)) == roi) rotated.copyTo(img(roi));
}

// A colour table (TURBO) indexed by error / vmax in [0, 1].
class ErrorColours {
 public:
  explicit ErrorColours(double vmax_m) : vmax_m_(vmax_m) {
    cv::Mat ramp(1, 256, CV_8UC1);
    for (int i = 0; i < 256; ++i) ramp.at<unsigned char>(0, i) = static_cast<unsigned char>(i);
    cv::applyColorMap(ramp, table_, cv::COLORMAP_TURBO);
  }
  cv::Scalar operator()(double error_m) const {
    const int i = std::clamp(static_cast<int>(std::lround(255.0 * error_m / vmax_m_)), 0, 255);
    const cv::Vec3b c = table_.at<cv::Vec3b>(0, i);
    return {static_cast<double>(c[0]), static_cast<double>(c[1]), static_cast<double>(c[2])};
  }
  double vmax_m() const { return vmax_m_; }

 private:
  double vmax_m_;
  cv::Mat table_;
};

// Maps data coordinates into a pixel rectangle (y up).
struct Axes {
  cv::Rect area;
  double x0 = 0.0;
  double y0 = 0.0;
  double sx = 1.0;  // px per unit
  double sy = 1.0;
  cv::Point to_px(double x, double y) const {
    return {area.x + static_cast<int>(std::lround((x - x0) * sx)),
            area.y + area.height - static_cast<int>(std::lround((y - y0) * sy))};
  }
};

void draw_axes(cv::Mat& img, const Axes& ax, double x_lo, double x_hi, double y_lo, double y_hi,
               const std::string& x_label, const std::string& y_label) {
  const Ticks xt = nice_ticks(x_lo, x_hi, 7);
  const Ticks yt = nice_ticks(y_lo, y_hi, 6);
  const int bottom = ax.area.y + ax.area.height;
  for (const double v : xt.values) {
    const int x = ax.to_px(v, y_lo).x;
    cv::line(img, {x, ax.area.y}, {x, bottom}, kGridGray, 1);
    cv::line(img, {x, bottom}, {x, bottom + 5}, kBlack, 1);
    put_text_centred(img, fmt::format("{:.{}f}", v, xt.decimals), {x, bottom + 22}, kTickScale);
  }
  for (const double v : yt.values) {
    const int y = ax.to_px(x_lo, v).y;
    cv::line(img, {ax.area.x, y}, {ax.area.x + ax.area.width, y}, kGridGray, 1);
    cv::line(img, {ax.area.x - 5, y}, {ax.area.x, y}, kBlack, 1);
    put_text_right(img, fmt::format("{:.{}f}", v, yt.decimals), ax.area.x - 8, y, kTickScale);
  }
  cv::rectangle(img, ax.area, kBlack, 1);
  put_text_centred(img, x_label, {ax.area.x + ax.area.width / 2, bottom + 48}, kLabelScale);
  put_text_vertical(img, y_label, {ax.area.x - 62, ax.area.y + ax.area.height / 2}, kLabelScale);
}

void draw_colour_bar(cv::Mat& img, const cv::Rect& bar, const ErrorColours& colours) {
  for (int r = 0; r < bar.height; ++r) {
    const double e = colours.vmax_m() * (1.0 - static_cast<double>(r) / (bar.height - 1));
    cv::line(img, {bar.x, bar.y + r}, {bar.x + bar.width - 1, bar.y + r}, colours(e), 1);
  }
  cv::rectangle(img, bar, kBlack, 1);
  const Ticks ticks = nice_ticks(0.0, colours.vmax_m(), 5);
  for (const double v : ticks.values) {
    const int y = bar.y + bar.height - 1 -
                  static_cast<int>(std::lround(v / colours.vmax_m() * (bar.height - 1)));
    cv::line(img, {bar.x + bar.width, y}, {bar.x + bar.width + 4, y}, kBlack, 1);
    put_text(img, fmt::format("{:.{}f}", v, ticks.decimals), {bar.x + bar.width + 7, y + 5},
             kTickScale);
  }
  put_text_centred(img, "ATE [m]", {bar.x + bar.width / 2 + 8, bar.y - 10}, kLabelScale);
}

void draw_top_view(cv::Mat& img, const cv::Rect& panel, const io::Trajectory& gt,
                   const eval::EvalResult& result, const ErrorColours& colours) {
  // The two axes of largest ground-truth extent, in index order (x-z for a
  // y-down camera: x to the right, z up, i.e. seen from above).
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const auto& p : gt) {
    lo = lo.cwiseMin(p.T_world_cam.translation());
    hi = hi.cwiseMax(p.T_world_cam.translation());
  }
  const Eigen::Vector3d gt_extent = hi - lo;
  std::array<int, 3> order{0, 1, 2};
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return gt_extent[a] > gt_extent[b]; });
  const int ax_h = std::min(order[0], order[1]);
  const int ax_v = std::max(order[0], order[1]);
  for (const auto& p : result.poses) {
    lo = lo.cwiseMin(p.p_est_aligned_m);
    hi = hi.cwiseMax(p.p_est_aligned_m);
  }
  static constexpr std::array<const char*, 3> kAxisNames{"x", "y", "z"};

  const cv::Rect area(panel.x + 90, panel.y + 70, panel.width - 90 - 120, panel.height - 70 - 75);
  double span_h = std::max(hi[ax_h] - lo[ax_h], 1e-3);
  double span_v = std::max(hi[ax_v] - lo[ax_v], 1e-3);
  // Equal scale on both axes; 4 % padding; centre the data.
  const double scale = std::min(area.width / (1.08 * span_h), area.height / (1.08 * span_v));
  Axes ax;
  ax.area = area;
  ax.sx = ax.sy = scale;
  ax.x0 = 0.5 * (lo[ax_h] + hi[ax_h]) - 0.5 * area.width / scale;
  ax.y0 = 0.5 * (lo[ax_v] + hi[ax_v]) - 0.5 * area.height / scale;
  span_h = area.width / scale;
  span_v = area.height / scale;
  draw_axes(img, ax, ax.x0, ax.x0 + span_h, ax.y0, ax.y0 + span_v,
            fmt::format("{} [m]", kAxisNames[ax_h]), fmt::format("{} [m]", kAxisNames[ax_v]));

  std::vector<cv::Point> gt_px;
  gt_px.reserve(gt.size());
  for (const auto& p : gt) {
    const Eigen::Vector3d& t = p.T_world_cam.translation();
    gt_px.push_back(ax.to_px(t[ax_h], t[ax_v]));
  }
  cv::polylines(img, gt_px, false, kGtGray, kGtThickness, cv::LINE_AA);
  for (std::size_t k = 0; k < result.poses.size(); ++k) {
    const eval::PoseError& p = result.poses[k];
    const cv::Point px = ax.to_px(p.p_est_aligned_m[ax_h], p.p_est_aligned_m[ax_v]);
    if (k > 0 && p.gt_index - result.poses[k - 1].gt_index <= kMaxSegmentGapFrames) {
      const eval::PoseError& q = result.poses[k - 1];
      cv::line(img, ax.to_px(q.p_est_aligned_m[ax_h], q.p_est_aligned_m[ax_v]), px,
               colours(0.5 * (p.error_m + q.error_m)), 2, cv::LINE_AA);
    }
    cv::circle(img, px, 2, colours(p.error_m), cv::FILLED, cv::LINE_AA);
  }
  cv::circle(img, gt_px.front(), 6, kBlack, 2, cv::LINE_AA);
  put_text(img, "start", gt_px.front() + cv::Point(9, -6), kTickScale);

  // Legend in the top-left corner of the plot area.
  const cv::Point legend(area.x + 12, area.y + 20);
  cv::rectangle(img, {legend.x - 6, legend.y - 14}, {legend.x + 290, legend.y + 32}, kWhite,
                cv::FILLED);
  cv::rectangle(img, {legend.x - 6, legend.y - 14}, {legend.x + 290, legend.y + 32}, kBlack, 1);
  cv::line(img, legend + cv::Point(0, -4), legend + cv::Point(30, -4), kGtGray, kGtThickness,
           cv::LINE_AA);
  put_text(img, "ground truth", legend + cv::Point(40, 0), kTickScale);
  cv::line(img, legend + cv::Point(0, 18), legend + cv::Point(30, 18),
           colours(0.5 * colours.vmax_m()), 2, cv::LINE_AA);
  put_text(img, "estimate, aligned (colour = ATE)", legend + cv::Point(40, 22), kTickScale);

  put_text_centred(img, fmt::format("Top view ({}-{} plane, equal scale)", kAxisNames[ax_h],
                                    kAxisNames[ax_v]),
                   {area.x + area.width / 2, panel.y + 55}, kLabelScale);
  draw_colour_bar(img, cv::Rect(area.x + area.width + 30, area.y + 20, 22, area.height - 20),
                  colours);
}

void draw_error_over_time(cv::Mat& img, const cv::Rect& panel, const eval::EvalResult& result,
                          const ErrorColours& colours) {
  const cv::Rect area(panel.x + 90, panel.y + 70, panel.width - 90 - 30, panel.height - 70 - 75);
  const double t0 = result.poses.front().t_gt_s;
  const double t1 = std::max(result.poses.back().t_gt_s, t0 + 1e-3);
  const double vmax = colours.vmax_m();
  Axes ax;
  ax.area = area;
  ax.x0 = 0.0;
  ax.y0 = 0.0;
  ax.sx = area.width / (t1 - t0);
  ax.sy = area.height / (1.05 * vmax);
  draw_axes(img, ax, 0.0, t1 - t0, 0.0, 1.05 * vmax, "time since first pose [s]", "ATE [m]");
  for (std::size_t k = 0; k < result.poses.size(); ++k) {
    const eval::PoseError& p = result.poses[k];
    const cv::Point px = ax.to_px(p.t_gt_s - t0, p.error_m);
    if (k > 0 && p.gt_index - result.poses[k - 1].gt_index <= kMaxSegmentGapFrames) {
      const eval::PoseError& q = result.poses[k - 1];
      cv::line(img, ax.to_px(q.t_gt_s - t0, q.error_m), px, kSeriesBlue, 1, cv::LINE_AA);
    }
    cv::circle(img, px, 2, colours(p.error_m), cv::FILLED, cv::LINE_AA);
  }
  // Dashed RMSE line with its value.
  const int y = ax.to_px(0.0, result.ate_m.rmse).y;
  for (int x = area.x; x < area.x + area.width; x += 14) {
    cv::line(img, {x, y}, {std::min(x + 8, area.x + area.width), y}, kRmseRed, 2);
  }
  // RMSE legend in a boxed corner, so it never sits on the data.
  const cv::Point legend(area.x + area.width - 200, area.y + 12);
  cv::rectangle(img, legend, legend + cv::Point(188, 28), kWhite, cv::FILLED);
  cv::rectangle(img, legend, legend + cv::Point(188, 28), kBlack, 1);
  cv::line(img, legend + cv::Point(8, 14), legend + cv::Point(18, 14), kRmseRed, 2);
  cv::line(img, legend + cv::Point(24, 14), legend + cv::Point(34, 14), kRmseRed, 2);
  put_text(img, fmt::format("rmse {:.4f} m", result.ate_m.rmse), legend + cv::Point(42, 19),
           kLabelScale);
  put_text_centred(img, "ATE over time", {area.x + area.width / 2, panel.y + 55}, kLabelScale);
}

}  // namespace

Expected<cv::Mat> render_eval_plot(const io::Trajectory& gt, const eval::EvalResult& result,
                                   const PlotOptions& options) {
  if (result.poses.empty() || gt.empty()) {
    return make_error(ErrorCode::kInvalidArgument,
                      "render_eval_plot: the evaluation has no associated poses to draw");
  }
  if (options.width_px < 800 || options.height_px < 400) {
    return make_error(ErrorCode::kInvalidArgument,
                      fmt::format("render_eval_plot: image size {}x{} px; at least 800x400 needed",
                                  options.width_px, options.height_px));
  }
  cv::Mat img(options.height_px, options.width_px, CV_8UC3, kWhite);
  const ErrorColours colours(nice_ceil(result.ate_m.max));
  const int split = options.width_px * 11 / 20;
  draw_top_view(img, cv::Rect(0, 0, split, options.height_px), gt, result, colours);
  draw_error_over_time(img, cv::Rect(split, 0, options.width_px - split, options.height_px),
                       result, colours);
  std::string title = fmt::format(
      "ATE rmse {:.4f} m  mean {:.4f}  max {:.4f}  |  RPE {:g} s: {:.4f} m, {:.3f} deg  |  "
      "coverage {:.1f} %",
      result.ate_m.rmse, result.ate_m.mean, result.ate_m.max, result.rpe_time.spec.delta_time_s,
      result.rpe_time.translation_m.rmse, result.rpe_time.rotation_deg.rmse,
      100.0 * result.coverage);
  if (result.time_offset_searched) {
    title += fmt::format("  |  time offset {:+.3f} s", result.time_offset_s);
  }
  put_text_centred(img, title, {options.width_px / 2, 26}, kTitleScale);
  return img;
}

Status write_eval_plot(const std::string& path, const io::Trajectory& gt, const eval::EvalResult& result,
                       const PlotOptions& options) {
  const std::string ext = ".png";
  if (path.size() <= ext.size() ||
      path.compare(path.size() - ext.size(), ext.size(), ext) != 0) {
    return make_error(ErrorCode::kInvalidArgument,
                      fmt::format("plot path '{}': expected a file name ending in .png", path));
  }
  SITEPOSE_TRY(const cv::Mat image, render_eval_plot(gt, result, options));
  bool written = false;
  std::string reason = "cv::imwrite returned false (does the directory exist?)";
  try {
    written = cv::imwrite(path, image);
  } catch (const cv::Exception& e) {
    reason = e.what();
  }
  if (!written) {
    return make_error(ErrorCode::kIoError,
                      fmt::format("could not write plot '{}': {}", path, reason));
  }
  return ok_status();
}

}  // namespace sitepose::experiments
