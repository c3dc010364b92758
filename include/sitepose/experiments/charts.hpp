#pragma once
// Line and bar charts of the `sitepose ablate ...` figures (OpenCV), and
// writing them and their CSV tables.

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "sitepose/core/expected.hpp"

namespace sitepose::experiments {

struct ChartSeries {
  std::string name;
  std::vector<double> x;
  std::vector<double> y;
  cv::Scalar color_bgr{0, 0, 0};
};

struct ChartOptions {
  std::string title;
  std::string x_label;
  std::string y_label;
  int width_px = 900;
  int height_px = 600;
  bool draw_diagonal = false;  // ROC: the chance line from (0,0) to (1,1)
  bool markers = true;
};

// Line chart of the series on shared axes (ranges from the data, NaN points
// skipped); a legend names the series. 8-bit BGR.
cv::Mat render_line_chart(const std::vector<ChartSeries>& series, const ChartOptions& options);

// Bar chart: one bar per label, value printed above it.
cv::Mat render_bar_chart(const std::vector<std::string>& labels, const std::vector<double>& values,
                         const ChartOptions& options);

// Writes a PNG (kIoError naming the path on failure).
Status write_png(const std::string& path, const cv::Mat& image);
// Writes a text file (CSV) (kIoError naming the path on failure).
Status write_text(const std::string& path, const std::string& text);

}  // namespace sitepose::experiments
