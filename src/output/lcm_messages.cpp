#include "sitepose/output/lcm_messages.hpp"

#include <cmath>
#include <limits>

#include <fmt/format.h>

namespace sitepose::output {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::int64_t utime_of(std::int64_t t_ns) {
  // Floor, so that negative times (simulation) round consistently.
  return t_ns >= 0 ? t_ns / 1000 : -((-t_ns + 999) / 1000);
}
}  // namespace

std::int8_t lcm_state(TrackingState state) {
  switch (state) {
    case TrackingState::kOk: return sitepose::pose_t::STATE_OK;
    case TrackingState::kRecovering: return sitepose::pose_t::STATE_RECOVERING;
    case TrackingState::kLost: return sitepose::pose_t::STATE_LOST;
  }
  return sitepose::pose_t::STATE_LOST;
}

sitepose::pose_t to_lcm_pose(const PoseEstimate& pose, const geo::SitePose* site, const Velocity* velocity,
                             const IntegrityOptions& integrity) {
  sitepose::pose_t m;
  m.utime = utime_of(pose.t_ns);
  m.seq = pose.seq;
  m.state = lcm_state(pose.state);
  m.state_reason = pose.state_reason;
  m.features_used = pose.counters.features_used;
  m.features_pass1 = pose.counters.features_used_pass1;
  m.static_objects_unmasked = pose.counters.static_objects_unmasked;
  m.masked_area_ratio = static_cast<float>(pose.counters.masked_area_ratio);

  const SE3& T = site ? site->T_site_cam : pose.T_world_cam;
  const Matrix6d covariance =
      site ? site->covariance_site : geo::site_covariance(SE3::identity(), pose.T_world_cam, pose.covariance);
  m.frame = site ? sitepose::pose_t::FRAME_SITE : sitepose::pose_t::FRAME_SLAM;
  for (int i = 0; i < 3; ++i) m.position[i] = T.translation()(i);
  m.orientation[0] = T.rotation().w();
  m.orientation[1] = T.rotation().x();
  m.orientation[2] = T.rotation().y();
  m.orientation[3] = T.rotation().z();
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) m.covariance[r * 6 + c] = covariance(r, c);
  }
  m.protection_level_m =
      protection_level_m(covariance.topLeftCorner<3, 3>(), integrity.protection_level_sigmas);
  m.integrity_alert = integrity_alert(m.protection_level_m, integrity.alert_limit_m) ? 1 : 0;
  const bool has_velocity = velocity != nullptr && velocity->valid();
  for (int r = 0; r < 3; ++r) {
    m.velocity[r] = has_velocity ? velocity->mps(r) : kNaN;
    for (int c = 0; c < 3; ++c)
      m.velocity_covariance[r * 3 + c] = has_velocity ? velocity->covariance(r, c) : kNaN;
  }
  if (site) {
    m.latitude_deg = site->geodetic.latitude_deg;
    m.longitude_deg = site->geodetic.longitude_deg;
    m.height_m = site->geodetic.height_m;
    m.utm_easting_m = site->utm.easting_m;
    m.utm_northing_m = site->utm.northing_m;
    m.utm_zone = static_cast<std::int8_t>(site->utm.zone);
    m.utm_north = site->utm.north ? 1 : 0;
    m.heading_deg = site->heading_deg;
    m.heading_std_deg = site->heading_std_deg;
    m.position_std_m = site->position_std_m;
  } else {
    m.latitude_deg = m.longitude_deg = m.height_m = kNaN;
    m.utm_easting_m = m.utm_northing_m = kNaN;
    m.utm_zone = -1;
    m.utm_north = 0;
    m.heading_deg = m.heading_std_deg = kNaN;
    m.position_std_m = std::sqrt(std::max(covariance.block<3, 3>(0, 0).trace(), 0.0));
  }
  return m;
}

sitepose::health_t to_lcm_health(const LcmHealth& health) {
  sitepose::health_t m;
  m.utime = utime_of(health.t_ns);
  m.last_pose_utime = health.last_pose_t_ns < 0 ? -1 : utime_of(health.last_pose_t_ns);
  m.last_pose_latency_ms = static_cast<float>(health.last_pose_latency_ms);
  m.fps = static_cast<float>(health.fps);
  m.latency_p50_ms = static_cast<float>(health.latency_p50_ms);
  m.latency_p99_ms = static_cast<float>(health.latency_p99_ms);
  m.state = lcm_state(health.state);
  m.state_reason = health.state_reason;
  m.frames_captured = health.frames_captured;
  m.frames_tracked = health.frames_tracked;
  m.stalls = health.stalls;
  m.num_stages = static_cast<std::int32_t>(health.stages.size());
  for (const LcmStageHealth& s : health.stages) {
    m.stage_names.push_back(s.name);
    m.drops.push_back(s.drops);
    m.queue_depths.push_back(s.queue_depth);
    m.p50_ms.push_back(static_cast<float>(s.p50_ms));
    m.p99_ms.push_back(static_cast<float>(s.p99_ms));
  }
  m.num_outputs = static_cast<std::int32_t>(health.outputs.size());
  for (const LcmOutputHealth& o : health.outputs) {
    m.output_names.push_back(o.name);
    m.output_errors.push_back(o.errors);
    m.output_failed.push_back(o.failed);
  }
  return m;
}

sitepose::gnss_fix_t to_lcm_gnss_fix(const geo::GnssFix& fix) {
  sitepose::gnss_fix_t m;
  m.utime = utime_of(fix.t_ns);
  m.latitude_deg = fix.position.latitude_deg;
  m.longitude_deg = fix.position.longitude_deg;
  m.height_m = fix.position.height_m;
  m.quality = static_cast<std::int8_t>(fix.quality);
  m.num_satellites = static_cast<std::int16_t>(fix.num_satellites);
  m.hdop = static_cast<float>(fix.hdop);
  return m;
}

Expected<geo::GnssFix> from_lcm_gnss_fix(const sitepose::gnss_fix_t& message) {
  auto quality = geo::gnss_quality_from_int(message.quality);
  if (!quality) {
    return make_error(ErrorCode::kInvalidArgument,
                      fmt::format("gnss_fix_t utime {}: {}", message.utime, quality.error().message));
  }
  if (message.num_satellites < 0) {
    return make_error(ErrorCode::kInvalidArgument,
                      fmt::format("gnss_fix_t utime {}: num_satellites = {}: expected >= 0", message.utime,
                                  message.num_satellites));
  }
  // Microseconds to nanoseconds must not overflow (fuzz_gnss_fix found it:
  // UB, and a wrapped time that pairs the fix with the wrong pose).
  constexpr std::int64_t kMaxUtime = std::numeric_limits<std::int64_t>::max() / 1000;
  if (message.utime > kMaxUtime || message.utime < -kMaxUtime) {
    return make_error(
        ErrorCode::kInvalidArgument,
        fmt::format("gnss_fix_t utime {}: out of range (|utime| <= {} us)", message.utime, kMaxUtime));
  }
  geo::GnssFix fix;
  fix.t_ns = message.utime * 1000;
  fix.position = {message.latitude_deg, message.longitude_deg, message.height_m};
  fix.quality = *quality;
  fix.num_satellites = message.num_satellites;
  fix.hdop = message.hdop;
  if (fix.quality != geo::GnssQuality::kInvalid || fix.has_position()) {
    SITEPOSE_TRY_STATUS(geo::validate_geodetic(
        fix.position, fmt::format("gnss_fix_t utime {} ({})", message.utime, geo::to_string(*quality))));
  }
  return fix;
}

}  // namespace sitepose::output
