#include "sitepose/daemon/outputs.hpp"

#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>

#include <fmt/format.h>

#include "sitepose/core/log.hpp"
#include "sitepose/output/j1939.hpp"

namespace sitepose::daemon {
namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kDegToRad = std::numbers::pi / 180.0;
}  // namespace

// ----------------------------------------------------------------- TimeBase

TimeBase::Now TimeBase::system_clock_now() {
  // Steady first: the system clock read after it is at most as late as the
  // capture stage's steady stamps, never earlier.
  Now now;
  now.steady = pipeline::SteadyClock::now();
  now.system_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
                      std::chrono::system_clock::now().time_since_epoch())
                      .count();
  return now;
}

std::int64_t TimeBase::capture_utc_ns(const pipeline::PosePacket& packet) {
  if (!offset_ns_) {
    const Now now = clock_();
    // A packet without a capture stamp (a test's) counts as captured now.
    const std::int64_t age_ns =
        packet.captured == pipeline::SteadyTime{}
            ? 0
            : std::max<std::int64_t>(
                  0,
                  std::chrono::duration_cast<std::chrono::nanoseconds>(now.steady - packet.captured).count());
    const std::int64_t offset = now.system_ns - age_ns - packet.pose.t_ns;
    offset_ns_ = std::abs(offset) < kUtcTolerance_ns ? 0 : offset;
    spdlog::info("time base: capture stamps + {:.6f} s = UTC{}", static_cast<double>(*offset_ns_) * 1e-9,
                 *offset_ns_ == 0 ? " (the source stamps in UTC)" : "");
  }
  return packet.pose.t_ns + *offset_ns_;
}

double TimeBase::latency_ms(const pipeline::PosePacket& packet) const {
  if (packet.captured == pipeline::SteadyTime{}) return 0.0;
  return std::chrono::duration<double, std::milli>(clock_().steady - packet.captured).count();
}

// ---------------------------------------------------------------- Anchoring

PublishOptions publish_options(const DaemonConfig& config) {
  PublishOptions p;
  p.lever_arm_m = config.reference_point.lever_arm_m;
  p.covariance = config.covariance;
  p.integrity = config.integrity;
  return p;
}

Expected<std::unique_ptr<Anchoring>> Anchoring::create(const GeoConfig& config,
                                                       const PublishOptions& publish) {
  std::unique_ptr<Anchoring> a(new Anchoring(config, publish));
  if (!publish.lever_arm_m.isZero()) {
    SITEPOSE_TRY(const Eigen::Matrix3d R_cam_machine, output::rotation_cam_machine(config.forward_axis_cam));
    a->lever_arm_cam_m_ = R_cam_machine * publish.lever_arm_m;
  }
  if (config.mode != GeoMode::kNone && !config.geoid.empty()) {
    auto geoid = geo::GeoidGrid::load(config.geoid);
    if (!geoid) return make_error(geoid.error().code, "geo.geoid: " + geoid.error().message);
    a->geoid_ = std::move(*geoid);
  }
  if (config.mode == GeoMode::kFixed) {
    SITEPOSE_TRY(geo::SiteFrame frame,
                 geo::SiteFrame::create(config.origin, config.T_site_slam, config.forward_axis_cam));
    a->fixed_ = std::move(frame);
  } else if (config.mode == GeoMode::kOnline) {
    SITEPOSE_TRY(geo::SiteAnchor anchor, geo::SiteAnchor::create(config.anchor));
    a->anchor_ = std::move(anchor);
  }
  return a;
}

void Anchoring::push_fix(const geo::GnssFix& fix) {
  // Drop-oldest: a burst of fixes must not stall the receiving thread.
  (void)fixes_.push_drop_oldest(geo::GnssFix{fix});
}

void Anchoring::set_scheduled_fixes(std::vector<geo::GnssFix> fixes) {
  scheduled_ = std::move(fixes);
  next_scheduled_ = 0;
}

std::optional<geo::AnchorStatus> Anchoring::anchor_status() const {
  if (!anchor_) return std::nullopt;
  return anchor_->status();
}

