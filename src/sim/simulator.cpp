#include "sitepose/sim/simulator.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "detail/models.hpp"
#include "detail/rng.hpp"

namespace sitepose::sim {
namespace {

using detail::mix64;
using detail::Rng;

constexpr double kDegToRad = std::numbers::pi / 180.0;
constexpr double kSamePoseEpsilon = 1e-9;  // m and rad: "the pose changed"

Eigen::Matrix3d body_from_camera(const CameraSpec& c) {
  const double th = c.pitch_down_deg * kDegToRad;
  Eigen::Matrix3d R;
  if (c.side == "right") {
    R.col(2) = Eigen::Vector3d(0, -std::cos(th), -std::sin(th));
    R.col(1) = Eigen::Vector3d(0, std::sin(th), -std::cos(th));
  } else {
    R.col(2) = Eigen::Vector3d(0, std::cos(th), -std::sin(th));
    R.col(1) = Eigen::Vector3d(0, -std::sin(th), -std::cos(th));
  }
  R.col(0) = R.col(1).cross(R.col(2));
  return R;
}

SE3 planar_pose(double x, double y, double yaw_rad) {
  return SE3(Eigen::Quaterniond(Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ())),
             Eigen::Vector3d(x, y, 0.0));
}

bool same_pose(const SE3& a, const SE3& b) {
  return (a.translation() - b.translation()).norm() <= kSamePoseEpsilon &&
         rotation_angle_rad(a.rotation().inverse() * b.rotation()) <= kSamePoseEpsilon;
}

// The options applied to `s` (a new image size keeps the field of view);
// returns the number of frames. kInvalidArgument names a bad override.
Expected<int> apply_options(const SimOptions& options, Scenario& s) {
  if (options.seed) {
    if (*options.seed < 0)
      return make_error(ErrorCode::kInvalidArgument,
                        "seed = " + std::to_string(*options.seed) + ": must be >= 0");
    s.seed = *options.seed;
  }
  if (options.width) {
    s.camera.fx *= static_cast<double>(*options.width) / s.camera.width;
    s.camera.width = *options.width;
  }
  if (options.height) {
    s.camera.fy *= static_cast<double>(*options.height) / s.camera.height;
    s.camera.height = *options.height;
  }
  if (s.camera.width < 16 || s.camera.height < 16 || s.camera.width > 8192 || s.camera.height > 8192) {
    return make_error(ErrorCode::kInvalidArgument, "image size " + std::to_string(s.camera.width) + "x" +
                                                       std::to_string(s.camera.height) +
                                                       ": must be in [16, 8192]");
  }
  if (options.fps) {
    if (!(*options.fps > 0.0 && *options.fps <= 120.0)) {
      return make_error(ErrorCode::kInvalidArgument,
                        "fps = " + std::to_string(*options.fps) + ": must be in (0, 120]");
    }
    s.fps = *options.fps;
  }
  int frames = s.frame_count();
  if (options.frames) {
    if (*options.frames < 1)
      return make_error(ErrorCode::kInvalidArgument,
                        "frames = " + std::to_string(*options.frames) + ": must be >= 1");
    frames = *options.frames;
  }
  if (s.realism.motion_blur_samples % 2 == 0) {
    return make_error(ErrorCode::kInvalidArgument,
                      "realism.motion_blur_samples = " + std::to_string(s.realism.motion_blur_samples) +
                          ": must be odd (labels come from the middle sample)");
  }
  return frames;
}

// Ego speed profile: segments back to back, then a stop.
SpeedProfile ego_speed_profile(const EgoSpec& ego) {
  std::vector<SpeedChange> changes;
  double t = 0.0;
  for (const EgoSegment& seg : ego.segments) {
    changes.push_back({t, seg.speed_mps});
    t += seg.duration_s;
  }
  changes.push_back({t, 0.0});
  return SpeedProfile(changes, ego.accel_mps2);
}

// [x, y] waypoints of a scenario as points on the ground.
std::vector<Eigen::Vector2d> ground_points(const std::vector<std::vector<double>>& waypoints) {
  std::vector<Eigen::Vector2d> points;
  points.reserve(waypoints.size());
  for (const auto& w : waypoints) points.emplace_back(w[0], w[1]);
  return points;
}

// The background over the lane stretch the camera travels in `frames`, or
// the x range of the ego's path when it has one.
MeshPtr site_background(const Scenario& s, const SpeedProfile& ego_profile, int frames) {
  detail::BackgroundLayout layout;
  if (!s.ego.waypoints.empty()) {
    layout.x_min_m = layout.x_max_m = s.ego.waypoints.front()[0];
    for (const auto& w : s.ego.waypoints) {
      layout.x_min_m = std::min(layout.x_min_m, w[0]);
      layout.x_max_m = std::max(layout.x_max_m, w[0]);
    }
  } else {
    const double duration = std::max(1.0, (frames - 1) / s.fps);
    double x_min = 0.0, x_max = 0.0;
    for (int k = 0; k <= 400; ++k) {
      const double x = ego_profile.distance_m(duration * k / 400.0);
      x_min = std::min(x_min, x);
      x_max = std::max(x_max, x);
    }
    layout.x_min_m = s.ego.start_x_m + x_min;
    layout.x_max_m = s.ego.start_x_m + x_max;
  }
  layout.view_sign = s.camera.side == "right" ? -1.0 : 1.0;
  layout.structures_min_m = s.world.structures_min_m;
  layout.structures_max_m = s.world.structures_max_m;
  layout.tyre_tracks = s.world.tyre_tracks;
  Rng world_rng(mix64(static_cast<std::uint64_t>(s.seed) * 7919ull + 1ull));
  // Shift the site so the background pattern does not depend on the start.
  return std::make_shared<const Mesh>(detail::make_background(world_rng, layout));
}

// Joint angle of a working machine at t: each work interval adds its
// half-cosine stroke, held once the interval is over.
double work_angle_rad(const std::vector<WorkSpec>& work, double t_s, bool slew) {
  double angle = 0.0;
  for (const WorkSpec& w : work) {
    if (t_s <= w.at_s) break;
    const double tau = std::min(t_s - w.at_s, w.duration_s);
    const double amplitude = (slew ? w.slew_deg : w.dig_deg) * kDegToRad;
    angle += amplitude * 0.5 * (1.0 - std::cos(2.0 * std::numbers::pi * tau / w.period_s));
  }
  return angle;
}

// A machine's speed along its path: start, then its stops.
SpeedProfile machine_speed_profile(const MachineSpec& m) {
  std::vector<SpeedChange> mc{{m.start_s, m.speed_mps}};
  for (const StopSpec& stop : m.stops) {
    mc.push_back({std::max(stop.at_s, m.start_s), 0.0});
    mc.push_back({std::max(stop.at_s, m.start_s) + stop.duration_s, m.speed_mps});
  }
  return SpeedProfile(mc, m.accel_mps2);
}

}  // namespace

