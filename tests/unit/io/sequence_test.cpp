#include "sitepose/io/sequence.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>

#include "sitepose/io/kitti_calib.hpp"
#include "sitepose/io/trajectory.hpp"
#include "sitepose/testing/files.hpp"

namespace sitepose::io {
namespace {

using testing::TempDir;
namespace fs = std::filesystem;

constexpr int kWidth = 64;
constexpr int kHeight = 48;
// fx 50, cx 32, cy 24, baseline 0.5 m -> P1[0][3] = -25.
constexpr const char* kCalib =
    "P0: 50 0 32 0 0 50 24 0 0 0 1 0\n"
    "P1: 50 0 32 -25 0 50 24 0 0 0 1 0\n";

std::string frame_name(int i) {
  char name[16];
  std::snprintf(name, sizeof(name), "%06d.png", i);
  return name;
}

// Left pixel (0,0) = 10 i, right = 10 i + 1: a test can tell frames apart.
cv::Mat frame_image(int i, bool right, bool bgr, int width = kWidth, int height = kHeight) {
  cv::Mat gray(height, width, CV_8UC1, cv::Scalar(100));
  gray.at<std::uint8_t>(0, 0) = static_cast<std::uint8_t>(10 * i + (right ? 1 : 0));
  if (!bgr) return gray;
  cv::Mat color(height, width, CV_8UC3, cv::Scalar(100, 100, 100));
  color.at<cv::Vec3b>(0, 0) =
      cv::Vec3b(gray.at<std::uint8_t>(0, 0), gray.at<std::uint8_t>(0, 0), gray.at<std::uint8_t>(0, 0));
  return color;
}

SE3 gt_pose(int i) { return SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.0, 0.0, 1.5 * i)); }

// A 3-frame sitepose sequence in dir/seq.
std::string write_sequence(const TempDir& dir, int n = 3, bool bgr = false, bool poses = true) {
  const fs::path root = dir.path() / "seq";
  fs::create_directories(root / "image_0");
  fs::create_directories(root / "image_1");
  dir.write("seq/calib.txt", kCalib);
  std::string times;
  std::vector<SE3> gt;
  for (int i = 0; i < n; ++i) {
    times += std::to_string(0.1 * i) + "\n";
    cv::imwrite((root / "image_0" / frame_name(i)).string(), frame_image(i, false, bgr));
    cv::imwrite((root / "image_1" / frame_name(i)).string(), frame_image(i, true, bgr));
    gt.push_back(gt_pose(i));
  }
  dir.write("seq/times.txt", times);
  if (poses) {
    EXPECT_TRUE(write_kitti_poses((root / "poses.txt").string(), gt));
  }
  return root.string();
}

TEST(KittiCalib, ParsesAndIgnoresOtherKeys) {
  TempDir dir;
  // KITTI odometry 00 calib (P2, P3, Tr present).
  const std::string path = dir.write(
      "calib.txt",
      "P0: 7.188560000000e+02 0.000000000000e+00 6.071928000000e+02 0.000000000000e+00 0.000000000000e+00 "
      "7.188560000000e+02 1.852157000000e+02 0.000000000000e+00 0.000000000000e+00 0.000000000000e+00 "
      "1.000000000000e+00 0.000000000000e+00\n"
      "P1: 7.188560000000e+02 0.000000000000e+00 6.071928000000e+02 -3.861448000000e+02 0.000000000000e+00 "
      "7.188560000000e+02 1.852157000000e+02 0.000000000000e+00 0.000000000000e+00 0.000000000000e+00 "
      "1.000000000000e+00 0.000000000000e+00\n"
      "P2: 7.188560000000e+02 0 6.071928000000e+02 4.538225000000e+01 0 7.188560000000e+02 "
      "1.852157000000e+02 -1.130887000000e-01 0 0 1 3.779761000000e-03\n"
      "P3: 7.188560000000e+02 0 6.071928000000e+02 -3.372877000000e+02 0 7.188560000000e+02 "
      "1.852157000000e+02 2.369057000000e+00 0 0 1 4.915215000000e-03\n"
      "Tr: 4.276802385584e-04 -9.999672484946e-01 -8.084491683471e-03 -1.198459927713e-02 "
      "-7.210626507497e-03 8.081198471645e-03 -9.999413164504e-01 -5.403984729748e-02 "
      "9.999738645903e-01 4.859485810390e-04 -7.206933692422e-03 -2.921968648686e-01\n");
  auto cam = read_kitti_calib(path);
  ASSERT_TRUE(cam) << cam.error().message;
  EXPECT_DOUBLE_EQ(cam->fx, 718.856);
  EXPECT_DOUBLE_EQ(cam->cy, 185.2157);
  EXPECT_NEAR(cam->baseline_m, 386.1448 / 718.856, 1e-12);  // 0.537 m
}