const geo::SiteFrame* Anchoring::site_frame(const pipeline::PosePacket& packet) {
  const PoseEstimate& pose = packet.pose;
  if (fixed_) return &*fixed_;
  if (!anchor_) return nullptr;
  // Fixes first (those up to this pose's time), then the pose, so a fix
  // waiting for a later SLAM pose finds it. The anchor pairs the camera.
  while (auto fix = fixes_.try_pop()) anchor_->add_fix(*fix);
  while (next_scheduled_ < scheduled_.size() &&
         scheduled_[next_scheduled_].t_ns + config_.anchor.gnss_clock_offset_ns <= pose.t_ns) {
    anchor_->add_fix(scheduled_[next_scheduled_++]);
  }
  if (pose.state == TrackingState::kOk && !packet.from_stall) {
    anchor_->add_slam_pose(pose.t_ns, pose.T_world_cam);
  }
  return anchor_->site_frame() ? &*anchor_->site_frame() : nullptr;
}

std::pair<double, double> Anchoring::anchor_std() const {
  if (fixed_) return {config_.anchor_std.position_m, config_.anchor_std.attitude_deg * kDegToRad};
  if (!anchor_ || !anchor_->site_frame()) return {0.0, 0.0};
  // The fit's own uncertainty, to first order: the inliers' RMS over
  // sqrt(inliers) for the position, over the lateral spread for the
  // attitude; never below the configured one (survey and antenna errors).
  const geo::AnchorStatus st = anchor_->status();
  const double n = std::max(1, st.inliers);
  const double position_m = st.inlier_rms_m / std::sqrt(n);
  const double attitude_rad = st.lateral_spread_m > 0.0 ? position_m / st.lateral_spread_m : 0.0;
  return {std::max(position_m, config_.anchor_std.position_m),
          std::max(attitude_rad, config_.anchor_std.attitude_deg * kDegToRad)};
}

const PublishedPose& Anchoring::published(const pipeline::PosePacket& packet) {
  const PoseEstimate& pose = packet.pose;
  if (cache_valid_ && cached_seq_ == pose.seq && cached_t_ns_ == pose.t_ns &&
      cached_stall_ == packet.from_stall) {
    return published_;
  }
  cache_valid_ = true;
  cached_seq_ = pose.seq;
  cached_t_ns_ = pose.t_ns;
  cached_stall_ = packet.from_stall;
  cached_.reset();
  published_ = PublishedPose{};
  published_.utc_ns = time_base_.capture_utc_ns(packet);
  const geo::SiteFrame* frame = site_frame(packet);
  const auto [anchor_position_m, anchor_attitude_rad] =
      frame != nullptr ? anchor_std() : std::pair<double, double>{0.0, 0.0};
  published_.pose = output::published_pose(pose, lever_arm_cam_m_, publish_.covariance, anchor_position_m,
                                           anchor_attitude_rad);
  published_.pose.t_ns = published_.utc_ns;
  if (frame != nullptr) {
    // Not finite or outside UTM/UPS: published without a site.
    if (auto site = frame->to_site(published_.pose)) cached_ = std::move(*site);
  }
  published_.site = cached_ ? &*cached_ : nullptr;
  if (published_.site != nullptr && geoid_) {
    const geo::Geodetic& g = published_.site->geodetic;
    if (auto n = geoid_->height_above_ellipsoid_m(g.latitude_deg, g.longitude_deg))
      published_.geoid_separation_m = *n;
  }
  update_velocity(packet);
  const Matrix6d covariance =
      published_.site
          ? published_.site->covariance_site
          : geo::site_covariance(SE3::identity(), published_.pose.T_world_cam, published_.pose.covariance);
  published_.protection_level_m = output::protection_level_m(covariance.topLeftCorner<3, 3>(),
                                                             publish_.integrity.protection_level_sigmas);
  published_.integrity_alert =
      output::integrity_alert(published_.protection_level_m, publish_.integrity.alert_limit_m);
  return published_;
}

void Anchoring::update_velocity(const pipeline::PosePacket& packet) {
  const bool usable = packet.pose.state != TrackingState::kLost && !packet.from_stall;
  if (!usable) {
    last_position_.reset();
    return;
  }
  LastPosition now;
  now.t_ns = published_.utc_ns;
  now.site = published_.site != nullptr;
  const Matrix6d covariance = now.site ? published_.site->covariance_site
                                       : geo::site_covariance(SE3::identity(), published_.pose.T_world_cam,
                                                              published_.pose.covariance);
  now.p = now.site ? published_.site->T_site_cam.translation() : published_.pose.T_world_cam.translation();
  now.covariance = covariance.topLeftCorner<3, 3>();
  if (last_position_ && last_position_->site == now.site) {
    published_.velocity = output::finite_difference_velocity(
        last_position_->p, last_position_->covariance, last_position_->t_ns, now.p, now.covariance, now.t_ns);
  }
  last_position_ = now;
}