Expected<Simulator> Simulator::create(const Scenario& scenario_in, const SimOptions& options) {
  Simulator sim;
  sim.scenario_ = scenario_in;
  SITEPOSE_TRY(sim.frames_, apply_options(options, sim.scenario_));
  const Scenario& s = sim.scenario_;
  sim.camera_ = StereoCamera{s.camera.fx,         s.camera.fy,    s.camera.width / 2.0, s.camera.height / 2.0,
                             s.camera.baseline_m, s.camera.width, s.camera.height};
  SITEPOSE_TRY_STATUS(sim.camera_.validate());
  sim.ego_profile_ = ego_speed_profile(s.ego);
  if (!s.ego.waypoints.empty())
    sim.ego_path_ = Polyline(rounded_corners(ground_points(s.ego.waypoints), s.ego.turn_radius_m));
  Rng rng(mix64(static_cast<std::uint64_t>(s.seed)) ^ 0x5173ull);
  for (double& p : sim.vib_phase_) p = rng.uniform(0, 2 * std::numbers::pi);
  for (double& p : sim.exposure_phase_) p = rng.uniform(0, 2 * std::numbers::pi);
  sim.background_ = site_background(s, sim.ego_profile_, sim.frames_);
  sim.add_objects();
  sim.T_site_world_ = sim.T_site_cam(0.0);
  if (s.realism.distorted) sim.make_distortion_maps();
  return sim;
}

