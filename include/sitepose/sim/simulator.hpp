#pragma once
// The construction-site stereo simulator: a Scenario becomes rendered stereo
// frames with ground truth (poses, instance masks, boxes, moving flags).
//
// Frames (see scene.hpp for the site frame):
//   * T_site_cam: left camera in the ground-fixed site frame.
//   * T_world_cam: left camera in the sequence's world frame, which is the
//     LEFT camera at frame 0 (KITTI convention: poses.txt starts at the
//     identity). T_site_world = T_site_cam(frame 0) relates the two.
// Camera: rectified pinhole, fx, fy from the scenario, cx = width / 2,
// cy = height / 2, right camera at +baseline_m along the left camera's x.
// Time: frame k is at t = k / fps seconds (t_ns = round(t * 1e9)).
// `moving` of an object at frame k: its site pose differs from frame k-1
// (frame 0: from frame 1, i.e. the motion across frames 0 -> 1), by more
// than 1e-9 m or 1e-9 rad.
// Threads: render() is const and may run concurrently for different frames.
// Determinism: everything derives from the scenario and its seed; the same
// inputs give byte-identical frames regardless of thread count.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "sitepose/core/expected.hpp"
#include "sitepose/core/se3.hpp"
#include "sitepose/core/stereo_camera.hpp"
#include "sitepose/sim/motion.hpp"
#include "sitepose/sim/renderer.hpp"
#include "sitepose/sim/scenario.hpp"

namespace sitepose::sim {

// Overrides of the scenario (command-line flags).
struct SimOptions {
  std::optional<int> frames;
  std::optional<int> seed;
  std::optional<int> width;   // a new size keeps the field of view:
  std::optional<int> height;  // fx scales with width, fy with height
  std::optional<double> fps;
};

// One rigid part of an articulated machine (excavator with work, loader).
struct PartTruth {
  std::uint8_t part = 0;  // 1 + index in the machine's part list; the part mask's value
  std::string name;       // undercarriage, house, boom, arm, bucket, body
  SE3 T_site_part;        // maps the machine's rest-pose model frame
  bool moving = false;    // same rule as ObjectTruth::moving, for this part
  bool visible = false;
  cv::Rect box;
  int pixels = 0;
};

struct ObjectTruth {
  std::uint16_t instance = 0;  // > 0, stable across frames
  std::string class_name;      // roller | truck | excavator | loader | person | cone
  SE3 T_site_obj;
  // 1 when its base pose or any part's pose changed (a slewing excavator
  // whose tracks stand is moving).
  bool moving = false;
  std::vector<PartTruth> parts;  // empty for rigid objects
  bool visible = false;          // has pixels in the left mask
  cv::Rect box;                  // tight bounds of its mask pixels (when visible)
  int pixels = 0;
};

struct SimFrame {
  int index = 0;
  double t_s = 0.0;
  std::int64_t t_ns = 0;
  cv::Mat left;           // CV_8UC1 (unrectified when the scenario asks for distortion)
  cv::Mat right;          // CV_8UC1
  cv::Mat instance_mask;  // CV_16UC1, left image, same geometry as `left`
  // CV_8UC1, PartTruth::part of articulated machines (0 elsewhere); empty
  // when the scenario has none.
  cv::Mat part_mask;
  cv::Mat depth_m;  // CV_32FC1, left rectified depth (z), +inf for sky
  SE3 T_world_cam;
  SE3 T_site_cam;
  std::vector<ObjectTruth> objects;      // every object, visible or not
  double occlusion_ratio = 0.0;          // left pixels on any object (machines and cones)
  double machine_occlusion_ratio = 0.0;  // left pixels on machines only
  double exposure_gain = 1.0;            // gain applied to the left image
};

class Simulator {
 public:
  // Applies the overrides and builds the world (textures are generated here,
  // ~1 s). kInvalidArgument names a bad override.
  static Expected<Simulator> create(const Scenario& scenario, const SimOptions& options = {});

  const Scenario& scenario() const { return scenario_; }  // overrides applied
  int frame_count() const { return frames_; }
  double fps() const { return scenario_.fps; }
  // Rectified pair (what calib.txt says).
  const StereoCamera& camera() const { return camera_; }
  // Distortion of both cameras when the output is unrectified.
  bool distorted() const { return scenario_.realism.distorted; }

  SE3 T_site_cam(double t_s) const;
  SE3 T_site_world() const { return T_site_world_; }
  double ego_speed_mps(double t_s) const { return ego_profile_.speed_mps(t_s); }

  SimFrame render(int frame_index) const;
  bool has_articulated() const { return articulated_; }

 private:
  struct Part {
    std::string name;
    MeshPtr mesh;
    int parent = -1;  // earlier part, -1 = the base
    Eigen::Vector3d pivot = Eigen::Vector3d::Zero();
    Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
    int drive = 0;  // 0 fixed, 1 slew, 2 dig
    double gain = 0.0;
  };
  struct Object {
    std::uint16_t instance = 0;
    std::string class_name;
    MeshPtr mesh;
    SE3 parked;
    bool has_path = false;
    Polyline path;
    SpeedProfile profile;
    bool reverse = false;
    std::vector<Part> parts;  // articulated: rendered part by part, `mesh` unused
    std::vector<WorkSpec> work;
  };

  Simulator() : renderer_(RenderOptions{}) {}
  void add_objects();           // the scenario's machines and cones
  void make_distortion_maps();  // distort_map_x_ / _y_ for the camera
  SE3 object_pose(const Object& o, double t_s) const;
  // T_obj_part of each part at t (rest-pose model frame to the base frame).
  static std::vector<SE3> part_poses(const Object& o, double t_s);
  void part_truth(const Object& o, const SimFrame& f, double t_other, ObjectTruth& truth) const;
  Scene scene_at(double t_s) const;
  cv::Mat render_radiance(double t_s, bool right_camera, RenderBuffers* labels) const;
  cv::Mat to_image(const cv::Mat& radiance, double gain, int frame_index, int camera_index) const;
  double exposure_gain(int frame_index) const;

  Scenario scenario_;
  int frames_ = 0;
  StereoCamera camera_;
  Renderer renderer_;
  MeshPtr background_;
  std::vector<Object> objects_;
  SpeedProfile ego_profile_;
  std::optional<Polyline> ego_path_;  // ego.waypoints, corners rounded; none: the +x lane
  SE3 T_site_world_;
  double vib_phase_[4] = {0, 0, 0, 0};
  double exposure_phase_[2] = {0, 0};
  cv::Mat distort_map_x_, distort_map_y_;  // distorted pixel -> rectified pixel
  bool articulated_ = false;
};

}  // namespace sitepose::sim