// --------------------------------------------------------- TrajectoryOutput

namespace {

// Time of the last line of a TUM file (its first field), in ns; nullopt
// for an empty file or one whose last line does not start with a number.
std::optional<std::int64_t> last_tum_time_ns(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  const std::streamoff tail = std::min<std::streamoff>(size, 4096);
  in.seekg(size - tail);
  std::string text(static_cast<std::size_t>(tail), '\0');
  in.read(text.data(), tail);
  while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
  const std::size_t begin = text.rfind('\n') == std::string::npos ? 0 : text.rfind('\n') + 1;
  double t_s = 0.0;
  const auto result = std::from_chars(text.data() + begin, text.data() + text.size(), t_s);
  if (result.ec != std::errc() || !std::isfinite(t_s) || std::abs(t_s) > 9e9) return std::nullopt;
  return std::llround(t_s * 1e9);
}

}  // namespace

Expected<std::unique_ptr<TrajectoryOutput>> TrajectoryOutput::open(const std::string& path, bool append) {
  auto file = io::LineFile::open(path, append);
  if (!file) return make_error(file.error().code, "outputs.trajectory.path: " + file.error().message);
  std::unique_ptr<TrajectoryOutput> out(new TrajectoryOutput(std::move(*file), path));
  if (append) out->last_t_ns_ = last_tum_time_ns(path);
  return out;
}

Status TrajectoryOutput::rotate() {
  namespace fs = std::filesystem;
  std::error_code ec;
  std::string moved;
  for (int n = 1; n <= 100000; ++n) {
    moved = path_ + "." + std::to_string(n);
    if (!fs::exists(fs::symlink_status(moved, ec))) break;
  }
  fs::rename(path_, moved, ec);
  if (ec)
    return make_error(ErrorCode::kIoError,
                      "outputs.trajectory.path: cannot move " + path_ + " to " + moved + ": " + ec.message());
  auto file = io::LineFile::open(path_, false);
  if (!file) {
    fs::rename(moved, path_, ec);  // keep writing where we were
    return make_error(file.error().code, "outputs.trajectory.path: " + file.error().message);
  }
  file_ = std::move(*file);
  spdlog::warn(
      "outputs.trajectory.path: a pose time not after the file's last line (the time base started "
      "again: a restarted replay, or a clock stepped back); earlier lines moved to {}",
      moved);
  return ok_status();
}

Status TrajectoryOutput::write_pending() {
  if (last_t_ns_ && pending_t_ns_ <= *last_t_ns_) {
    SITEPOSE_TRY_STATUS(rotate());
    last_t_ns_.reset();
  }
  SITEPOSE_TRY_STATUS(file_.write(pending_));
  pending_.clear();
  last_t_ns_ = pending_t_ns_;
  ++lines_written_;
  return ok_status();
}