void Simulator::add_objects() {
  const Scenario& s = scenario_;
  std::uint16_t next_id = 1;
  for (const MachineSpec& m : s.machines) {
    Object o;
    o.instance = next_id++;
    o.class_name = m.class_name;
    Rng mrng(mix64(static_cast<std::uint64_t>(s.seed) * 104729ull + o.instance));
    const detail::MachineLook look{m.paint, m.label};
    if (m.class_name == "loader" || (m.class_name == "excavator" && !m.work.empty())) {
      const std::vector<detail::JointPart> parts = m.class_name == "loader"
                                                       ? detail::make_loader_parts(mrng, look)
                                                       : detail::make_excavator_parts(mrng, look);
      for (const detail::JointPart& jp : parts) {
        o.parts.push_back({jp.name, std::make_shared<const Mesh>(jp.mesh), jp.parent, jp.pivot, jp.axis,
                           static_cast<int>(jp.drive), jp.gain});
      }
      o.work = m.work;
      articulated_ = true;
    } else {
      Mesh mesh = m.class_name == "roller"   ? detail::make_roller(mrng, look)
                  : m.class_name == "truck"  ? detail::make_truck(mrng, look)
                  : m.class_name == "person" ? detail::make_person(mrng, look, m.pose == "crouching")
                                             : detail::make_excavator(mrng, look);
      o.mesh = std::make_shared<const Mesh>(std::move(mesh));
    }
    o.parked = planar_pose(m.x_m, m.y_m, m.yaw_deg * kDegToRad);
    if (!m.waypoints.empty()) {
      o.has_path = true;
      o.path = Polyline(ground_points(m.waypoints));
      o.reverse = m.reverse;
      o.profile = machine_speed_profile(m);
    }
    objects_.push_back(std::move(o));
  }
  Rng cone_rng(mix64(static_cast<std::uint64_t>(s.seed) * 31337ull));
  const MeshPtr cone = std::make_shared<const Mesh>(detail::make_cone(cone_rng));
  for (const ConeSpec& c : s.cones) {
    Object o;
    o.instance = next_id++;
    o.class_name = "cone";
    o.mesh = cone;
    o.parked = planar_pose(c.x_m, c.y_m, 0.0);
    objects_.push_back(std::move(o));
  }
}

void Simulator::make_distortion_maps() {
  const Scenario& s = scenario_;
  // For every pixel of the distorted image, where it lies in the rectified one.
  std::vector<cv::Point2f> pixels;
  pixels.reserve(static_cast<size_t>(s.camera.width) * s.camera.height);
  for (int v = 0; v < s.camera.height; ++v)
    for (int u = 0; u < s.camera.width; ++u)
      pixels.emplace_back(static_cast<float>(u), static_cast<float>(v));
  const cv::Matx33d K(camera_.fx, 0, camera_.cx, 0, camera_.fy, camera_.cy, 0, 0, 1);
  const cv::Vec4d D(s.realism.distortion.k1, s.realism.distortion.k2, s.realism.distortion.p1,
                    s.realism.distortion.p2);
  std::vector<cv::Point2f> ideal;
  cv::undistortPoints(pixels, ideal, K, D, cv::noArray(), K);
  distort_map_x_.create(s.camera.height, s.camera.width, CV_32FC1);
  distort_map_y_.create(s.camera.height, s.camera.width, CV_32FC1);
  for (int v = 0; v < s.camera.height; ++v) {
    for (int u = 0; u < s.camera.width; ++u) {
      const cv::Point2f& p = ideal[static_cast<size_t>(v) * s.camera.width + u];
      distort_map_x_.at<float>(v, u) = p.x;
      distort_map_y_.at<float>(v, u) = p.y;
    }
  }
}

