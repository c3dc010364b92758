#include "sitepose/calib/stereo_calibrate.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "sitepose/calib/rectifier.hpp"
#include "sitepose/testing/charuco_target.hpp"
#include "sitepose/testing/checkerboard.hpp"

namespace sitepose::calib {
namespace {

using testing::CheckerboardSpec;
using testing::StereoRigTruth;

BoardSpec board_of(const CheckerboardSpec& spec) {
  return {BoardKind::kChessboard, spec.cols, spec.rows, spec.square_m, {}};
}

std::function<Expected<CalibrationView>(std::size_t)> loader(
    const std::vector<std::pair<cv::Mat, cv::Mat>>& views) {
  return [&views](std::size_t i) -> Expected<CalibrationView> {
    return CalibrationView{"view" + std::to_string(i), views[i].first, views[i].second};
  };
}

// One calibration of the rendered set, shared by the accuracy checks.
class RenderedCalibration : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    rig_ = new StereoRigTruth(testing::test_stereo_rig());
    views_ = new std::vector<std::pair<cv::Mat, cv::Mat>>(testing::render_calibration_set(*rig_, spec_));
    auto report = calibrate_stereo(views_->size(), loader(*views_), board_of(spec_), {});
    ASSERT_TRUE(report) << report.error().message;
    report_ = new CalibrationReport(std::move(*report));
    const StereoCalibration& c = report_->calibration;
    std::printf(
        "fx %.3f / %.3f  fy %.3f / %.3f  cx %.3f / %.3f  cy %.3f / %.3f  baseline %.5f / %.5f m  "
        "rms %.3f px\n",
        c.K1.at<double>(0, 0), rig_->K_left(0, 0), c.K1.at<double>(1, 1), rig_->K_left(1, 1),
        c.K1.at<double>(0, 2), rig_->K_left(0, 2), c.K1.at<double>(1, 2), rig_->K_left(1, 2), cv::norm(c.T),
        rig_->baseline_m(), c.rms_px);
  }
  static void TearDownTestSuite() {
    delete report_;
    delete views_;
    delete rig_;
  }
  static inline const CheckerboardSpec spec_{};
  static inline StereoRigTruth* rig_ = nullptr;
  static inline std::vector<std::pair<cv::Mat, cv::Mat>>* views_ = nullptr;
  static inline CalibrationReport* report_ = nullptr;
};

TEST_F(RenderedCalibration, UsesEveryViewWithSubPixelResiduals) {
  ASSERT_NE(report_, nullptr);
  EXPECT_EQ(report_->views_used, 10);
  for (const ViewResult& v : report_->views) {
    EXPECT_TRUE(v.used) << v.name << ": " << v.why_skipped;
    EXPECT_LT(v.rms_left_px, 0.3) << v.name;
    EXPECT_LT(v.rms_right_px, 0.3) << v.name;
  }
  EXPECT_LT(report_->calibration.rms_px, 0.3);
}

TEST_F(RenderedCalibration, RecoversFocalLengthsWithinHalfAPercent) {
  ASSERT_NE(report_, nullptr);
  const StereoCalibration& c = report_->calibration;
  for (auto [est, truth] : {std::pair{&c.K1, &rig_->K_left}, std::pair{&c.K2, &rig_->K_right}}) {
    EXPECT_NEAR(est->at<double>(0, 0), (*truth)(0, 0), 0.005 * (*truth)(0, 0));
    EXPECT_NEAR(est->at<double>(1, 1), (*truth)(1, 1), 0.005 * (*truth)(1, 1));
  }
}

TEST_F(RenderedCalibration, RecoversPrincipalPointsWithinThreePixels) {
  ASSERT_NE(report_, nullptr);
  const StereoCalibration& c = report_->calibration;
  for (auto [est, truth] : {std::pair{&c.K1, &rig_->K_left}, std::pair{&c.K2, &rig_->K_right}}) {
    EXPECT_NEAR(est->at<double>(0, 2), (*truth)(0, 2), 3.0);
    EXPECT_NEAR(est->at<double>(1, 2), (*truth)(1, 2), 3.0);
  }
}

TEST_F(RenderedCalibration, RecoversBaselineWithinOnePercentAndTheRelativeRotation) {
  ASSERT_NE(report_, nullptr);
  const StereoCalibration& c = report_->calibration;
  const double baseline = cv::norm(c.T);
  EXPECT_NEAR(baseline, rig_->baseline_m(), 0.01 * rig_->baseline_m());
  EXPECT_LT(c.T.at<double>(0), 0.0) << "the right camera sits at +x of the left";
  const cv::Mat dR = c.R * cv::Mat(rig_->R_right_left).t();
  cv::Mat rvec;
  cv::Rodrigues(dR, rvec);
  EXPECT_LT(cv::norm(rvec) * 180.0 / CV_PI, 0.1);
  auto camera = rectified_camera(c);
  ASSERT_TRUE(camera) << camera.error().message;
  EXPECT_NEAR(camera->baseline_m, rig_->baseline_m(), 0.01 * rig_->baseline_m());
}

