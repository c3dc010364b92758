#include "sitepose/experiments/eval_plot.hpp"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "../eval/test_trajectories.hpp"

namespace sitepose::experiments {
namespace {

using eval::testing::curvy_trajectory;
using eval::testing::sparse_estimate;

TEST(EvalPlot, RendersBothPanels) {
  const io::Trajectory gt = curvy_trajectory(200, 10.0);
  const auto r = eval::evaluate(gt, sparse_estimate(gt), eval::EvalOptions{});
  ASSERT_TRUE(r.has_value());
  const auto img = render_eval_plot(gt, *r);
  ASSERT_TRUE(img.has_value()) << img.error().message;
  EXPECT_EQ(img->cols, 1600);
  EXPECT_EQ(img->rows, 800);
  EXPECT_EQ(img->type(), CV_8UC3);
  // Non-trivial: a good share of non-white pixels in each half.
  const auto non_white = [](const cv::Mat& m) {
    int n = 0;
    for (int y = 0; y < m.rows; ++y)
      for (int x = 0; x < m.cols; ++x)
        if (m.at<cv::Vec3b>(y, x) != cv::Vec3b(255, 255, 255)) ++n;
    return n;
  };
  EXPECT_GT(non_white((*img)(cv::Rect(0, 0, 800, 800))), 20000);
  EXPECT_GT(non_white((*img)(cv::Rect(900, 0, 700, 800))), 20000);
  eval::EvalResult empty;
  EXPECT_FALSE(render_eval_plot(gt, empty).has_value());
  EXPECT_FALSE(render_eval_plot(gt, *r, PlotOptions{400, 300}).has_value());
}

}  // namespace
}  // namespace sitepose::experiments