SE3 Simulator::T_site_cam(double t_s) const {
  const Scenario& s = scenario_;
  SE3 T_site_body;
  if (ego_path_) {
    const double along_m = ego_profile_.distance_m(t_s);
    const Eigen::Vector2d p = ego_path_->position(along_m);
    T_site_body = planar_pose(p.x(), p.y(), ego_path_->heading_rad(along_m));
  } else {
    T_site_body = planar_pose(s.ego.start_x_m + ego_profile_.distance_m(t_s), s.ego.start_y_m, 0.0);
  }
  // Drum vibration: full amplitude while driving, a quarter at standstill.
  const VibrationSpec& vib = s.ego.vibration;
  const double activity = 0.25 + 0.75 * std::min(1.0, std::abs(ego_profile_.speed_mps(t_s)) / 0.3);
  const double w = 2.0 * std::numbers::pi * vib.frequency_hz * t_s;
  auto wave = [&](int i) {
    return 0.7 * std::sin(w + vib_phase_[i]) + 0.3 * std::sin(1.37 * w + vib_phase_[(i + 1) % 4]);
  };
  const double dz = vib.amplitude_m * activity * wave(0);
  const double roll = vib.amplitude_deg * kDegToRad * activity * wave(1);
  const double pitch = vib.amplitude_deg * kDegToRad * activity * wave(2);
  const SE3 T_body_vib(Eigen::Quaterniond(Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()) *
                                          Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY())),
                       Eigen::Vector3d(0, 0, dz));
  const SE3 T_vib_cam(body_from_camera(s.camera), Eigen::Vector3d(0, 0, s.camera.height_m));
  return T_site_body * T_body_vib * T_vib_cam;
}

SE3 Simulator::object_pose(const Object& o, double t_s) const {
  if (!o.has_path) return o.parked;
  const double s = o.profile.distance_m(t_s);
  const Eigen::Vector2d p = o.path.position(s);
  const double yaw = o.path.heading_rad(s) + (o.reverse ? std::numbers::pi : 0.0);
  return planar_pose(p.x(), p.y(), yaw);
}

std::vector<SE3> Simulator::part_poses(const Object& o, double t_s) {
  const double slew = work_angle_rad(o.work, t_s, true);
  const double dig = work_angle_rad(o.work, t_s, false);
  std::vector<SE3> poses;
  poses.reserve(o.parts.size());
  for (const Part& p : o.parts) {
    const double angle = p.gain * (p.drive == 1 ? slew : p.drive == 2 ? dig : 0.0);
    const Eigen::Quaterniond q(Eigen::AngleAxisd(angle, p.axis));
    const SE3 local(q, p.pivot - q * p.pivot);  // turn about the pivot
    poses.push_back(p.parent < 0 ? local : poses[static_cast<size_t>(p.parent)] * local);
  }
  return poses;
}

Scene Simulator::scene_at(double t_s) const {
  Scene scene;
  scene.instances.push_back({background_, SE3::identity(), 0});
  for (const Object& o : objects_) {
    const SE3 T_world_obj = object_pose(o, t_s);
    if (o.parts.empty()) {
      scene.instances.push_back({o.mesh, T_world_obj, o.instance});
      continue;
    }
    const std::vector<SE3> poses = part_poses(o, t_s);
    for (size_t i = 0; i < o.parts.size(); ++i) {
      scene.instances.push_back(
          {o.parts[i].mesh, T_world_obj * poses[i], o.instance, static_cast<std::uint8_t>(i + 1)});
    }
  }
  return scene;
}

void Simulator::part_truth(const Object& o, const SimFrame& f, double t_other, ObjectTruth& truth) const {
  const std::vector<SE3> now = part_poses(o, f.t_s);
  const std::vector<SE3> other = part_poses(o, t_other);
  const SE3 T_site_other = object_pose(o, t_other);
  for (size_t i = 0; i < o.parts.size(); ++i) {
    PartTruth p;
    p.part = static_cast<std::uint8_t>(i + 1);
    p.name = o.parts[i].name;
    p.T_site_part = truth.T_site_obj * now[i];
    p.moving = !same_pose(p.T_site_part, T_site_other * other[i]);
    truth.moving = truth.moving || p.moving;
    truth.parts.push_back(p);
  }
  // Tight boxes of the part's pixels.
  std::vector<int> u0(o.parts.size(), INT32_MAX), v0(o.parts.size(), INT32_MAX), u1(o.parts.size(), -1),
      v1(o.parts.size(), -1);
  for (int v = 0; v < f.instance_mask.rows; ++v) {
    const std::uint16_t* ins = f.instance_mask.ptr<std::uint16_t>(v);
    const std::uint8_t* part = f.part_mask.ptr<std::uint8_t>(v);
    for (int u = 0; u < f.instance_mask.cols; ++u) {
      if (ins[u] != o.instance || part[u] == 0 || part[u] > o.parts.size()) continue;
      const size_t i = part[u] - 1u;
      u0[i] = std::min(u0[i], u);
      u1[i] = std::max(u1[i], u);
      v0[i] = std::min(v0[i], v);
      v1[i] = std::max(v1[i], v);
      ++truth.parts[i].pixels;
    }
  }
  for (size_t i = 0; i < o.parts.size(); ++i) {
    if (truth.parts[i].pixels == 0) continue;
    truth.parts[i].visible = true;
    truth.parts[i].box = cv::Rect(u0[i], v0[i], u1[i] - u0[i] + 1, v1[i] - v0[i] + 1);
  }
}

