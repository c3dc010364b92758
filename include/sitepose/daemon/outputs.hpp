#pragma once
// The daemon's publish side: the site anchoring every output shares, and
// the pipeline::PoseOutput implementations (LCM, CAN, TUM trajectory).
// Threads: everything here runs on the pipeline's publish thread, except
// Anchoring::push_fix() (one GNSS receiving thread; a lock-free SPSC ring
// hands the fixes over) and the outputs' destructors (after the threads end).

#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sitepose/daemon/daemon_config.hpp"
#include "sitepose/geo/geoid.hpp"
#include "sitepose/geo/site_anchor.hpp"
#include "sitepose/geo/site_frame.hpp"
#include "sitepose/io/line_file.hpp"
#include "sitepose/output/can_pose_encoder.hpp"
#include "sitepose/output/can_sink.hpp"
#include "sitepose/output/lcm_publisher.hpp"
#include "sitepose/output/published_pose.hpp"
#include "sitepose/pipeline/hooks.hpp"
#include "sitepose/pipeline/spsc_ring.hpp"

namespace sitepose::daemon {

// The one time base of every output (docs/daemon/README.md "Time base"):
// UTC, ns since the Unix epoch. A pose's UTC time is its capture time
// stamp (PoseEstimate::t_ns, the source's clock) plus one offset, fixed at
// the first pose: that frame's capture on the system clock (system time now
// minus how long ago, on the steady clock, the capture stage got it) minus
// its stamp. So time differences stay the source's (a replay keeps its
// spacing, shifted to now) and every output stamps one pose alike. A source
// that already stamps in UTC (offset under kUtcTolerance) keeps its stamps.
// Used on the publish thread only.
class TimeBase {
 public:
  struct Now {
    std::int64_t system_ns = 0;  // UTC, ns since the Unix epoch
    pipeline::SteadyTime steady;
  };
  using Clock = std::function<Now()>;
  static constexpr std::int64_t kUtcTolerance_ns = 1'000'000'000;

  explicit TimeBase(Clock clock = system_clock_now) : clock_(std::move(clock)) {}
  static Now system_clock_now();

  // UTC of the packet's capture (fixes the offset at the first call).
  std::int64_t capture_utc_ns(const pipeline::PosePacket& packet);
  Now now() const { return clock_(); }
  std::int64_t now_utc_ns() const { return clock_().system_ns; }
  // Publish latency: steady time now minus the packet's capture (0 for a
  // packet without a capture stamp). On the steady clock, so it stays true
  // for a replay at rate max, whose pose times run ahead of the clock.
  double latency_ms(const pipeline::PosePacket& packet) const;
  std::optional<std::int64_t> offset_ns() const { return offset_ns_; }

 private:
  Clock clock_;
  std::optional<std::int64_t> offset_ns_;
};

// How a tracked camera pose becomes the published one
// (output/published_pose.hpp): outputs.reference_point, outputs.covariance.
// The default publishes the camera with the tracker's covariance.
struct PublishOptions {
  Eigen::Vector3d lever_arm_m = Eigen::Vector3d::Zero();  // machine frame
  output::CovarianceOptions covariance;
  output::IntegrityOptions integrity;  // outputs.integrity; alert limit 0 = never alert
};
PublishOptions publish_options(const DaemonConfig& config);

// One pose as every output publishes it.
struct PublishedPose {
  std::int64_t utc_ns = 0;              // capture time, UTC (TimeBase)
  PoseEstimate pose;                    // the reference point: T_world_cam * lever arm, t_ns = utc_ns,
                                        // covariance scaled, floored and with the anchor's uncertainty
  const geo::SitePose* site = nullptr;  // the same in the site frame; nullptr without one
  output::Velocity velocity;            // in the site frame when site, else the SLAM frame
  // Geoid height above the ellipsoid at the site position (geo.geoid);
  // NaN without a site position or a geoid.
  double geoid_separation_m = std::numeric_limits<double>::quiet_NaN();
  // Protection level of the published covariance (outputs.integrity.
  // protection_level_sigmas x the largest position std) and whether it
  // exceeds outputs.integrity.alert_limit_m (LCM and CAN carry both).
  double protection_level_m = std::numeric_limits<double>::infinity();
  bool integrity_alert = false;
};

// T_site_slam for the outputs: fixed from the config, or estimated online
// by geo::SiteAnchor from GNSS fixes (LCM or an NMEA file), or none. Each
// pose is anchored once and the result shared by every output, so LCM and
// CAN never disagree about one pose even while the estimate changes.
class Anchoring {
 public:
  static Expected<std::unique_ptr<Anchoring>> create(const GeoConfig& config,
                                                     const PublishOptions& publish = {});

  // The pose as published (reference point, UTC time, covariance, site
  // pose, velocity); cached for the last pose like site_pose().
  const PublishedPose& published(const pipeline::PosePacket& packet);

  // The published pose in the site frame; nullptr while no site frame is
  // known (mode none, or online before the first estimate) or when the pose
  // cannot be converted. Caches the last pose's answer (keyed by seq, t_ns,
  // stall).
  const geo::SitePose* site_pose(const pipeline::PosePacket& packet) { return published(packet).site; }
  // Any one thread (the GNSS subscriber): a fix for the online anchor.
  void push_fix(const geo::GnssFix& fix);
  // Fixes known up front (an NMEA file); fed as the poses reach their time.
  void set_scheduled_fixes(std::vector<geo::GnssFix> fixes);

