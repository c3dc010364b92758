#include "sitepose/dynamic/motion_classifier.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>

#include "detail/object_verdict.hpp"
#include "detail/point_displacement.hpp"
#include "sitepose/core/stopwatch.hpp"
#include "sitepose/features/hamming.hpp"
#include "sitepose/optim/triangulation.hpp"

namespace sitepose::dynamic {
namespace {

// Descriptor matching between the objects of RF and CF (METHOD.md: the
// authors' ratio test 0.7; ORB-SLAM2's TH_LOW 50 bits as the upper bound).
constexpr double kMatchRatio = 0.7;
constexpr int kMaxMatchDistance = 50;
// Authors' code: object points within 40 baselines; errors above 10 m are
// mismatches, not motion.
constexpr double kMaxDepthBaselines = 40.0;
constexpr double kMaxPointErrorM = 10.0;
// Level-0 keypoint noise (px) of u_l, v_l and of the refined u_r; grows with
// the pyramid scale like ORB-SLAM2's information matrix.
constexpr double kPixelSigmaPx = 1.0;
// Bounds on the a-posteriori variance factor (clamped_variance_factor).
constexpr double kMinVarianceFactor = 0.05;
constexpr double kMaxVarianceFactor = 4.0;
// Sitepose mode: a static verdict needs this much time between RF and CF;
// over a shorter gap a slowly starting machine has not moved measurably yet
// (the authors' reference: 0.5 s). Moving verdicts count at any gap.
constexpr double kMinStaticEvidenceS = 0.4;
// Ring length in seconds of frames (sitepose mode looks back for parallax).
constexpr double kRingSeconds = 2.0;

// Standing camera (no frame in the ring with parallax): the newest frame at
// least this old. Any displacement is then the object's own; a 2 s gap (the
// ring's oldest) would keep a machine that stopped masked for 2 s more.
constexpr double kStandingReferenceS = 1.0;
// The camera counts as standing when its centre moved less than this since
// the reference (vibration of a standing roller is ~1 mm).
constexpr double kStandingMotionM = 0.03;
// People (METHOD: always a dynamic class) are unmasked only on strong
// evidence: twice the points and three times the static frames.
constexpr const char* kPersonClass = "person";
// Machines whose parts move on their own (slewing house, boom, arm, bucket)
// are "working" with two moving verdicts within kWorkingMemoryS
// (detail/object_verdict.hpp: how a working machine's points are judged).
// Longer than the pauses between a working machine's strokes (4-8 s). An
// articulated machine with a moving verdict and one more sign of motion
// within it stays masked: its next stroke starts from rest, too slowly for
// the first frames' test, and its moving house loses its matches while the
// standing tracks keep theirs and look static.
constexpr double kWorkingMemoryS = 20.0;
// `seen_t_ns` (a verdict's or sign's time, if any) lies within
// kWorkingMemoryS before t_ns.
bool within_working_memory(const std::optional<std::int64_t>& seen_t_ns, std::int64_t t_ns) {
  return seen_t_ns && static_cast<double>(t_ns - *seen_t_ns) * 1e-9 <= kWorkingMemoryS;
}
bool is_articulated_class(const std::string& class_name) {
  return class_name == "excavator" || class_name == "loader";
}
constexpr int kPersonPointFactor = 2;
constexpr int kPersonHysteresisFactor = 3;

using detail::errors_m_of;
using detail::judge_paper;
using detail::judge_sitepose;
using detail::ObjectKind;
using detail::PointDisplacement;

// CF's pose covariance as the noise model uses it (scaled by the clamped
// variance factor); nullopt when unknown.
std::optional<Matrix6d> scaled_pose_covariance(const ObjectFeatures& frame) {
  if (!frame.covariance) return std::nullopt;
  return *frame.covariance * clamped_variance_factor(frame.variance_factor);
}

// Per CF keypoint its RF keypoint, or -1: the nearest RF descriptor under the
// ratio test, one CF keypoint per RF keypoint (the closer wins); then the
// mutual check: the RF keypoint's own nearest CF keypoint must be the same
// one (few-point objects were called moving on mismatches otherwise).
std::vector<int> match_keypoints(const ObjectFeatures& current, const ObjectFeatures& ref) {
  const int n_cf = static_cast<int>(current.uv_px.size());
  const int n_rf = static_cast<int>(ref.uv_px.size());
  const auto cf_descriptor = [&](int c) { return current.descriptors.ptr<std::uint8_t>(c); };
  const auto rf_descriptor = [&](int r) { return ref.descriptors.ptr<std::uint8_t>(r); };
  std::vector<int> match(n_cf, -1);
  std::vector<int> best_distance_of_ref(n_rf, features::kDescriptorBits + 1);
  std::vector<int> cf_of_ref(n_rf, -1);
  for (int c = 0; c < n_cf; ++c) {
    const features::NearestTwo nearest = features::nearest_two(cf_descriptor(c), n_rf, rf_descriptor);
    const int r = nearest.index;
    if (r < 0 || nearest.distance > kMaxMatchDistance ||
        nearest.distance > kMatchRatio * nearest.second_distance) {
      continue;
    }
    if (nearest.distance < best_distance_of_ref[r]) {
      if (cf_of_ref[r] >= 0) match[cf_of_ref[r]] = -1;
      best_distance_of_ref[r] = nearest.distance;
      cf_of_ref[r] = c;
      match[c] = r;
    }
  }
  for (int c = 0; c < n_cf; ++c) {
    if (match[c] >= 0 && features::nearest_two(rf_descriptor(match[c]), n_cf, cf_descriptor).index != c) {
      match[c] = -1;
    }
  }
  return match;
}

// RF object of each CF object: votes of matched keypoints per (CF object, RF
// object); greedily the pair with most votes, each object used once.
std::map<std::uint16_t, std::uint16_t> associate_objects(const ObjectFeatures& current,
                                                         const ObjectFeatures* ref,
                                                         const std::vector<int>& match) {
  std::map<std::pair<std::uint16_t, std::uint16_t>, int> votes;
  for (std::size_t c = 0; c < match.size(); ++c) {
    if (match[c] >= 0) ++votes[{current.instance[c], ref->instance[match[c]]}];
  }
  std::vector<std::pair<int, std::pair<std::uint16_t, std::uint16_t>>> ranked;
  ranked.reserve(votes.size());
  for (const auto& [pair, n] : votes) ranked.push_back({n, pair});
  std::sort(ranked.begin(), ranked.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::map<std::uint16_t, std::uint16_t> ref_of_current;
  std::map<std::uint16_t, bool> ref_used;
  for (const auto& [n, pair] : ranked) {
    if (ref_of_current.count(pair.first) != 0 || ref_used[pair.second]) continue;
    ref_of_current[pair.first] = pair.second;
    ref_used[pair.second] = true;
  }
  return ref_of_current;
}

}  // namespace

ObjectFeatures make_object_features(const tracking::PreparedFrame& frame, const std::vector<ObjectBox>& boxes,
                                    const SE3& T_world_cam, const std::optional<Matrix6d>& covariance,
                                    double variance_factor, double max_depth_m) {
  ObjectFeatures out;
  out.variance_factor = variance_factor;
  out.seq = frame.seq;
  out.t_ns = frame.t_ns;
  out.T_world_cam = T_world_cam;
  out.covariance = covariance;
  out.boxes = boxes;
  std::vector<int> rows;
  for (int k = 0; k < frame.size(); ++k) {
    if (frame.instance[k] != 0 && detail::gives_trusted_point(frame, k, max_depth_m)) rows.push_back(k);
  }
  out.descriptors.create(static_cast<int>(rows.size()), features::kDescriptorBytes, CV_8UC1);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const int k = rows[i];
    out.uv_px.push_back(frame.uv_px[k]);
    out.u_right_px.push_back(frame.features.u_right[k]);
    out.octave.push_back(frame.octave[k]);
    out.instance.push_back(frame.instance[k]);
    frame.features.descriptors.row(k).copyTo(out.descriptors.row(static_cast<int>(i)));
  }
  return out;
}

std::vector<ClassifiedObject> unclassified_objects(const std::vector<ObjectBox>& boxes) {
  std::vector<ClassifiedObject> out;
  for (const ObjectBox& b : boxes) {
    ClassifiedObject o;
    o.verdict.instance = b.instance;
    o.verdict.class_name = b.class_name;
    o.verdict.unknown_reason = UnknownReason::kNoReference;
    out.push_back(std::move(o));
  }
  return out;
}

double clamped_variance_factor(double variance_factor) {
  return std::clamp(variance_factor, kMinVarianceFactor, kMaxVarianceFactor);
}

bool is_static_at(const std::vector<double>& statistics, double threshold, double fraction) {
  if (statistics.empty()) return false;
  const auto below =
      std::count_if(statistics.begin(), statistics.end(), [&](double s) { return s < threshold; });
  return static_cast<double>(below) > fraction * static_cast<double>(statistics.size());
}

MotionClassifier::MotionClassifier(const StereoCamera& camera, const config::DynamicConfig& config,
                                   double fps, double scale_factor, int n_levels)
    : camera_(camera), config_(config) {
  reference_offset_ = config.reference_offset_frames > 0
                          ? config.reference_offset_frames
                          : std::max(1, static_cast<int>(std::lround(fps / 2.5)));
  capacity_ =
      static_cast<std::size_t>(std::max<double>(reference_offset_, std::ceil(kRingSeconds * fps)) + 1);
  max_depth_m_ = kMaxDepthBaselines * camera.baseline_m;
  double s = 1.0;
  for (int l = 0; l < std::max(1, n_levels); ++l) {
    level_scale_.push_back(s);
    s *= scale_factor;
  }
}

void MotionClassifier::reset() {
  ring_.clear();
  tracks_.clear();
}

std::vector<std::uint16_t> MotionClassifier::static_instances() const {
  std::vector<std::uint16_t> out;
  for (const auto& [instance, track] : tracks_) {
    if (track.state == MotionState::kStatic) out.push_back(instance);
  }
  return out;
}

void MotionClassifier::remember(ObjectFeatures frame) {
  ring_.push_back(std::move(frame));
  while (ring_.size() > capacity_) ring_.pop_front();
}

double MotionClassifier::pixel_sigma_px(int octave, double variance_factor) const {
  const int level = std::clamp(octave, 0, static_cast<int>(level_scale_.size()) - 1);
  return kPixelSigmaPx * level_scale_[level] * std::sqrt(clamped_variance_factor(variance_factor));
}

std::optional<MotionClassifier::WorldPoint> MotionClassifier::to_world(
    const Eigen::Vector2d& uv_px, double u_right_px, int octave, double variance_factor,
    const SE3& T_world_cam, const Matrix6d* pose_covariance) const {
  const double sigma_px = pixel_sigma_px(octave, variance_factor);
  const auto p_cam = optim::stereo_point_in_camera(
      camera_, uv_px, u_right_px, optim::stereo_pixel_covariance(sigma_px, sigma_px, sigma_px));
  if (!p_cam) return std::nullopt;
  const optim::PointWithCovariance p_world = optim::point_to_world(*p_cam, T_world_cam, pose_covariance);
  const Eigen::Matrix3d R_world_cam = T_world_cam.rotation_matrix();
  return WorldPoint{p_world.p, p_world.covariance, R_world_cam * p_cam->covariance * R_world_cam.transpose()};
}

const ObjectFeatures* MotionClassifier::select_reference(const ObjectFeatures& current) const {
  if (ring_.empty()) return nullptr;
  if (config_.classifier == config::ClassifierMode::kPaper) {
    if (ring_.size() < static_cast<std::size_t>(reference_offset_)) return nullptr;
    return &ring_[ring_.size() - reference_offset_];
  }
  // Newest frame with enough baseline to CF (and time for static evidence).
  const Eigen::Vector3d c = current.T_world_cam.translation();
  const auto age_s = [&](const ObjectFeatures& f) {
    return static_cast<double>(current.t_ns - f.t_ns) * 1e-9;
  };
  for (auto it = ring_.rbegin(); it != ring_.rend(); ++it) {
    if ((it->T_world_cam.translation() - c).norm() >= config_.min_reference_parallax_m &&
        age_s(*it) >= kMinStaticEvidenceS) {
      return &*it;
    }
  }
  // Camera standing still: a frame chosen by time. Stereo triangulates
  // without parallax and any displacement is the object's own, so the
  // newest frame kStandingReferenceS back suffices; else (creeping) the
  // oldest kept frame, whose longer gap shows slow motion best.
  for (auto it = ring_.rbegin(); it != ring_.rend(); ++it) {
    if (age_s(*it) >= kStandingReferenceS) {
      if ((it->T_world_cam.translation() - c).norm() < kStandingMotionM) return &*it;
      break;
    }
  }
  return &ring_.front();
}

bool MotionClassifier::is_working(std::uint16_t instance, const std::string& class_name,
                                  std::int64_t t_ns) const {
  if (!is_articulated_class(class_name)) return false;
  const auto it = tracks_.find(instance);
  return it != tracks_.end() && within_working_memory(it->second.previous_moving_t_ns, t_ns);
}

bool MotionClassifier::may_resume_work(std::uint16_t instance, const std::string& class_name,
                                       std::int64_t t_ns) const {
  if (!is_articulated_class(class_name)) return false;
  const auto it = tracks_.find(instance);
  // One moving verdict alone may be a mismatch (a machine coming out from
  // behind a passing truck); a second sign of motion confirms it.
  return it != tracks_.end() && within_working_memory(it->second.last_moving_t_ns, t_ns) &&
         within_working_memory(it->second.previous_sign_t_ns, t_ns);
}

MotionState MotionClassifier::smooth(std::uint16_t instance, const ObjectFeatures& current, MotionState raw,
                                     StaticEvidence static_evidence, bool conflicting_evidence,
                                     int hysteresis_frames) {
  Track& t = tracks_[instance];
  t.last_seq = current.seq;
  const int n = hysteresis_frames;
  switch (raw) {
    case MotionState::kMoving: t.mask_as_moving(current.t_ns); break;
    case MotionState::kStatic:
      t.unknown_streak = 0;
      if (static_evidence == StaticEvidence::kTooShort) break;
      if (static_evidence == StaticEvidence::kPaused) {
        t.static_streak = 0;
        t.state = MotionState::kUnknown;
        break;
      }
      ++t.static_streak;
      if (t.static_streak >= n) t.state = MotionState::kStatic;
      break;
    case MotionState::kUnknown:
      t.static_streak = 0;
      if (conflicting_evidence) {
        // The points disagree with "static": mask again now and count
        // static verdicts from zero (unmasking needs proof, masking only
        // doubt).
        t.unknown_streak = 0;
        t.state = MotionState::kUnknown;
        t.note_sign_of_motion(current.t_ns);
        break;
      }
      ++t.unknown_streak;
      // A static object stays static through short gaps; after that it
      // must prove itself again (masked meanwhile).
      if (t.state != MotionState::kStatic || t.unknown_streak > n) t.state = MotionState::kUnknown;
      break;
  }
  return t.state;
}

std::vector<ClassifiedObject> MotionClassifier::classify(const ObjectFeatures& current) {
  timings_ = {};
  std::vector<ClassifiedObject> out = unclassified_objects(current.boxes);
  const auto t_match = SteadyClock::now();
  const ObjectFeatures* ref = select_reference(current);
  const std::vector<int> match =
      ref != nullptr ? match_keypoints(current, *ref) : std::vector<int>(current.uv_px.size(), -1);
  const std::map<std::uint16_t, std::uint16_t> ref_of_current = associate_objects(current, ref, match);
  timings_.match_ms = ms_since(t_match);

  const auto t_test = SteadyClock::now();
  const Pairing pairing{current, ref, match, scaled_pose_covariance(current)};
  for (ClassifiedObject& object : out) judge(pairing, ref_of_current, object);
  forget_unseen_tracks(current.seq);
  timings_.test_ms = ms_since(t_test);
  return out;
}

std::vector<PointDisplacement> MotionClassifier::displacements(const Pairing& pairing, std::uint16_t instance,
                                                               std::uint16_t ref_instance) const {
  const ObjectFeatures& current = pairing.current;
  const ObjectFeatures& ref = *pairing.ref;
  const Matrix6d* cov_cf = pairing.pose_covariance ? &*pairing.pose_covariance : nullptr;
  std::vector<PointDisplacement> points;
  for (std::size_t c = 0; c < pairing.match.size(); ++c) {
    if (pairing.match[c] < 0 || current.instance[c] != instance) continue;
    const int r = pairing.match[c];
    if (ref.instance[r] != ref_instance) continue;
    const auto w_cf = to_world(current.uv_px[c], current.u_right_px[c], current.octave[c],
                               current.variance_factor, current.T_world_cam, cov_cf);
    // RF's pose error is left out: RF and CF are tracked against the same map
    // points, so their errors are strongly correlated and adding both
    // covariances overstates the relative error (a machine 8 cm from where it
    // was looked static).
    const auto w_rf = to_world(ref.uv_px[r], ref.u_right_px[r], ref.octave[r], ref.variance_factor,
                               ref.T_world_cam, nullptr);
    if (!w_cf || !w_rf) continue;
    const Eigen::Vector3d d = w_cf->p - w_rf->p;
    if (d.norm() > kMaxPointErrorM) continue;
    PointDisplacement p;
    p.d = d;
    p.uv_px = current.uv_px[c];
    const Eigen::Vector3d rf_in_cf = current.T_world_cam.inverse() * w_rf->p;
    if (rf_in_cf.z() > 0.0) {
      const double sigma_px = pixel_sigma_px(current.octave[c], current.variance_factor);
      p.image_shift2 = (camera_.project(rf_in_cf) - current.uv_px[c]).squaredNorm() / (sigma_px * sigma_px);
    }
    p.covariance = w_cf->covariance + w_rf->covariance;
    p.pixel_covariance = w_cf->pixel_covariance + w_rf->pixel_covariance;
    points.push_back(p);
  }
  return points;
}

void MotionClassifier::judge(const Pairing& pairing,
                             const std::map<std::uint16_t, std::uint16_t>& ref_of_current,
                             ClassifiedObject& object) {
  ObjectVerdict& v = object.verdict;
  const bool paper = config_.classifier == config::ClassifierMode::kPaper;
  const bool person = v.class_name == kPersonClass;
  const bool working = is_working(v.instance, v.class_name, pairing.current.t_ns);
  UnknownReason reason = pairing.ref == nullptr ? UnknownReason::kNoReference : UnknownReason::kTooFewPoints;
  if (const auto it = ref_of_current.find(v.instance); it != ref_of_current.end()) {
    v.reference_instance = it->second;
    v.reference_seq = pairing.ref->seq;
    std::vector<PointDisplacement> points = displacements(pairing, v.instance, it->second);
    if (paper) {
      object.statistics = judge_paper(errors_m_of(points), config_, v);
      v.matched_points = static_cast<int>(points.size());
    } else {
      for (PointDisplacement& p : points) p.mahalanobis2 = p.d.dot(p.covariance.ldlt().solve(p.d));
      const ObjectKind kind = detail::object_kind(v.class_name, working, pairing.current.boxes, v.instance);
      reason = judge_sitepose(points, config_, config_.min_object_points, kind, v, object.statistics);
      // A person proves motion like any object, but "static" only with
      // twice the points.
      if (person && v.raw == MotionState::kStatic &&
          v.points < kPersonPointFactor * config_.min_object_points) {
        v.raw = MotionState::kUnknown;
        reason = UnknownReason::kTooFewPoints;
      }
    }
  }
  const bool long_enough =
      pairing.ref != nullptr &&
      static_cast<double>(pairing.current.t_ns - pairing.ref->t_ns) * 1e-9 >= kMinStaticEvidenceS;
  const StaticEvidence static_evidence = !long_enough ? StaticEvidence::kTooShort
                                         : may_resume_work(v.instance, v.class_name, pairing.current.t_ns)
                                             ? StaticEvidence::kPaused
                                             : StaticEvidence::kCounts;
  const int hysteresis = config_.hysteresis_frames * (person ? kPersonHysteresisFactor : 1);
  v.state = paper ? v.raw
                  : smooth(v.instance, pairing.current, v.raw, static_evidence,
                           reason == UnknownReason::kAmbiguous, hysteresis);
  if (v.state != MotionState::kUnknown) {
    v.unknown_reason = UnknownReason::kNone;
  } else if (v.raw == MotionState::kStatic) {
    v.unknown_reason = UnknownReason::kSettling;
  } else {
    v.unknown_reason = v.raw == MotionState::kUnknown ? reason : UnknownReason::kSettling;
  }
}

void MotionClassifier::forget_unseen_tracks(std::int64_t seq) {
  for (auto it = tracks_.begin(); it != tracks_.end();) {
    it = seq - it->second.last_seq > static_cast<std::int64_t>(capacity_) ? tracks_.erase(it) : std::next(it);
  }
}

}  // namespace sitepose::dynamic