cv::Mat Simulator::render_radiance(double t_s, bool right_camera, RenderBuffers* labels) const {
  const int n = scenario_.realism.motion_blur_samples;
  const SE3 T_left_right(Eigen::Quaterniond::Identity(), Eigen::Vector3d(camera_.baseline_m, 0, 0));
  cv::Mat sum;
  for (int i = 0; i < n; ++i) {
    const double ts =
        n == 1 ? t_s : t_s + scenario_.realism.exposure_time_s * (static_cast<double>(i) / (n - 1) - 0.5);
    SE3 T = T_site_cam(ts);
    if (right_camera) T = T * T_left_right;
    RenderBuffers buffers;
    renderer_.render(scene_at(ts), camera_, T, buffers);
    if (labels && i == n / 2) *labels = buffers;
    if (n == 1) return buffers.radiance;
    if (sum.empty())
      sum = buffers.radiance.clone();
    else
      sum += buffers.radiance;
  }
  return sum / n;
}

double Simulator::exposure_gain(int k) const {
  const RealismSpec& r = scenario_.realism;
  const double t = k / scenario_.fps;
  // Slow drift of the auto exposure plus a per-frame step.
  const double slow = 0.6 * std::sin(2 * std::numbers::pi * t / 9.7 + exposure_phase_[0]) +
                      0.4 * std::sin(2 * std::numbers::pi * t / 3.1 + exposure_phase_[1]);
  Rng rng(
      mix64(static_cast<std::uint64_t>(scenario_.seed) ^ (static_cast<std::uint64_t>(k) << 20) ^ 0xE7ull));
  const double step = rng.uniform(-1.0, 1.0);
  double transmission = 1.0;
  for (const LensCoverSpec& cover : r.lens_covered) {
    if (t >= cover.at_s && t < cover.at_s + cover.duration_s) transmission = cover.transmission;
  }
  return transmission * r.brightness * (1.0 + r.exposure_variation * (0.7 * slow + 0.3 * step));
}

cv::Mat Simulator::to_image(const cv::Mat& radiance, double gain, int frame_index, int camera_index) const {
  const RealismSpec& r = scenario_.realism;
  cv::Mat out(radiance.size(), CV_8UC1);
  const float g = static_cast<float>(gain);
  const float contrast = static_cast<float>(r.contrast);
  const float sigma = static_cast<float>(r.noise_sigma * 1.7320508);  // Irwin-Hall(4) has std 1/sqrt(3)
  const std::uint64_t base = mix64(static_cast<std::uint64_t>(scenario_.seed) * 0x9E37ull +
                                   static_cast<std::uint64_t>(frame_index) * 4ull + camera_index);
  cv::parallel_for_(
      cv::Range(0, radiance.rows),
      [&](const cv::Range& rows) {
        for (int v = rows.start; v < rows.end; ++v) {
          const float* in = radiance.ptr<float>(v);
          uchar* o = out.ptr<uchar>(v);
          std::uint64_t state = mix64(base + static_cast<std::uint64_t>(v));
          for (int u = 0; u < radiance.cols; ++u) {
            // xorshift64: four 16-bit uniforms per step.
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            const float sum4 = static_cast<float>((state & 0xFFFF) + ((state >> 16) & 0xFFFF) +
                                                  ((state >> 32) & 0xFFFF) + (state >> 48)) *
                               (1.0f / 65536.0f);
            const float value = 128.0f + (in[u] * g - 128.0f) * contrast + (sum4 - 2.0f) * sigma;
            o[u] = cv::saturate_cast<uchar>(value);
          }
        }
      },
      8);
  return out;
}