TEST(KittiCalib, MalformedLinesNamed) {
  TempDir dir;
  auto short_p1 = read_kitti_calib(
      dir.write("a.txt", "P0: 50 0 32 0 0 50 24 0 0 0 1 0\nP1: 50 0 32 -25 0 50 24 0 0 0 1\n"));
  ASSERT_FALSE(short_p1);
  EXPECT_NE(short_p1.error().message.find("a.txt:2: expected 12 numbers, got 11"), std::string::npos)
      << short_p1.error().message;
  auto missing = read_kitti_calib(dir.write("b.txt", "P0: 50 0 32 0 0 50 24 0 0 0 1 0\n"));
  ASSERT_FALSE(missing);
  EXPECT_NE(
      missing.error().message.find("b.txt: expected lines 'P0: 12 numbers' and 'P1: 12 numbers', missing P1"),
      std::string::npos)
      << missing.error().message;
  auto no_colon = read_kitti_calib(dir.write("c.txt", std::string(kCalib) + "garbage line\n"));
  ASSERT_FALSE(no_colon);
  EXPECT_NE(no_colon.error().message.find("c.txt:3: expected 'KEY: numbers'"), std::string::npos);
  auto repeated =
      read_kitti_calib(dir.write("d.txt", std::string(kCalib) + "P1: 50 0 32 -25 0 50 24 0 0 0 1 0\n"));
  ASSERT_FALSE(repeated);
  EXPECT_NE(repeated.error().message.find("d.txt:3: key 'P1' repeated (first on line 2)"), std::string::npos);
  auto swapped = read_kitti_calib(
      dir.write("e.txt", "P0: 50 0 32 0 0 50 24 0 0 0 1 0\nP1: 50 0 32 25 0 50 24 0 0 0 1 0\n"));
  ASSERT_FALSE(swapped);
  EXPECT_NE(swapped.error().message.find("e.txt:2: expected P1[0][3] = -fx * baseline < 0"),
            std::string::npos);
  auto unrectified = read_kitti_calib(
      dir.write("f.txt", "P0: 50 0 32 0 0 50 24 0 0 0 1 0\nP1: 51 0 32 -25 0 50 24 0 0 0 1 0\n"));
  ASSERT_FALSE(unrectified);
  EXPECT_NE(unrectified.error().message.find("f.txt:2: expected P1 with the same fx"), std::string::npos);
}

TEST(SiteposeSequence, OpensAndReadsFrames) {
  TempDir dir;
  const std::string root = write_sequence(dir);
  auto seq = open_sequence(root);
  ASSERT_TRUE(seq) << seq.error().message;
  const Sequence& s = **seq;
  EXPECT_EQ(s.layout(), SequenceLayout::kSitepose);
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s.camera().width, kWidth);
  EXPECT_EQ(s.camera().height, kHeight);
  EXPECT_DOUBLE_EQ(s.camera().fx, 50.0);
  EXPECT_DOUBLE_EQ(s.camera().baseline_m, 0.5);
  EXPECT_EQ(s.time_ns(2), 200'000'000);
  auto frame = s.read_frame(2);
  ASSERT_TRUE(frame) << frame.error().message;
  EXPECT_EQ(frame->seq, 2);
  EXPECT_EQ(frame->t_ns(), 200'000'000);
  EXPECT_EQ(frame->left.type(), CV_8UC1);
  EXPECT_EQ(frame->left.at<std::uint8_t>(0, 0), 20);
  EXPECT_EQ(frame->right.at<std::uint8_t>(0, 0), 21);
  EXPECT_EQ(frame->source_id, root);
  ASSERT_TRUE(s.has_gt());
  ASSERT_EQ(s.gt_poses().size(), 3u);
  EXPECT_NEAR(s.gt_poses()[2]->translation().z(), 3.0, 1e-12);
  EXPECT_FALSE(s.has_labels());
  EXPECT_FALSE(s.has_masks());
  EXPECT_FALSE(s.read_instance_mask(0));
  EXPECT_FALSE(s.meta_json_path());
  auto out_of_range = s.read_frame(3);
  ASSERT_FALSE(out_of_range);
  EXPECT_EQ(out_of_range.error().code, ErrorCode::kInvalidArgument);
}