TEST_F(RenderedCalibration, RectifiedCornersLieOnTheSameRows) {
  ASSERT_NE(report_, nullptr);
  auto rectifier = StereoRectifier::create(report_->calibration);
  ASSERT_TRUE(rectifier) << rectifier.error().message;
  cv::Mat left, right;
  ASSERT_TRUE(rectifier->rectify((*views_)[0].first, (*views_)[0].second, left, right));
  const auto cl = find_board_corners(left, board_of(spec_)).points_px;
  const auto cr = find_board_corners(right, board_of(spec_)).points_px;
  ASSERT_EQ(cl.size(), cr.size());
  ASSERT_FALSE(cl.empty());
  double worst = 0.0;
  for (std::size_t i = 0; i < cl.size(); ++i) {
    worst = std::max(worst, static_cast<double>(std::abs(cl[i].y - cr[i].y)));
    EXPECT_GT(cl[i].x, cr[i].x) << "positive disparity";
  }
  EXPECT_LT(worst, 0.5);
  // A wrong-size image is refused, naming the expected size.
  auto st = rectifier->rectify(cv::Mat(10, 10, CV_8UC1), cv::Mat(10, 10, CV_8UC1), left, right);
  ASSERT_FALSE(st);
  EXPECT_NE(st.error().message.find("640x480"), std::string::npos) << st.error().message;
}

TEST(StereoCalibrate, NamesAndSkipsViewsWithoutTheBoard) {
  const StereoRigTruth rig = testing::test_stereo_rig();
  const CheckerboardSpec spec;
  auto views = testing::render_calibration_set(rig, spec);
  views[3].second = cv::Mat(rig.size, CV_8UC1, cv::Scalar(110));  // right camera covered
  views[7].first = cv::Mat(rig.size, CV_8UC1, cv::Scalar(110));
  views[7].second = cv::Mat(rig.size, CV_8UC1, cv::Scalar(110));
  std::vector<std::string> progress;
  CalibrateOptions options;
  options.progress = [&progress](int done, int total, const ViewResult& v) {
    progress.push_back(std::to_string(done) + "/" + std::to_string(total) + " " + v.name);
  };
  auto report = calibrate_stereo(views.size(), loader(views), board_of(spec), options);
  ASSERT_TRUE(report) << report.error().message;
  EXPECT_EQ(report->views_used, 8);
  EXPECT_FALSE(report->views[3].used);
  EXPECT_EQ(report->views[3].why_skipped, "board not found in the right image");
  EXPECT_EQ(report->views[7].why_skipped, "board not found in either image");
  ASSERT_EQ(progress.size(), 10u);
  EXPECT_EQ(progress.back(), "10/10 view9");
}

TEST(StereoCalibrate, TooFewViewsIsAnInputErrorThatSaysWhy) {
  const StereoRigTruth rig = testing::test_stereo_rig();
  const CheckerboardSpec spec;
  auto views = testing::render_calibration_set(rig, spec, 3);
  views[2].first = cv::Mat(rig.size, CV_8UC1, cv::Scalar(110));
  auto report = calibrate_stereo(views.size(), loader(views), board_of(spec), {});
  ASSERT_FALSE(report);
  EXPECT_EQ(report.error().exit_status(), 2);
  EXPECT_NE(report.error().message.find("2 of 3 views"), std::string::npos) << report.error().message;
  EXPECT_NE(report.error().message.find("at least 5"), std::string::npos) << report.error().message;
}

TEST(StereoCalibrate, ParsesBoardSpecs) {
  auto b = parse_board("9x6", 0.025);
  ASSERT_TRUE(b);
  EXPECT_EQ(b->cols, 9);
  EXPECT_EQ(b->rows, 6);
  EXPECT_FALSE(parse_board("9", 0.025));
  EXPECT_FALSE(parse_board("9x", 0.025));
  EXPECT_FALSE(parse_board("1x6", 0.025));
  EXPECT_FALSE(parse_board("7x7", 0.025));
  EXPECT_FALSE(parse_board("-9x6", 0.025));
  EXPECT_FALSE(parse_board("9x6", 0.0));
  const auto points = board_points(*b);
  ASSERT_EQ(points.size(), 54u);
  EXPECT_FLOAT_EQ(points[10].x, 0.025f);
  EXPECT_FLOAT_EQ(points[10].y, 0.025f);
}

// A ChArUco board of 9x6 inner corners (10 x 7 squares of 35 mm, 26 mm
// markers of DICT_5X5_100) and its rendered set.
BoardSpec charuco_spec() {
  auto board = parse_board("9x6", 0.035, CharucoMarkers{0.026, "DICT_5X5_100"});
  EXPECT_TRUE(board) << board.error().message;
  return board ? *board : BoardSpec{};
}

std::vector<std::pair<cv::Mat, cv::Mat>> charuco_views(const StereoRigTruth& rig) {
  return testing::render_calibration_set(
      rig, testing::charuco_target(9, 6, 0.035, 0.026, cv::aruco::DICT_5X5_100));
}