Status TrajectoryOutput::publish(const pipeline::PosePacket& packet) {
  const PoseEstimate& p = packet.pose;
  pending_.clear();
  if (p.state == TrackingState::kLost || packet.from_stall) return ok_status();
  const auto& t = p.T_world_cam.translation();
  const auto& q = p.T_world_cam.rotation();
  pending_ = fmt::format("{:.9f} {:.9f} {:.9f} {:.9f} {:.9f} {:.9f} {:.9f} {:.9f}\n",
                         static_cast<double>(p.t_ns) * 1e-9, t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
  pending_t_ns_ = p.t_ns;
  return write_pending();
}

Status TrajectoryOutput::retry() { return pending_.empty() ? ok_status() : write_pending(); }

// ---------------------------------------------------------------- CanOutput

Status CanOutput::publish(const pipeline::PosePacket& packet) {
  const PublishedPose& published = anchoring_.published(packet);
  const PoseEstimate& pose = published.pose;
  const geo::SitePose* site = published.site;
  output::CanPoseInputs in;
  in.utc_t_ns = published.utc_ns;
  in.quality = output::pose_quality_from_estimate(pose);
  in.quality.integrity_alert = published.integrity_alert;
  if (site == nullptr) {
    in.latitude_deg = in.longitude_deg = in.altitude_m = kNaN;
    in.heading_rad = in.course_over_ground_rad = in.speed_over_ground_mps = in.pitch_rad = kNaN;
    in.quality.state = TrackingState::kLost;  // no WGS84 position to steer by
  } else {
    in.latitude_deg = site->geodetic.latitude_deg;
    in.longitude_deg = site->geodetic.longitude_deg;
    in.altitude_m = site->geodetic.height_m;
    in.geoidal_separation_m = published.geoid_separation_m;
    in.heading_rad = site->heading_deg * kDegToRad;  // NaN stays NaN: "not available"
    in.quality.position_std_m = site->position_std_m;
    const Eigen::Vector3d forward = site->T_site_cam.rotation() * geo::axis_vector(anchoring_.forward_axis());
    in.pitch_rad = std::atan2(forward.z(), std::hypot(forward.x(), forward.y()));
    in.course_over_ground_rad = in.speed_over_ground_mps = kNaN;
    if (published.velocity.valid()) {
      const Eigen::Vector3d& v = published.velocity.mps;
      in.speed_over_ground_mps = std::hypot(v.x(), v.y());
      if (in.speed_over_ground_mps > 0.01) {  // a course needs motion
        in.course_over_ground_rad = std::atan2(v.x(), v.y());
        if (in.course_over_ground_rad < 0) in.course_over_ground_rad += 2 * std::numbers::pi;
      }
    }
  }
  frames_ = encoder_.encode(in);
  next_frame_ = 0;
  flushed_ = false;
  frame_t_ns_ = published.utc_ns;
  return send_pending();
}

Status CanOutput::send_pending() {
  while (next_frame_ < frames_.size()) {
    SITEPOSE_TRY_STATUS(sink_->send(frame_t_ns_, frames_[next_frame_]));
    ++next_frame_;
  }
  if (!flushed_) {
    SITEPOSE_TRY_STATUS(sink_->flush());
    flushed_ = true;
  }
  return ok_status();
}

Status CanOutput::retry() { return send_pending(); }

// ---------------------------------------------------------------- LcmOutput

Status LcmOutput::publish(const pipeline::PosePacket& packet) {
  const PublishedPose& published = anchoring_.published(packet);
  SITEPOSE_TRY_STATUS(
      publisher_->publish_pose(published.pose, published.site, &published.velocity, anchoring_.integrity()));
  last_pose_utc_ns_ = published.utc_ns;
  last_latency_ms_ = anchoring_.time_base().latency_ms(packet);
  return ok_status();
}

output::LcmHealth to_lcm_health(const pipeline::PipelineHealth& h, std::int64_t t_ns) {
  output::LcmHealth l;
  l.t_ns = t_ns;
  l.fps = h.fps;
  l.latency_p50_ms = h.latency_p50_ms;
  l.latency_p99_ms = h.latency_p99_ms;
  l.state = h.state;
  l.state_reason = h.state_reason;
  l.frames_captured = static_cast<std::int64_t>(h.frames_captured);
  l.frames_tracked = static_cast<std::int64_t>(h.frames_tracked);
  l.stalls = static_cast<std::int64_t>(h.stalls);
  for (const auto& s : h.stages) {
    l.stages.push_back({s.name, static_cast<std::int64_t>(s.drops), static_cast<std::int32_t>(s.queue_depth),
                        s.p50_ms, s.p99_ms});
  }
  for (const auto& o : h.outputs) {
    l.outputs.push_back({o.name, static_cast<std::int64_t>(o.errors), static_cast<std::int64_t>(o.failed)});
  }
  return l;
}

Status LcmOutput::publish_health(const pipeline::PipelineHealth& health) {
  output::LcmHealth h = to_lcm_health(health, anchoring_.time_base().now_utc_ns());
  h.last_pose_t_ns = last_pose_utc_ns_;
  h.last_pose_latency_ms = last_latency_ms_;
  return publisher_->publish_health(h);
}

}  // namespace sitepose::daemon