SimFrame Simulator::render(int k) const {
  SimFrame f;
  f.index = k;
  f.t_s = k / scenario_.fps;
  f.t_ns = static_cast<std::int64_t>(std::llround(f.t_s * 1e9));
  f.T_site_cam = T_site_cam(f.t_s);
  f.T_world_cam = T_site_world_.inverse() * f.T_site_cam;
  RenderBuffers labels;
  cv::Mat rad_left = render_radiance(f.t_s, false, &labels);
  cv::Mat rad_right = render_radiance(f.t_s, true, nullptr);
  f.depth_m = labels.depth_m;
  f.instance_mask = labels.instance;
  if (articulated_) f.part_mask = labels.part;
  if (distorted()) {
    cv::Mat left_d, right_d;  // separate buffers: remap must not write into its source
    cv::remap(rad_left, left_d, distort_map_x_, distort_map_y_, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    cv::remap(rad_right, right_d, distort_map_x_, distort_map_y_, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    rad_left = left_d;
    rad_right = right_d;
    cv::remap(labels.instance, f.instance_mask, distort_map_x_, distort_map_y_, cv::INTER_NEAREST,
              cv::BORDER_CONSTANT, 0);
    if (articulated_) {
      cv::remap(labels.part, f.part_mask, distort_map_x_, distort_map_y_, cv::INTER_NEAREST,
                cv::BORDER_CONSTANT, 0);
    }
  }
  f.exposure_gain = exposure_gain(k);
  f.left = to_image(rad_left, f.exposure_gain, k, 0);
  f.right = to_image(rad_right, f.exposure_gain * scenario_.realism.right_gain, k, 1);

  // Ground truth per object: pose, moving flag, tight box of its mask pixels.
  const double t_other = (k == 0 ? 1 : k - 1) / scenario_.fps;
  std::vector<int> index_of(objects_.size() + 1, -1);
  for (size_t i = 0; i < objects_.size(); ++i) {
    const Object& o = objects_[i];
    ObjectTruth truth;
    truth.instance = o.instance;
    truth.class_name = o.class_name;
    truth.T_site_obj = object_pose(o, f.t_s);
    truth.moving = !same_pose(truth.T_site_obj, object_pose(o, t_other));
    if (!o.parts.empty()) part_truth(o, f, t_other, truth);
    index_of[o.instance] = static_cast<int>(i);
    f.objects.push_back(truth);
  }
  std::vector<int> u0(objects_.size(), INT32_MAX), v0(objects_.size(), INT32_MAX), u1(objects_.size(), -1),
      v1(objects_.size(), -1), count(objects_.size(), 0);
  long covered = 0, machines = 0;
  for (int v = 0; v < f.instance_mask.rows; ++v) {
    const std::uint16_t* row = f.instance_mask.ptr<std::uint16_t>(v);
    for (int u = 0; u < f.instance_mask.cols; ++u) {
      const std::uint16_t id = row[u];
      if (id == 0 || id >= index_of.size() || index_of[id] < 0) continue;
      const size_t i = static_cast<size_t>(index_of[id]);
      u0[i] = std::min(u0[i], u);
      u1[i] = std::max(u1[i], u);
      v0[i] = std::min(v0[i], v);
      v1[i] = std::max(v1[i], v);
      ++count[i];
      ++covered;
      if (objects_[i].class_name != "cone") ++machines;
    }
  }
  for (size_t i = 0; i < objects_.size(); ++i) {
    if (count[i] == 0) continue;
    f.objects[i].visible = true;
    f.objects[i].pixels = count[i];
    f.objects[i].box = cv::Rect(u0[i], v0[i], u1[i] - u0[i] + 1, v1[i] - v0[i] + 1);
  }
  const double area = static_cast<double>(f.instance_mask.total());
  f.occlusion_ratio = covered / area;
  f.machine_occlusion_ratio = machines / area;
  return f;
}

}  // namespace sitepose::sim