TEST(StereoCalibrateCharuco, RecoversTheRigWithinTheChessboardBounds) {
  const StereoRigTruth rig = testing::test_stereo_rig();
  const auto views = charuco_views(rig);
  auto report = calibrate_stereo(views.size(), loader(views), charuco_spec(), {});
  ASSERT_TRUE(report) << report.error().message;
  const StereoCalibration& c = report->calibration;
  std::printf("charuco: fx %.3f / %.3f  cx %.3f / %.3f  baseline %.5f / %.5f m  rms %.3f px, %d views\n",
              c.K1.at<double>(0, 0), rig.K_left(0, 0), c.K1.at<double>(0, 2), rig.K_left(0, 2), cv::norm(c.T),
              rig.baseline_m(), c.rms_px, report->views_used);
  EXPECT_EQ(report->views_used, 10);
  EXPECT_LT(c.rms_px, 0.3);
  for (auto [est, truth] : {std::pair{&c.K1, &rig.K_left}, std::pair{&c.K2, &rig.K_right}}) {
    EXPECT_NEAR(est->at<double>(0, 0), (*truth)(0, 0), 0.005 * (*truth)(0, 0));
    EXPECT_NEAR(est->at<double>(1, 1), (*truth)(1, 1), 0.005 * (*truth)(1, 1));
    EXPECT_NEAR(est->at<double>(0, 2), (*truth)(0, 2), 3.0);
    EXPECT_NEAR(est->at<double>(1, 2), (*truth)(1, 2), 3.0);
  }
  EXPECT_NEAR(cv::norm(c.T), rig.baseline_m(), 0.01 * rig.baseline_m());
}

TEST(StereoCalibrateCharuco, PartlyHiddenBoardsAreUsedWhereAChessboardIsNot) {
  const StereoRigTruth rig = testing::test_stereo_rig();
  auto views = charuco_views(rig);
  auto chessboard_views = testing::render_calibration_set(rig, CheckerboardSpec{});
  // Something covers the left third of both images of view 0 in each set.
  for (auto* set : {&views, &chessboard_views}) {
    for (cv::Mat* image : {&(*set)[0].first, &(*set)[0].second}) {
      (*image)(cv::Rect(0, 0, rig.size.width / 3 + 60, rig.size.height)) = 110;
    }
  }
  auto charuco = calibrate_stereo(views.size(), loader(views), charuco_spec(), {});
  ASSERT_TRUE(charuco) << charuco.error().message;
  EXPECT_TRUE(charuco->views[0].used) << charuco->views[0].why_skipped;
  auto chessboard = calibrate_stereo(chessboard_views.size(), loader(chessboard_views), board_of({}), {});
  ASSERT_TRUE(chessboard) << chessboard.error().message;
  EXPECT_FALSE(chessboard->views[0].used);
  // Fewer common corners than options.min_common_corners: named and
  // skipped (the board has 54, so every view is; the progress reports why).
  CalibrateOptions strict;
  strict.min_common_corners = 55;
  std::vector<std::string> why;
  strict.progress = [&why](int, int, const ViewResult& v) { why.push_back(v.why_skipped); };
  auto too_few = calibrate_stereo(views.size(), loader(views), charuco_spec(), strict);
  ASSERT_FALSE(too_few);
  EXPECT_NE(too_few.error().message.find("0 of 10 views"), std::string::npos) << too_few.error().message;
  ASSERT_EQ(why.size(), views.size());
  EXPECT_NE(why[0].find("ChArUco corners seen by both cameras, fewer than 55"), std::string::npos) << why[0];
}

TEST(StereoCalibrateCharuco, ParsesBoardsAndNamesWhatIsWrong) {
  const auto square = parse_board("7x7", 0.03, CharucoMarkers{0.02, "DICT_4X4_50"});
  ASSERT_TRUE(square) << "markers fix the orientation: " << square.error().message;
  EXPECT_EQ(square->kind, BoardKind::kCharuco);
  EXPECT_EQ(board_points(*square).size(), 49u);
  const auto big_marker = parse_board("9x6", 0.03, CharucoMarkers{0.03, "DICT_4X4_50"});
  ASSERT_FALSE(big_marker);
  EXPECT_NE(big_marker.error().message.find("smaller than the square"), std::string::npos);
  const auto unknown = parse_board("9x6", 0.03, CharucoMarkers{0.02, "DICT_3X3_9"});
  ASSERT_FALSE(unknown);
  EXPECT_NE(unknown.error().message.find("DICT_5X5_100"), std::string::npos) << "lists the known ones";
  // 16 x 11 squares hold 88 markers; DICT_4X4_50 has 50.
  const auto small_dictionary = parse_board("15x10", 0.03, CharucoMarkers{0.02, "DICT_4X4_50"});
  ASSERT_FALSE(small_dictionary);
  EXPECT_NE(small_dictionary.error().message.find("has 50 markers"), std::string::npos)
      << small_dictionary.error().message;
  EXPECT_EQ(charuco_dictionary_names().size(), 17u);
}

}  // namespace
}  // namespace sitepose::calib
