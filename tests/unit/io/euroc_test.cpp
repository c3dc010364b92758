#include "sitepose/io/euroc.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "sitepose/io/sequence.hpp"
#include "sitepose/testing/files.hpp"

namespace sitepose::io {
namespace {

using testing::TempDir;
namespace fs = std::filesystem;

// T_BS of EuRoC MH_01 cam0 / cam1 (baseline ~0.11 m, small relative rotation).
constexpr const char* kTbsCam0 =
    "[0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975,\n"
    "         0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768,\n"
    "        -0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949,\n"
    "         0.0, 0.0, 0.0, 1.0]";
constexpr const char* kTbsCam1 =
    "[0.0125552670891, -0.999755099723, 0.0182237714554, -0.0198435579556,\n"
    "         0.999598781151, 0.0130119051815, 0.0251588363115, 0.0453689425024,\n"
    "        -0.0253898008918, 0.0179005838253, 0.999517347078, 0.00786212447038,\n"
    "         0.0, 0.0, 0.0, 1.0]";

// EuRoC-shaped sensor.yaml, intrinsics scaled to a 64x48 image. Line 16
// holds `intrinsics:` (tests check reported line numbers against it).
std::string sensor_yaml(const std::string& intrinsics, const std::string& distortion, const char* t_bs) {
  return std::string("%YAML:1.0\n") +              // 1
         "---\n"                                   // 2
         "# General sensor definitions.\n"         // 3
         "sensor_type: camera\n"                   // 4
         "comment: VI-Sensor (MT9M034)\n"          // 5
         "T_BS:\n"                                 // 6
         "  cols: 4\n"                             // 7
         "  rows: 4\n"                             // 8
         "  data: " + t_bs + "\n"                  // 9-12
         "resolution: [64, 48]\n"                  // 13
         "rate_hz: 20\n"
         "camera_model: pinhole\n"
         "intrinsics: " + intrinsics + " #fu, fv, cu, cv\n"
         "distortion_model: radial-tangential\n"
         "distortion_coefficients: " + distortion + "\n";
}
constexpr int kIntrinsicsLine = 16;

constexpr const char* kIntrinsics0 = "[40.1, 39.9, 32.3, 24.2]";
constexpr const char* kDistortion0 = "[-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]";
constexpr const char* kIntrinsics1 = "[40.5, 40.3, 31.6, 23.7]";
constexpr const char* kDistortion1 = "[-0.28368365, 0.07451284, -0.00010473, -3.55590700e-05]";

EurocCameraSensor sensor(const TempDir& dir, const std::string& name, const std::string& intr,
                         const std::string& dist, const char* t_bs) {
  auto s = read_euroc_sensor_yaml(dir.write(name, sensor_yaml(intr, dist, t_bs)));
  EXPECT_TRUE(s) << s.error().message;
  return s ? *s : EurocCameraSensor{};
}

TEST(EurocSensorYaml, ParsesRealShapedFile) {
  TempDir dir;
  const EurocCameraSensor s = sensor(dir, "sensor.yaml", kIntrinsics0, kDistortion0, kTbsCam0);
  EXPECT_DOUBLE_EQ(s.fu, 40.1);
  EXPECT_DOUBLE_EQ(s.cv, 24.2);
  EXPECT_DOUBLE_EQ(s.distortion[0], -0.28340811);
  EXPECT_DOUBLE_EQ(s.distortion[3], 1.76187114e-05);
  EXPECT_EQ(s.width, 64);
  EXPECT_EQ(s.height, 48);
  EXPECT_NEAR(s.T_body_cam.translation().y(), -0.064676986768, 1e-12);
  EXPECT_NEAR(s.T_body_cam.rotation_matrix()(1, 0), 0.999557249008, 1e-6);
}

TEST(EurocSensorYaml, MalformedNamesFileLineAndKey) {
  TempDir dir;
  auto three = read_euroc_sensor_yaml(dir.write("a.yaml", sensor_yaml("[40, 40, 32]", kDistortion0, kTbsCam0)));
  ASSERT_FALSE(three);
  EXPECT_NE(three.error().message.find("a.yaml:" + std::to_string(kIntrinsicsLine) +
                                       ": key 'intrinsics': expected 4 numbers [fu, fv, cu, cv], got 3 values"),
            std::string::npos)
      << three.error().message;
  auto word = read_euroc_sensor_yaml(dir.write("b.yaml", sensor_yaml("[40, 40, 32, abc]", kDistortion0, kTbsCam0)));
  ASSERT_FALSE(word);
  EXPECT_NE(word.error().message.find("b.yaml:" + std::to_string(kIntrinsicsLine) +
                                      ": key 'intrinsics': element 4 'abc' is not a finite number"),
            std::string::npos)
      << word.error().message;
  auto t_bs = read_euroc_sensor_yaml(dir.write("c.yaml", sensor_yaml(kIntrinsics0, kDistortion0, "[1, 0, 0, 0]")));
  ASSERT_FALSE(t_bs);
  EXPECT_NE(t_bs.error().message.find("c.yaml:9: key 'data': expected 16 numbers"), std::string::npos)
      << t_bs.error().message;
  auto not_rigid = read_euroc_sensor_yaml(dir.write(
      "d.yaml", sensor_yaml(kIntrinsics0, kDistortion0, "[2,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]")));
  ASSERT_FALSE(not_rigid);
  EXPECT_NE(not_rigid.error().message.find("d.yaml:9: key 'T_BS': expected a rigid transform"), std::string::npos)
      << not_rigid.error().message;
  std::string fisheye = sensor_yaml(kIntrinsics0, kDistortion0, kTbsCam0);
  fisheye.replace(fisheye.find("radial-tangential"), 17, "equidistant");
  auto unsupported = read_euroc_sensor_yaml(dir.write("e.yaml", fisheye));
  ASSERT_FALSE(unsupported);
  EXPECT_EQ(unsupported.error().code, ErrorCode::kUnsupported);
  EXPECT_NE(unsupported.error().message.find("distortion_model 'equidistant'"), std::string::npos);
  auto syntax = read_euroc_sensor_yaml(dir.write("f.yaml", "intrinsics: [1, 2\nresolution: ]]\n"));
  ASSERT_FALSE(syntax);
  EXPECT_NE(syntax.error().message.find("f.yaml:"), std::string::npos);
  EXPECT_NE(syntax.error().message.find("invalid YAML"), std::string::npos) << syntax.error().message;
}

// Rectification is checked against OpenCV's own distortion model: a point
// seen at an integer rectified pixel must map back to where the raw,
// distorted camera sees it, for both cameras.
TEST(EurocRectification, MapsAgreeWithRawProjection) {
  TempDir dir;
  const EurocCameraSensor cam0 = sensor(dir, "cam0.yaml", kIntrinsics0, kDistortion0, kTbsCam0);
  const EurocCameraSensor cam1 = sensor(dir, "cam1.yaml", kIntrinsics1, kDistortion1, kTbsCam1);
  auto rect = make_euroc_rectification(cam0, cam1);
  ASSERT_TRUE(rect) << rect.error().message;
  const StereoCamera& cam = rect->camera;
  ASSERT_TRUE(cam.validate());
  const SE3 T_cam1_cam0 = cam1.T_body_cam.inverse() * cam0.T_body_cam;
  EXPECT_NEAR(cam.baseline_m, T_cam1_cam0.translation().norm(), 1e-9);
  EXPECT_NEAR(cam.baseline_m, 0.110, 0.001);
  EXPECT_EQ(cam.width, 64);
  EXPECT_EQ(cam.height, 48);
  // alpha 0 zooms in: the rectified focal length is not below the raw one.
  EXPECT_GT(cam.fx, 30.0);
  EXPECT_LT(cam.fx, 80.0);
  EXPECT_NEAR(cam.fx, cam.fy, 1e-9);
  // The rectifying rotation is small for this almost-parallel pair.
  EXPECT_LT(rotation_angle_rad(rect->T_cam0_rect.rotation()), 0.05);

  cv::Mat m0x, m0y, m1x, m1y;
  cv::convertMaps(rect->map0_a, rect->map0_b, m0x, m0y, CV_32FC1);
  cv::convertMaps(rect->map1_a, rect->map1_b, m1x, m1y, CV_32FC1);
  const auto K = [](const EurocCameraSensor& s) {
    return cv::Matx33d(s.fu, 0, s.cu, 0, s.fv, s.cv, 0, 0, 1);
  };
  const auto D = [](const EurocCameraSensor& s) {
    return cv::Vec4d(s.distortion[0], s.distortion[1], s.distortion[2], s.distortion[3]);
  };
  const auto raw_pixel = [&](const EurocCameraSensor& s, const Eigen::Vector3d& p) {
    std::vector<cv::Point3d> pts{cv::Point3d(p.x(), p.y(), p.z())};
    std::vector<cv::Point2d> px;
    cv::projectPoints(pts, cv::Vec3d::zeros(), cv::Vec3d::zeros(), K(s), D(s), px);
    return px[0];
  };
  int checked = 0;
  for (int v = 6; v < 44; v += 9) {
    for (int u_right = 6; u_right < 50; u_right += 11) {
      const int disparity = 4;
      const double depth_m = cam.depth_from_disparity(disparity);
      const Eigen::Vector3d p_rect = cam.unproject(Eigen::Vector2d(u_right + disparity, v), depth_m);
      EXPECT_NEAR(cam.project_right_u(p_rect), u_right, 1e-9);
      const Eigen::Vector3d p_cam0 = rect->T_cam0_rect * p_rect;
      const Eigen::Vector3d p_cam1 = T_cam1_cam0 * p_cam0;
      const cv::Point2d raw0 = raw_pixel(cam0, p_cam0);
      const cv::Point2d raw1 = raw_pixel(cam1, p_cam1);
      // Fixed-point maps resolve 1/32 px.
      EXPECT_NEAR(m0x.at<float>(v, u_right + disparity), raw0.x, 0.05) << "left " << u_right << "," << v;
      EXPECT_NEAR(m0y.at<float>(v, u_right + disparity), raw0.y, 0.05);
      EXPECT_NEAR(m1x.at<float>(v, u_right), raw1.x, 0.05) << "right " << u_right << "," << v;
      EXPECT_NEAR(m1y.at<float>(v, u_right), raw1.y, 0.05);
      ++checked;
    }
  }
  EXPECT_EQ(checked, 20);
}

TEST(EurocRectification, SwappedOrMismatchedPairRejected) {
  TempDir dir;
  const EurocCameraSensor cam0 = sensor(dir, "cam0.yaml", kIntrinsics0, kDistortion0, kTbsCam0);
  const EurocCameraSensor cam1 = sensor(dir, "cam1.yaml", kIntrinsics1, kDistortion1, kTbsCam1);
  auto swapped = make_euroc_rectification(cam1, cam0);
  ASSERT_FALSE(swapped);
  EXPECT_NE(swapped.error().message.find("expected cam1 to the right of cam0"), std::string::npos)
      << swapped.error().message;
  EurocCameraSensor small = cam1;
  small.width = 32;
  auto sizes = make_euroc_rectification(cam0, small);
  ASSERT_FALSE(sizes);
  EXPECT_NE(sizes.error().message.find("cam0 resolution 64x48 differs from cam1 32x48"), std::string::npos);
}

TEST(EurocGroundTruth, InterpolatesAndComposesHandCase) {
  const Eigen::Quaterniond rz90(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));
  std::vector<EurocGtSample> samples{{100, SE3()}, {200, SE3(rz90, Eigen::Vector3d(2, 0, 0))}};
  const SE3 T_body_rect(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0.5, 0));
  const std::vector<std::int64_t> times{50, 100, 150, 200, 250};
  const auto gt = euroc_gt_at_times(samples, times, T_body_rect, 1000);
  ASSERT_EQ(gt.size(), 5u);
  EXPECT_FALSE(gt[0]);  // before the GT span
  EXPECT_FALSE(gt[4]);  // after it
  ASSERT_TRUE(gt[1] && gt[2] && gt[3]);
  EXPECT_NEAR((gt[1]->translation() - Eigen::Vector3d(0, 0.5, 0)).norm(), 0.0, 1e-12);
  // t = 200: body turned 90 deg about z at (2, 0, 0); the rect point (1, 0, 0)
  // sits at (1, 0.5, 0) in the body -> world (2 - 0.5, 1, 0).
  EXPECT_NEAR(((*gt[3]) * Eigen::Vector3d(1, 0, 0) - Eigen::Vector3d(1.5, 1, 0)).norm(), 0.0, 1e-12);
  // t = 150: halfway, 45 deg and (1, 0, 0); camera origin = R45 (0, 0.5, 0) + (1, 0, 0).
  const double h = std::sqrt(0.5);
  EXPECT_NEAR((gt[2]->translation() - Eigen::Vector3d(1 - 0.5 * h, 0.5 * h, 0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR(rotation_angle_rad(gt[2]->rotation()), M_PI / 4, 1e-12);
  // A 100 ns gap is more than a 50 ns limit: no GT inside it, exact hits kept.
  const auto gapped = euroc_gt_at_times(samples, times, T_body_rect, 50);
  EXPECT_FALSE(gapped[2]);
  EXPECT_TRUE(gapped[1] && gapped[3]);
}

TEST(EurocGroundTruth, CsvParsedAndMalformedRowNamed) {
  TempDir dir;
  const std::string header =
      "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z [], "
      "v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], b_w_RS_S_x [rad s^-1], b_w_RS_S_y [rad s^-1], "
      "b_w_RS_S_z [rad s^-1], b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], b_a_RS_S_z [m s^-2]\n";
  auto good = read_euroc_groundtruth(dir.write(
      "gt.csv", header +
                    "1403636580838555648,4.688319,-1.786938,0.783338,0.534108,-0.153029,-0.827383,-0.082152,"
                    "-0.027876,0.033207,0.800006,-0.003172,0.021267,0.078502,-0.025266,0.136696,0.075593\n"));
  ASSERT_TRUE(good) << good.error().message;
  ASSERT_EQ(good->size(), 1u);
  EXPECT_EQ((*good)[0].t_ns, 1403636580838555648);
  EXPECT_NEAR((*good)[0].T_world_body.translation().x(), 4.688319, 1e-12);
  EXPECT_NEAR(std::abs((*good)[0].T_world_body.rotation().w()), 0.534108, 1e-5);
  auto bad = read_euroc_groundtruth(dir.write("bad.csv", header + "1,1,2,3,1,0,0,0\n2,1,2,3,1,0,0\n"));
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("bad.csv:3: expected at least 8 fields"), std::string::npos)
      << bad.error().message;
}

// A whole EuRoC folder: pairing by exact timestamp, rectified frames, GT.
TEST(EurocSequence, OpensPairsRectifiesAndAttachesGt) {
  TempDir dir;
  const fs::path mav0 = dir.path() / "MH_tiny" / "mav0";
  dir.write("MH_tiny/mav0/cam0/sensor.yaml", sensor_yaml(kIntrinsics0, kDistortion0, kTbsCam0));
  dir.write("MH_tiny/mav0/cam1/sensor.yaml", sensor_yaml(kIntrinsics1, kDistortion1, kTbsCam1));
  const std::int64_t t0 = 1403636579763555584;
  const std::int64_t ms = 1'000'000;
  const std::vector<std::int64_t> left_t{t0, t0 + 50 * ms, t0 + 100 * ms, t0 + 150 * ms};
  const std::vector<std::int64_t> right_t{t0, t0 + 50 * ms, t0 + 101 * ms, t0 + 150 * ms};
  for (const auto& [cam, times] : {std::pair{"cam0", left_t}, std::pair{"cam1", right_t}}) {
    std::string csv = "#timestamp [ns],filename\n";
    fs::create_directories(mav0 / cam / "data");
    for (std::int64_t t : times) {
      csv += std::to_string(t) + "," + std::to_string(t) + ".png\n";
      cv::imwrite((mav0 / cam / "data" / (std::to_string(t) + ".png")).string(),
                  cv::Mat(48, 64, CV_8UC1, cv::Scalar(100)));
    }
    dir.write("MH_tiny/mav0/" + std::string(cam) + "/data.csv", csv);
  }
  // Body at rest at the origin, GT every 20 ms from t0 - 10 ms to t0 + 70 ms.
  std::string gt = "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z []\n";
  for (int k = 0; k < 5; ++k) gt += std::to_string(t0 - 10 * ms + k * 20 * ms) + ",0,0,0,1,0,0,0\n";
  dir.write("MH_tiny/mav0/state_groundtruth_estimate0/data.csv", gt);

  auto seq = open_sequence((dir.path() / "MH_tiny").string());
  ASSERT_TRUE(seq) << seq.error().message;
  const Sequence& s = **seq;
  EXPECT_EQ(s.layout(), SequenceLayout::kEuroc);
  ASSERT_EQ(s.size(), 3u);  // t0 + 100 ms (left) and + 101 ms (right) have no partner
  EXPECT_EQ(s.unpaired_images(), 2u);
  EXPECT_EQ(s.time_ns(2), t0 + 150 * ms);
  EXPECT_NEAR(s.camera().baseline_m, 0.110, 0.001);
  auto frame = s.read_frame(1);
  ASSERT_TRUE(frame) << frame.error().message;
  EXPECT_EQ(frame->t_ns(), t0 + 50 * ms);
  EXPECT_EQ(frame->left.type(), CV_8UC1);
  EXPECT_EQ(frame->left.size(), cv::Size(64, 48));
  EXPECT_EQ(frame->left.at<std::uint8_t>(24, 32), 100);
  EXPECT_EQ(frame->right.at<std::uint8_t>(24, 32), 100);

  ASSERT_EQ(s.gt_poses().size(), 3u);
  ASSERT_TRUE(s.gt_poses()[0] && s.gt_poses()[1]);
  EXPECT_FALSE(s.gt_poses()[2]);  // after the GT span
  // Body at the world origin: T_world_rect = T_body_cam0 * T_cam0_rect.
  auto cam0 = read_euroc_sensor_yaml((mav0 / "cam0" / "sensor.yaml").string());
  ASSERT_TRUE(cam0);
  const SE3& T_world_rect = *s.gt_poses()[0];
  EXPECT_NEAR((T_world_rect.translation() - cam0->T_body_cam.translation()).norm(), 0.0, 1e-12);
  // The rectified optical axis stays within a few degrees of cam0's.
  const Eigen::Vector3d z_rect = T_world_rect.rotation() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d z_cam0 = cam0->T_body_cam.rotation() * Eigen::Vector3d::UnitZ();
  EXPECT_GT(z_rect.dot(z_cam0), std::cos(0.05));
  EXPECT_FALSE(s.has_labels());
  EXPECT_FALSE(s.read_instance_mask(0));

  // Opening mav0 itself works too; a missing image names the frame.
  fs::remove(mav0 / "cam1" / "data" / (std::to_string(t0 + 150 * ms) + ".png"));
  auto broken = open_sequence(mav0.string());
  ASSERT_FALSE(broken);
  EXPECT_NE(broken.error().message.find("frame 2: image"), std::string::npos) << broken.error().message;
}

}  // namespace
}  // namespace sitepose::io