TEST(SiteposeSequence, MeanFrameRateFromTimeStamps) {
  TempDir dir;
  auto seq = open_sequence(write_sequence(dir));  // frames at 0, 0.1, 0.2 s
  ASSERT_TRUE(seq) << seq.error().message;
  EXPECT_NEAR(mean_frame_rate_hz(**seq), 10.0, 1e-9);
  EXPECT_NEAR(mean_frame_rate_hz(**seq, 2), 10.0, 1e-9);
  EXPECT_NEAR(mean_frame_rate_hz(**seq, 99), 10.0, 1e-9);  // capped at size()
  EXPECT_EQ(mean_frame_rate_hz(**seq, 1), 0.0);            // one frame: unknown
}

TEST(SiteposeSequence, BgrImagesConvertedToGray) {
  TempDir dir;
  const std::string root = write_sequence(dir, 2, /*bgr=*/true);
  auto seq = open_sequence(root);
  ASSERT_TRUE(seq) << seq.error().message;
  auto frame = (*seq)->read_frame(1);
  ASSERT_TRUE(frame) << frame.error().message;
  EXPECT_EQ(frame->left.type(), CV_8UC1);
  EXPECT_EQ(frame->left.at<std::uint8_t>(0, 0), 10);
  EXPECT_EQ(frame->right.at<std::uint8_t>(0, 0), 11);
}

// camera.channel_order / ORB-SLAM2's Camera.RGB: a pure blue pixel as
// cv::imread decodes it (B, G, R) = (200, 0, 0) is gray 0.114 * 200 = 23 read
// as BGR, and 0.299 * 200 = 60 read as RGB (the first channel taken as red);
// gray images are not touched by either order.
TEST(SiteposeSequence, ChannelOrderDecidesHowColourBecomesGray) {
  TempDir dir;
  const std::string root = write_sequence(dir, 2, /*bgr=*/true);
  cv::Mat blue(kHeight, kWidth, CV_8UC3, cv::Scalar(200, 0, 0));
  for (const char* side : {"image_0", "image_1"}) {
    ASSERT_TRUE(cv::imwrite((fs::path(root) / side / frame_name(1)).string(), blue));
  }
  for (const auto& [order, expected] :
       {std::pair{ChannelOrder::kBgr, 23}, std::pair{ChannelOrder::kRgb, 60}}) {
    SequenceOptions options;
    options.channel_order = order;
    auto seq = open_sequence(root, options);
    ASSERT_TRUE(seq) << seq.error().message;
    auto frame = (*seq)->read_frame(1);
    ASSERT_TRUE(frame) << frame.error().message;
    EXPECT_EQ(frame->left.at<std::uint8_t>(5, 5), expected);
    EXPECT_EQ(frame->right.at<std::uint8_t>(5, 5), expected);
    auto first = (*seq)->read_frame(0);  // (100, 100, 100): the same either way
    ASSERT_TRUE(first) << first.error().message;
    EXPECT_EQ(first->left.at<std::uint8_t>(5, 5), 100);
  }
}

TEST(SiteposeSequence, KittiLayoutWithExplicitGtPath) {
  TempDir dir;
  const std::string root = write_sequence(dir, 3, false, /*poses=*/false);
  {
    auto no_gt = open_sequence(root);
    ASSERT_TRUE(no_gt) << no_gt.error().message;
    EXPECT_FALSE((*no_gt)->has_gt());
    EXPECT_EQ((*no_gt)->gt_poses().size(), 3u);
  }
  const std::string gt_path = dir / "00.txt";
  ASSERT_TRUE(write_kitti_poses(gt_path, {gt_pose(0), gt_pose(5), gt_pose(7)}));
  SequenceOptions options;
  options.gt_path = gt_path;
  auto seq = open_sequence(root, options);
  ASSERT_TRUE(seq) << seq.error().message;
  ASSERT_TRUE((*seq)->has_gt());
  EXPECT_NEAR((*seq)->gt_poses()[1]->translation().z(), 7.5, 1e-12);

  ASSERT_TRUE(write_kitti_poses(gt_path, {gt_pose(0), gt_pose(5)}));
  auto short_gt = open_sequence(root, options);
  ASSERT_FALSE(short_gt);
  EXPECT_NE(short_gt.error().message.find("00.txt has 2 poses"), std::string::npos)
      << short_gt.error().message;
}

