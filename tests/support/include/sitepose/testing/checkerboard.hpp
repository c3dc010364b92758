#pragma once
// Chessboard views (or views of any planar target) of a known stereo rig,
// for calibration tests: the board plane is warped into each camera by its
// homography K [r1 r2 t], rendered at 4x and area-averaged down (so corners
// are anti-aliased and sub-pixel positions are meaningful). No lens
// distortion. Needs OpenCV imgproc.

#include <cmath>
#include <cstdint>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

namespace sitepose::testing {

struct CheckerboardSpec {
  int cols = 9;  // inner corners
  int rows = 6;
  double square_m = 0.035;
};

// A pinhole camera and the board's pose in it (x_cam = R x_board + t).
struct BoardView {
  cv::Matx33d K;
  cv::Matx33d R_cam_board;
  cv::Vec3d t_cam_board;
};

// Rotation of `ax`, `ay`, `az` degrees about x, then y, then z (Rz Ry Rx).
inline cv::Matx33d rotation_deg(double ax, double ay, double az) {
  const double a = ax * CV_PI / 180.0, b = ay * CV_PI / 180.0, c = az * CV_PI / 180.0;
  const cv::Matx33d rx(1, 0, 0, 0, std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a));
  const cv::Matx33d ry(std::cos(b), 0, std::sin(b), 0, 1, 0, -std::sin(b), 0, std::cos(b));
  const cv::Matx33d rz(std::cos(c), -std::sin(c), 0, std::sin(c), std::cos(c), 0, 0, 0, 1);
  return rz * ry * rx;
}

// 8-bit gray image of a planar texture seen by `view`: texture pixel
// (x, y) (centres at integers) lies at board-plane point
// texture_to_board * (x, y, 1). Rendered at 4x and area-averaged down, on a
// mid-grey background, with Gaussian noise of `noise_sigma` grey levels.
inline cv::Mat render_planar_texture(const BoardView& view, const cv::Mat& texture,
                                     const cv::Matx33d& texture_to_board, cv::Size size, std::uint64_t seed,
                                     double noise_sigma) {
  constexpr int kSuper = 4;
  // Pixel u of the final image covers 4x pixels 4u .. 4u+3, centred at 4u + 1.5.
  const double off = (kSuper - 1) / 2.0;
  const cv::Matx33d to_super(kSuper, 0, off, 0, kSuper, off, 0, 0, 1);
  const cv::Matx33d& R = view.R_cam_board;
  const cv::Matx33d plane_to_cam(R(0, 0), R(0, 1), view.t_cam_board[0], R(1, 0), R(1, 1), view.t_cam_board[1],
                                 R(2, 0), R(2, 1), view.t_cam_board[2]);
  const cv::Matx33d H = to_super * view.K * plane_to_cam * texture_to_board;
  cv::Mat big;
  cv::warpPerspective(texture, big, cv::Mat(H), size * kSuper, cv::INTER_LINEAR, cv::BORDER_CONSTANT,
                      cv::Scalar(110));
  cv::Mat image;
  cv::resize(big, image, size, 0, 0, cv::INTER_AREA);
  if (noise_sigma > 0.0) {
    cv::Mat noise(size, CV_16SC1);
    cv::RNG rng(seed);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, noise_sigma);
    cv::Mat sum;
    cv::add(image, noise, sum, cv::noArray(), CV_16SC1);
    sum.convertTo(image, CV_8UC1);
  }
  return image;
}

// A stereo rig: x_right = R_right_left x_left + t_right_left.
struct StereoRigTruth {
  cv::Matx33d K_left;
  cv::Matx33d K_right;
  cv::Matx33d R_right_left;
  cv::Vec3d t_right_left;
  cv::Size size;
  double baseline_m() const { return cv::norm(t_right_left); }
};

// 640x480, slightly different cameras, 0.12 m baseline, 0.5 deg toe-in.
inline StereoRigTruth test_stereo_rig() {
  StereoRigTruth rig;
  rig.size = {640, 480};
  rig.K_left = cv::Matx33d(520.0, 0, 322.5, 0, 518.0, 241.0, 0, 0, 1);
  rig.K_right = cv::Matx33d(515.0, 0, 318.0, 0, 514.0, 236.5, 0, 0, 1);
  rig.R_right_left = rotation_deg(0.2, -0.5, 0.1);
  rig.t_right_left = -(rig.R_right_left * cv::Vec3d(0.12, 0.0, 0.0));
  return rig;
}

