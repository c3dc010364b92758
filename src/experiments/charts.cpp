#include "sitepose/experiments/charts.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace sitepose::experiments {
namespace {

struct Axes {
  double x0 = 0, x1 = 1, y0 = 0, y1 = 1;
  cv::Rect plot;
  cv::Point to_px(double x, double y) const {
    const double fx = (x - x0) / (x1 - x0);
    const double fy = (y - y0) / (y1 - y0);
    return {plot.x + static_cast<int>(std::lround(fx * plot.width)),
            plot.y + plot.height - static_cast<int>(std::lround(fy * plot.height))};
  }
};

std::string format_tick(double v) {
  char buf[32];
  if (std::abs(v) >= 100 || v == std::floor(v)) {
    std::snprintf(buf, sizeof(buf), "%.0f", v);
  } else if (std::abs(v) >= 1) {
    std::snprintf(buf, sizeof(buf), "%.1f", v);
  } else {
    std::snprintf(buf, sizeof(buf), "%.3g", v);
  }
  return buf;
}

void draw_frame(cv::Mat& img, const Axes& axes, const ChartOptions& options) {
  const cv::Scalar black(0, 0, 0), grid(220, 220, 220);
  for (int i = 0; i <= 5; ++i) {
    const double x = axes.x0 + (axes.x1 - axes.x0) * i / 5.0;
    const double y = axes.y0 + (axes.y1 - axes.y0) * i / 5.0;
    const cv::Point px = axes.to_px(x, axes.y0), py = axes.to_px(axes.x0, y);
    cv::line(img, px, {px.x, axes.plot.y}, grid, 1);
    cv::line(img, py, {axes.plot.x + axes.plot.width, py.y}, grid, 1);
    cv::putText(img, format_tick(x), {px.x - 12, px.y + 20}, cv::FONT_HERSHEY_SIMPLEX, 0.45, black, 1,
                cv::LINE_AA);
    cv::putText(img, format_tick(y), {py.x - 55, py.y + 5}, cv::FONT_HERSHEY_SIMPLEX, 0.45, black, 1, cv::LINE_AA);
  }
  cv::rectangle(img, axes.plot, black, 1);
  cv::putText(img, options.title, {axes.plot.x, 30}, cv::FONT_HERSHEY_SIMPLEX, 0.65, black, 1, cv::LINE_AA);
  cv::putText(img, options.x_label, {axes.plot.x + axes.plot.width / 2 - 60, img.rows - 15},
              cv::FONT_HERSHEY_SIMPLEX, 0.55, black, 1, cv::LINE_AA);
  cv::putText(img, options.y_label, {10, axes.plot.y - 12}, cv::FONT_HERSHEY_SIMPLEX, 0.55, black, 1,
              cv::LINE_AA);
}

}  // namespace

cv::Mat render_line_chart(const std::vector<ChartSeries>& series, const ChartOptions& options) {
  cv::Mat img(options.height_px, options.width_px, CV_8UC3, cv::Scalar(255, 255, 255));
  Axes axes;
  axes.plot = cv::Rect(80, 60, options.width_px - 110, options.height_px - 130);
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
  for (const auto& s : series) {
    for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      x0 = std::min(x0, s.x[i]);
      x1 = std::max(x1, s.x[i]);
      y0 = std::min(y0, s.y[i]);
      y1 = std::max(y1, s.y[i]);
    }
  }
  if (!std::isfinite(x0)) x0 = 0, x1 = 1, y0 = 0, y1 = 1;
  if (options.draw_diagonal) x0 = y0 = 0.0, x1 = y1 = 1.0;
  y0 = std::min(y0, 0.0);
  if (x1 <= x0) x1 = x0 + 1.0;
  if (y1 <= y0) y1 = y0 + 1.0;
  axes.x0 = x0;
  axes.x1 = x1;
  axes.y0 = y0;
  axes.y1 = y1 + 0.05 * (y1 - y0);
  draw_frame(img, axes, options);
  if (options.draw_diagonal) {
    cv::line(img, axes.to_px(0, 0), axes.to_px(1, 1), cv::Scalar(180, 180, 180), 1, cv::LINE_AA);
  }
  int legend_y = axes.plot.y + 20;
  for (const auto& s : series) {
    std::vector<cv::Point> pts;
    for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (std::isfinite(s.x[i]) && std::isfinite(s.y[i])) pts.push_back(axes.to_px(s.x[i], s.y[i]));
    }
    if (pts.size() >= 2) cv::polylines(img, pts, false, s.color_bgr, 2, cv::LINE_AA);
    if (options.markers) {
      for (const auto& p : pts) cv::circle(img, p, 3, s.color_bgr, cv::FILLED, cv::LINE_AA);
    }
    const cv::Point l(axes.plot.x + axes.plot.width - 340, legend_y);
    cv::line(img, l, {l.x + 25, l.y}, s.color_bgr, 3);
    cv::putText(img, s.name, {l.x + 32, l.y + 5}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 1,
                cv::LINE_AA);
    legend_y += 22;
  }
  return img;
}