TEST(SiteposeSequence, CountMismatchRejected) {
  TempDir dir;
  const std::string root = write_sequence(dir);
  dir.write("seq/times.txt", "0.0\n0.1\n");  // 2 times, 3 images
  auto seq = open_sequence(root);
  ASSERT_FALSE(seq);
  EXPECT_NE(seq.error().message.find("holds 3 frame images"), std::string::npos) << seq.error().message;
  EXPECT_NE(seq.error().message.find("has 2 times"), std::string::npos);

  dir.write("seq/times.txt", "0.0\n0.1\n0.2\n");
  ASSERT_TRUE(write_kitti_poses(dir / "seq/poses.txt", {gt_pose(0)}));
  auto poses = open_sequence(root);
  ASSERT_FALSE(poses);
  EXPECT_NE(poses.error().message.find("poses.txt has 1 poses"), std::string::npos) << poses.error().message;
}

TEST(SiteposeSequence, MissingImageNamesFrameAndFile) {
  TempDir dir;
  const std::string root = write_sequence(dir);
  fs::remove(fs::path(root) / "image_1" / "000001.png");
  auto seq = open_sequence(root);
  ASSERT_FALSE(seq);
  EXPECT_EQ(seq.error().code, ErrorCode::kNotFound);
  EXPECT_NE(seq.error().message.find("frame 1: image"), std::string::npos) << seq.error().message;
  EXPECT_NE(seq.error().message.find("image_1/000001.png does not exist"), std::string::npos);
}

// issue 20: an entry that cannot be stat'ed (ELOOP) threw filesystem_error out
// of the image-folder check and aborted `sitepose run` and --check-config.
TEST(SiteposeSequence, SymlinkLoopInImageFolderIsNoCrash) {
  TempDir dir;
  const std::string root = write_sequence(dir);
  const fs::path folder = fs::path(root) / "image_0";
  fs::create_symlink("loop", folder / "loop");    // not a frame name: ignored
  fs::create_symlink("b.png", folder / "a.png");  // a 2-link cycle
  fs::create_symlink("a.png", folder / "b.png");
  auto seq = open_sequence(root);
  ASSERT_TRUE(seq) << seq.error().message;
  EXPECT_EQ((*seq)->size(), 3u);

  // A frame image that is a loop is a missing frame, named.
  fs::remove(folder / "000001.png");
  fs::create_symlink("000001.png", folder / "000001.png");
  auto looped = open_sequence(root);
  ASSERT_FALSE(looped);
  EXPECT_EQ(looped.error().code, ErrorCode::kNotFound);
  EXPECT_NE(looped.error().message.find("image_0/000001.png does not exist"), std::string::npos)
      << looped.error().message;
}

TEST(SiteposeSequence, ImageRemovedAfterOpenNamesFrame) {
  TempDir dir;
  const std::string root = write_sequence(dir);
  auto seq = open_sequence(root);
  ASSERT_TRUE(seq) << seq.error().message;
  fs::remove(fs::path(root) / "image_0" / "000002.png");
  auto frame = (*seq)->read_frame(2);
  ASSERT_FALSE(frame);
  EXPECT_NE(frame.error().message.find("frame 2 ("), std::string::npos) << frame.error().message;
  EXPECT_NE(frame.error().message.find("image_0/000002.png"), std::string::npos);
}

TEST(SiteposeSequence, ImageSizeMismatchRejected) {
  TempDir dir;
  const std::string root = write_sequence(dir);
  cv::imwrite((fs::path(root) / "image_1" / "000000.png").string(), frame_image(0, true, false, 32, 48));
  auto first = open_sequence(root);
  ASSERT_FALSE(first);
  EXPECT_NE(first.error().message.find("image is 32x48, expected 64x48"), std::string::npos)
      << first.error().message;

  const std::string root2 = write_sequence(dir);  // rewrites frame 0
  cv::imwrite((fs::path(root2) / "image_0" / "000002.png").string(), frame_image(2, false, false, 64, 40));
  auto seq = open_sequence(root2);
  ASSERT_TRUE(seq) << seq.error().message;  // only frame 0 is decoded at open
  auto frame = (*seq)->read_frame(2);
  ASSERT_FALSE(frame);
  EXPECT_NE(frame.error().message.find("frame 2"), std::string::npos);
  EXPECT_NE(frame.error().message.find("image is 64x40, expected 64x48"), std::string::npos);
}