// A planar calibration target: its picture and where the picture lies on
// the board plane (see render_planar_texture), and the point the views
// centre on.
struct PlanarTarget {
  cv::Mat texture;
  cv::Matx33d texture_to_board;
  cv::Vec3d centre_on_board;
};

// The chessboard of `board` as a target, centred on its inner corners.
inline PlanarTarget checkerboard_target(const CheckerboardSpec& board) {
  constexpr int kPxPerSquare = 40;
  const int squares_x = board.cols + 1, squares_y = board.rows + 1;
  PlanarTarget target;
  target.texture =
      cv::Mat((squares_y + 2) * kPxPerSquare, (squares_x + 2) * kPxPerSquare, CV_8UC1, cv::Scalar(235));
  for (int j = 0; j < squares_y; ++j) {
    for (int i = 0; i < squares_x; ++i) {
      if ((i + j) % 2 == 0) {
        target.texture(cv::Rect((i + 1) * kPxPerSquare, (j + 1) * kPxPerSquare, kPxPerSquare, kPxPerSquare)) =
            20;
      }
    }
  }
  // Texture pixel (centre at integer x) -> board plane (inner corner 0 at the origin).
  const double s = board.square_m / kPxPerSquare;
  const double origin = -2.0 * board.square_m + 0.5 * s;
  target.texture_to_board = cv::Matx33d(s, 0, origin, 0, s, origin, 0, 0, 1);
  target.centre_on_board =
      cv::Vec3d((board.cols - 1) * board.square_m / 2.0, (board.rows - 1) * board.square_m / 2.0, 0.0);
  return target;
}

// Board pose with its centre at `centre_cam` (left camera frame) and the
// given tilt; both images of view i of a calibration set.
inline std::pair<cv::Mat, cv::Mat> render_stereo_view(const StereoRigTruth& rig, const PlanarTarget& target,
                                                      const cv::Matx33d& R_left_board,
                                                      const cv::Vec3d& centre_cam, std::uint64_t seed) {
  const cv::Vec3d t_left = centre_cam - R_left_board * target.centre_on_board;
  const BoardView left{rig.K_left, R_left_board, t_left};
  const BoardView right{rig.K_right, rig.R_right_left * R_left_board,
                        rig.R_right_left * t_left + rig.t_right_left};
  return {render_planar_texture(left, target.texture, target.texture_to_board, rig.size, seed, 1.0),
          render_planar_texture(right, target.texture, target.texture_to_board, rig.size, seed + 1, 1.0)};
}

// Up to ten views (the first `count`) spread in tilt (up to 30 deg), roll and
// distance (0.55-0.9 m), the target centred between the cameras.
inline std::vector<std::pair<cv::Mat, cv::Mat>> render_calibration_set(const StereoRigTruth& rig,
                                                                       const PlanarTarget& target,
                                                                       std::size_t count = 10) {
  struct Pose {
    double ax, ay, az, x, y, z;
  };
  const Pose poses[] = {{0, 0, 0, 0.06, 0.0, 0.7},        {25, 0, 5, 0.06, 0.02, 0.75},
                        {-25, 0, -5, 0.05, -0.02, 0.7},   {0, 30, 0, 0.08, 0.0, 0.8},
                        {0, -30, 8, 0.04, 0.01, 0.75},    {20, 20, -8, 0.06, 0.03, 0.85},
                        {-20, -25, 10, 0.06, -0.03, 0.8}, {15, -20, 0, 0.1, 0.02, 0.9},
                        {-15, 25, -10, 0.02, 0.0, 0.65},  {5, 5, 3, 0.06, -0.01, 0.55}};
  std::vector<std::pair<cv::Mat, cv::Mat>> views;
  std::uint64_t seed = 10;
  for (const Pose& p : poses) {
    if (views.size() == count) break;
    views.push_back(
        render_stereo_view(rig, target, rotation_deg(p.ax, p.ay, p.az), cv::Vec3d(p.x, p.y, p.z), seed));
    seed += 2;
  }
  return views;
}

// The chessboard calibration set.
inline std::vector<std::pair<cv::Mat, cv::Mat>> render_calibration_set(const StereoRigTruth& rig,
                                                                       const CheckerboardSpec& board,
                                                                       std::size_t count = 10) {
  return render_calibration_set(rig, checkerboard_target(board), count);
}

}  // namespace sitepose::testing