cv::Mat render_bar_chart(const std::vector<std::string>& labels, const std::vector<double>& values,
                         const ChartOptions& options) {
  cv::Mat img(options.height_px, options.width_px, CV_8UC3, cv::Scalar(255, 255, 255));
  Axes axes;
  axes.plot = cv::Rect(80, 60, options.width_px - 110, options.height_px - 130);
  double y1 = 0.0;
  for (double v : values) {
    if (std::isfinite(v)) y1 = std::max(y1, v);
  }
  axes.x0 = 0;
  axes.x1 = static_cast<double>(std::max<std::size_t>(1, labels.size()));
  axes.y0 = 0;
  axes.y1 = y1 > 0 ? 1.15 * y1 : 1.0;
  const cv::Scalar black(0, 0, 0);
  cv::rectangle(img, axes.plot, black, 1);
  cv::putText(img, options.title, {axes.plot.x, 30}, cv::FONT_HERSHEY_SIMPLEX, 0.65, black, 1, cv::LINE_AA);
  cv::putText(img, options.y_label, {10, axes.plot.y - 12}, cv::FONT_HERSHEY_SIMPLEX, 0.55, black, 1,
              cv::LINE_AA);
  for (int i = 0; i <= 5; ++i) {
    const double y = axes.y1 * i / 5.0;
    const cv::Point p = axes.to_px(0, y);
    cv::line(img, p, {axes.plot.x + axes.plot.width, p.y}, cv::Scalar(220, 220, 220), 1);
    cv::putText(img, format_tick(y), {p.x - 55, p.y + 5}, cv::FONT_HERSHEY_SIMPLEX, 0.45, black, 1, cv::LINE_AA);
  }
  const cv::Scalar colors[] = {{200, 120, 40}, {40, 160, 40}, {40, 40, 200}, {160, 40, 160}, {40, 160, 200}};
  for (std::size_t i = 0; i < labels.size() && i < values.size(); ++i) {
    const cv::Point a = axes.to_px(i + 0.2, 0);
    const cv::Point b = axes.to_px(i + 0.8, std::isfinite(values[i]) ? values[i] : 0.0);
    cv::rectangle(img, cv::Rect(a, b), colors[i % 5], cv::FILLED);
    cv::putText(img, labels[i], {a.x, axes.plot.y + axes.plot.height + 22}, cv::FONT_HERSHEY_SIMPLEX, 0.5, black,
                1, cv::LINE_AA);
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%.4g", values[i]);
    cv::putText(img, buf, {a.x, b.y - 6}, cv::FONT_HERSHEY_SIMPLEX, 0.5, black, 1, cv::LINE_AA);
  }
  return img;
}

Status write_png(const std::string& path, const cv::Mat& image) {
  bool ok = false;
  try {
    ok = cv::imwrite(path, image);
  } catch (const cv::Exception& e) {
    return make_error(ErrorCode::kIoError, "cannot write " + path + ": " + e.what());
  }
  if (!ok) return make_error(ErrorCode::kIoError, "cannot write " + path);
  return ok_status();
}

Status write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  if (!out) return make_error(ErrorCode::kIoError, "cannot write " + path);
  out << text;
  if (!out) return make_error(ErrorCode::kIoError, "write failed: " + path);
  return ok_status();
}

}  // namespace sitepose::experiments