  // The time base of every output (kept here so that each pose is mapped
  // once, like its site pose).
  TimeBase& time_base() { return time_base_; }
  const output::IntegrityOptions& integrity() const { return publish_.integrity; }

  GeoMode mode() const { return config_.mode; }
  geo::ForwardAxis forward_axis() const { return config_.forward_axis_cam; }
  std::optional<geo::AnchorStatus> anchor_status() const;

 private:
  Anchoring(const GeoConfig& config, const PublishOptions& publish)
      : config_(config), publish_(publish), fixes_(256) {}
  const geo::SiteFrame* site_frame(const pipeline::PosePacket& packet);
  // The site anchor's uncertainty as isotropic position / attitude stds.
  std::pair<double, double> anchor_std() const;
  void update_velocity(const pipeline::PosePacket& packet);

  GeoConfig config_;
  PublishOptions publish_;
  Eigen::Vector3d lever_arm_cam_m_ = Eigen::Vector3d::Zero();
  TimeBase time_base_;
  std::optional<geo::GeoidGrid> geoid_;
  std::optional<geo::SiteFrame> fixed_;
  std::optional<geo::SiteAnchor> anchor_;
  pipeline::SpscRing<geo::GnssFix> fixes_;
  std::vector<geo::GnssFix> scheduled_;
  std::size_t next_scheduled_ = 0;
  // Cache of the last anchored pose.
  std::int64_t cached_seq_ = -1, cached_t_ns_ = -1;
  bool cached_stall_ = false, cache_valid_ = false;
  std::optional<geo::SitePose> cached_;
  PublishedPose published_;
  // The last position published (for the velocity): time, frame, [dp] covariance.
  struct LastPosition {
    std::int64_t t_ns = 0;
    bool site = false;
    Eigen::Vector3d p;
    Eigen::Matrix3d covariance;
  };
  std::optional<LastPosition> last_position_;
};

// TUM lines "t x y z qx qy qz qw" (T_world_cam, SLAM frame, FORMATS.md) of
// every published pose that is not LOST, through an io::LineFile: a failed
// or short write (full disk) is cut back, so the file holds whole lines
// only, and a retry writes the line again, never a duplicate. The times of
// a file always increase: with append, a restart whose first pose is not
// after the file's last line (a replay started again, a clock stepped back)
// moves the file to <path>.N (the first free N >= 1) and starts a new one.
class TrajectoryOutput final : public pipeline::PoseOutput {
 public:
  static Expected<std::unique_ptr<TrajectoryOutput>> open(const std::string& path, bool append);
  std::string name() const override { return "trajectory"; }
  Status publish(const pipeline::PosePacket& packet) override;
  Status retry() override;
  std::uint64_t lines_written() const { return lines_written_; }

 private:
  TrajectoryOutput(io::LineFile file, std::string path) : file_(std::move(file)), path_(std::move(path)) {}
  Status write_pending();
  Status rotate();
  io::LineFile file_;
  std::string path_;
  std::string pending_;  // the line not written yet
  std::int64_t pending_t_ns_ = 0;
  std::optional<std::int64_t> last_t_ns_;  // time of the file's last line
  std::uint64_t lines_written_ = 0;
};

// The CAN frame set of each pose (canring's CanPoseEncoder) into a CanSink,
// stamped (candump lines, 129029 date/time) with the pose's UTC capture time.
// Without a site frame the frames say LOST ("no site anchor"): the ECU
// needs WGS84 positions. Positions are the reference point's; speed and
// course its velocity (Anchoring::published). A failed frame is resumed by retry() from that frame on, so
// the ECU never sees a frame twice; the sink is flushed once per pose.
class CanOutput final : public pipeline::PoseOutput {
 public:
  CanOutput(const output::CanOutputOptions& options, std::unique_ptr<output::CanSink> sink,
            Anchoring& anchoring)
      : encoder_(options), sink_(std::move(sink)), anchoring_(anchoring) {}
  std::string name() const override { return "can"; }
  Status publish(const pipeline::PosePacket& packet) override;
  Status retry() override;
  output::CanSinkCounters sink_counters() const { return sink_->counters(); }

 private:
  Status send_pending();
  output::CanPoseEncoder encoder_;
  std::unique_ptr<output::CanSink> sink_;
  Anchoring& anchoring_;
  std::vector<output::CanFrame> frames_;
  std::size_t next_frame_ = 0;
  bool flushed_ = true;
  std::int64_t frame_t_ns_ = 0;
};

// pose_t per pose and health_t per health report (geolcm's LcmPublisher).
class LcmOutput final : public pipeline::PoseOutput {
 public:
  LcmOutput(std::unique_ptr<output::LcmPublisher> publisher, Anchoring& anchoring)
      : publisher_(std::move(publisher)), anchoring_(anchoring) {}
  std::string name() const override { return "lcm"; }
  Status publish(const pipeline::PosePacket& packet) override;
  Status retry() override { return publisher_->retry_pose(); }
  Status publish_health(const pipeline::PipelineHealth& health) override;
  output::LcmPublisherStats stats() const { return publisher_->stats(); }

 private:
  std::unique_ptr<output::LcmPublisher> publisher_;
  Anchoring& anchoring_;
  std::int64_t last_pose_utc_ns_ = -1;  // capture time of the last pose sent, UTC
  double last_latency_ms_ = -1.0;       // its publish latency (TimeBase::latency_ms)
};

// pipeline health -> LCM health_t contents; t_ns: the report's time (UTC).
output::LcmHealth to_lcm_health(const pipeline::PipelineHealth& health, std::int64_t t_ns);

}  // namespace sitepose::daemon