TEST(SiteposeSequence, CalibOutsideImageRejected) {
  TempDir dir;
  const std::string root = write_sequence(dir);
  dir.write("seq/calib.txt", "P0: 50 0 320 0 0 50 24 0 0 0 1 0\nP1: 50 0 320 -25 0 50 24 0 0 0 1 0\n");
  auto seq = open_sequence(root);
  ASSERT_FALSE(seq);
  EXPECT_NE(seq.error().message.find("cx=320 outside the image width 64"), std::string::npos)
      << seq.error().message;
}

// issue 20: an absurd calibration ran and reported absurd poses as OK.
TEST(SiteposeSequence, ImplausibleCalibRejectedNamingTheValue) {
  TempDir dir;
  const std::string root = write_sequence(dir);
  dir.write("seq/calib.txt",
            "P0: 1e300 0 32 0 0 1e300 24 0 0 0 1 0\nP1: 1e300 0 32 -5e299 0 1e300 24 0 0 0 1 0\n");
  auto focal = open_sequence(root);
  ASSERT_FALSE(focal);
  EXPECT_EQ(focal.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(focal.error().message.find("calib.txt with images of 64x48"), std::string::npos)
      << focal.error().message;
  EXPECT_NE(focal.error().message.find("fx=1e+300"), std::string::npos) << focal.error().message;
  dir.write("seq/calib.txt", "P0: 50 0 32 0 0 50 24 0 0 0 1 0\nP1: 50 0 32 -5e11 0 50 24 0 0 0 1 0\n");
  auto baseline = open_sequence(root);
  ASSERT_FALSE(baseline);
  EXPECT_NE(baseline.error().message.find("baseline_m=1e+10 implausible"), std::string::npos)
      << baseline.error().message;
}

TEST(SiteposeSequence, BadCalibLineNamed) {
  TempDir dir;
  const std::string root = write_sequence(dir);
  dir.write("seq/calib.txt", "P0: 50 0 32 0 0 50 24 0 0 0 1 0\nP1: 50 0 32 -25 0 fifty 24 0 0 0 1 0\n");
  auto seq = open_sequence(root);
  ASSERT_FALSE(seq);
  EXPECT_NE(seq.error().message.find("calib.txt:2: field 6 'fifty' is not a finite number"),
            std::string::npos)
      << seq.error().message;
}

TEST(SiteposeSequence, LabelsAndMasks) {
  TempDir dir;
  const std::string root = write_sequence(dir);
  dir.write("seq/labels/boxes.csv",
            "frame,instance,class,x,y,w,h,moving\n2,4,truck,1,2,10,10,1\n0,4,truck,1,2,10,10,\n"
            "2,9,cone,30,30,3,5,0\n");
  const fs::path masks = fs::path(root) / "labels" / "masks";
  fs::create_directories(masks);
  cv::Mat mask(kHeight, kWidth, CV_16UC1, cv::Scalar(0));
  mask(cv::Rect(1, 2, 10, 10)).setTo(4);
  cv::imwrite((masks / "000000.png").string(), mask);
  cv::imwrite((masks / "000002.png").string(), mask);  // frame 1 has no boxes: no mask needed
  dir.write("seq/meta.json", "{\"scenario\": \"test\"}\n");

  auto seq = open_sequence(root);
  ASSERT_TRUE(seq) << seq.error().message;
  // Masks changed after open are still checked when read.
  cv::Mat mask8(kHeight, kWidth, CV_8UC1, cv::Scalar(4));
  cv::imwrite((masks / "000001.png").string(), mask8);
  fs::remove(masks / "000002.png");
  const Sequence& s = **seq;
  ASSERT_TRUE(s.has_labels());
  ASSERT_TRUE(s.meta_json_path());
  EXPECT_EQ(*s.meta_json_path(), (fs::path(root) / "meta.json").string());
  EXPECT_EQ(s.boxes().size(), 3u);
  EXPECT_EQ(s.boxes_for_frame(0).size(), 1u);
  EXPECT_TRUE(s.boxes_for_frame(1).empty());
  const std::vector<LabelBox> f2 = s.boxes_for_frame(2);
  ASSERT_EQ(f2.size(), 2u);
  EXPECT_EQ(f2[0].instance, 4);
  EXPECT_EQ(f2[1].class_name, "cone");

  ASSERT_TRUE(s.has_masks());
  auto m0 = s.read_instance_mask(0);
  ASSERT_TRUE(m0) << m0.error().message;
  EXPECT_EQ(m0->at<std::uint16_t>(5, 5), 4);
  auto m1 = s.read_instance_mask(1);
  ASSERT_FALSE(m1);
  EXPECT_NE(m1.error().message.find("frame 1: "), std::string::npos) << m1.error().message;
  EXPECT_NE(m1.error().message.find("expected a 16-bit single-channel PNG"), std::string::npos);
  auto m2 = s.read_instance_mask(2);
  ASSERT_FALSE(m2);
  EXPECT_EQ(m2.error().code, ErrorCode::kNotFound);
  EXPECT_NE(m2.error().message.find("frame 2: "), std::string::npos);
}

// issue 20: a bad mask was found only when the detector decoded it mid-run,
// and `sitepose run` exited 1 (a failure while running) instead of 2.
TEST(SiteposeSequence, BadMasksFailOpenNamingFrameAndFile) {
  TempDir dir;
  const std::string root = write_sequence(dir);
  dir.write("seq/labels/boxes.csv", "frame,instance,class,x,y,w,h,moving\n1,4,truck,1,2,10,10,1\n");
  const fs::path masks = fs::path(root) / "labels" / "masks";
  fs::create_directories(masks);
  const auto open_error = [&] {
    auto seq = open_sequence(root);
    return seq ? std::string() : seq.error().message;
  };
  EXPECT_NE(open_error().find("frame 1: " + (masks / "000001.png").string() +
                              ": mask file does not exist (labels/boxes.csv has boxes for it)"),
            std::string::npos)
      << open_error();
  cv::imwrite((masks / "000001.png").string(), cv::Mat(kHeight, kWidth, CV_16UC1, cv::Scalar(4)));
  EXPECT_EQ(open_error(), "");
  cv::imwrite((masks / "000002.png").string(), cv::Mat(kHeight, kWidth, CV_8UC1, cv::Scalar(4)));
  EXPECT_NE(open_error().find("frame 2: " + (masks / "000002.png").string() +
                              ": expected a 16-bit single-channel PNG (instance ids), got 8-bit gray"),
            std::string::npos)
      << open_error();
  cv::imwrite((masks / "000002.png").string(), cv::Mat(kHeight, kWidth, CV_16UC3, cv::Scalar(4, 4, 4)));
  EXPECT_NE(open_error().find("got 16-bit colour"), std::string::npos) << open_error();
  cv::imwrite((masks / "000002.png").string(), cv::Mat(kHeight / 2, kWidth, CV_16UC1, cv::Scalar(4)));
  EXPECT_NE(open_error().find("mask is 64x24, expected 64x48"), std::string::npos) << open_error();
  dir.write("seq/labels/masks/000002.png", "not a png");
  EXPECT_NE(open_error().find("000002.png: not a PNG file"), std::string::npos) << open_error();
  auto seq = open_sequence(root);
  ASSERT_FALSE(seq);
  EXPECT_EQ(seq.error().exit_status(), 2);
}

TEST(SiteposeSequence, BadBoxesLineFailsOpen) {
  TempDir dir;
  const std::string root = write_sequence(dir);
  dir.write("seq/labels/boxes.csv",
            "frame,instance,class,x,y,w,h,moving\n0,4,truck,1,2,10,10,1\n1,4,truck,1,2,10\n");
  auto seq = open_sequence(root);
  ASSERT_FALSE(seq);
  EXPECT_NE(seq.error().message.find("boxes.csv:3: expected 8 fields"), std::string::npos)
      << seq.error().message;
  dir.write("seq/labels/boxes.csv", "frame,instance,class,x,y,w,h,moving\n3,4,truck,1,2,10,10,1\n");
  auto range = open_sequence(root);
  ASSERT_FALSE(range);
  EXPECT_NE(range.error().message.find("boxes.csv:2: field 'frame': expected < 3"), std::string::npos)
      << range.error().message;
}

TEST(OpenSequence, RejectsMissingAndUnknownFolders) {
  TempDir dir;
  auto missing = open_sequence(dir / "nope");
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().code, ErrorCode::kNotFound);
  fs::create_directories(dir.path() / "empty");
  auto unknown = open_sequence(dir / "empty");
  ASSERT_FALSE(unknown);
  EXPECT_NE(unknown.error().message.find("not a sequence: expected image_0/"), std::string::npos);
}

}  // namespace
}  // namespace sitepose::io
