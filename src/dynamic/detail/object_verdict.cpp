#include "object_verdict.hpp"

#include <algorithm>

#include "sitepose/dynamic/motion_classifier.hpp"

namespace sitepose::dynamic::detail {
namespace {

// Object-level test (sitepose mode): the mean displacement of the object's
// inlier points against its covariance. Pixel noise averages out over the
// points, the pose terms do not (common to all), so a machine that has just
// started moving shows long before most single points do.
constexpr double kPooledGate = kChi2ThreeDof999;
// When the point test fails as well, two independent signs of motion agree
// and a lower object-level gate (chi2 3 dof, 97.5 %) suffices: a slowly
// starting machine is caught about a frame earlier.
constexpr double kPooledGateWithPoints = 9.35;
// The object is tested only when most of its matched points agree with
// their common displacement (else unknown and masked: points that disagree
// with each other prove nothing).
constexpr double kMinConsistentFraction = 0.5;
// A part of an articulated machine moving against the rest (a slewing house
// on standing tracks, a lifting bucket): the points that leave the common
// displacement and each fail the point gate on their own (chi2 3 dof 99.9 %)
// (the common displacement alone would let the standing tracks outvote the
// turning house) ...
constexpr double kMovingPointGate = kChi2ThreeDof999;
// ... and whose shift across the image fails chi2 2 dof 99.9 % (a wrong
// stereo match moves a point in depth only, which the 3D gate alone would
// take for motion).
constexpr double kMovingImageGate = 13.82;

// Machines whose parts move on their own (slewing house, boom, arm, bucket).
// A machine with two moving verdicts within MotionClassifier's working
// memory (kWorkingMemoryS, motion_classifier.cpp) is "working":
// its points that leave the common displacement and each show motion make
// it moving once they are at least this share of the matched points and at
// least kMinArticulatedPartPoints; as many that leave it without proving
// motion make it unknown (masked).
// A machine that is not working keeps the rigid rules: a parked excavator
// passed by the ego shows such "parts" too (repeated texture, occlusion
// edges) and would stay masked (docs/dynamic/motion_states.md, "Tuning").
constexpr double kMinArticulatedPartFraction = 0.12;
constexpr int kMinArticulatedPartPoints = 2;
// An excavator's upper structure (house, boom, arm) turns on its standing
// undercarriage, whose tracks fill about the lowest quarter of its box from
// the side. At the start of a slew the house loses its matches while the
// tracks keep theirs and agree with "static" (docs/dynamic/motion_states.md,
// "Static evidence from the upper structure"). So a static verdict needs
// points of the upper structure among those that agree: at least
// kMinUpperStructurePoints and kMinUpperStructureShare of them above the
// lowest kUndercarriageBoxShare of the box.
constexpr double kUndercarriageBoxShare = 0.3;
constexpr int kMinUpperStructurePoints = 2;
constexpr double kMinUpperStructureShare = 0.2;
bool turns_on_undercarriage(const std::string& class_name) { return class_name == "excavator"; }
// The image row from which the object's box shows its undercarriage;
// nullopt when there is no box of that instance.
std::optional<double> undercarriage_row_px(const std::vector<ObjectBox>& boxes, std::uint16_t instance) {
  for (const ObjectBox& b : boxes) {
    if (b.instance == instance) return b.box.y + (1.0 - kUndercarriageBoxShare) * b.box.height;
  }
  return std::nullopt;
}

std::vector<double> mahalanobis2_of(const std::vector<PointDisplacement>& points) {
  std::vector<double> out;
  out.reserve(points.size());
  for (const PointDisplacement& p : points) out.push_back(p.mahalanobis2);
  return out;
}

// How many points a separately moving part needs (kMinArticulatedPartFraction).
double part_points_needed(std::size_t points) {
  return std::max(static_cast<double>(kMinArticulatedPartPoints),
                  kMinArticulatedPartFraction * static_cast<double>(points));
}

// The points that leave the common displacement and show motion on their
// own and across the image; empty when they are too few to be a part.
std::vector<PointDisplacement> moving_part(const std::vector<PointDisplacement>& points,
                                           const std::vector<bool>& agrees) {
  std::vector<PointDisplacement> part;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!agrees[i] && points[i].mahalanobis2 > kMovingPointGate &&
        points[i].image_shift2 > kMovingImageGate) {
      part.push_back(points[i]);
    }
  }
  if (static_cast<double>(part.size()) < part_points_needed(points.size())) part.clear();
  return part;
}

// How many of the points lie above the image row `from_v_px` (on the upper
// structure).
int points_above(const std::vector<PointDisplacement>& points, double from_v_px) {
  return static_cast<int>(std::count_if(points.begin(), points.end(),
                                        [&](const PointDisplacement& p) { return p.uv_px.y() < from_v_px; }));
}

}  // namespace

ObjectKind object_kind(const std::string& class_name, bool working, const std::vector<ObjectBox>& boxes,
                       std::uint16_t instance) {
  ObjectKind kind{working, std::nullopt};
  if (turns_on_undercarriage(class_name))
    kind.undercarriage_from_v_px = undercarriage_row_px(boxes, instance);
  return kind;
}

// Paper mode (Algorithm 2) on one object's point errors (m): the errors
// below the median are kept (outliers); static when more than
// static_inlier_fraction of them are below 3 sigma_bkg. Fills v.points,
// v.score and v.raw (with enough points); returns the kept errors.
std::vector<double> judge_paper(std::vector<double> errors_m, const config::DynamicConfig& config,
                                ObjectVerdict& v) {
  if (!errors_m.empty()) {
    const double median = quantile(errors_m, 0.5);
    std::vector<double> kept;
    for (double e : errors_m) {
      if (e < median) kept.push_back(e);
    }
    if (kept.empty()) kept.push_back(median);
    errors_m = std::move(kept);
  }
  v.points = static_cast<int>(errors_m.size());
  if (v.points >= config.min_object_points) {
    const double gate = 3.0 * config.sigma_bkg_m;
    const auto below = std::count_if(errors_m.begin(), errors_m.end(), [&](double e) { return e < gate; });
    v.score = static_cast<double>(below) / errors_m.size();
    v.raw = is_static_at(errors_m, gate, config.static_inlier_fraction) ? MotionState::kStatic
                                                                        : MotionState::kMoving;
  }
  return errors_m;
}

// Sitepose mode on one object's matched points (see the header). Fills
// v.points, v.matched_points, v.score, v.pooled_statistic,
// v.part_statistic and v.raw, and `statistics` with the tested points'
// squared Mahalanobis distances. Returns the reason of an unknown raw
// verdict; kAmbiguous is evidence against "static" without a moving verdict
// (no common displacement, or the points disagree with "static" while the
// object as a whole has not moved): masked at once.
UnknownReason judge_sitepose(const std::vector<PointDisplacement>& points,
                             const config::DynamicConfig& config, int min_points, ObjectKind kind,
                             ObjectVerdict& v, std::vector<double>& statistics) {
  v.points = static_cast<int>(points.size());
  v.matched_points = v.points;
  statistics = mahalanobis2_of(points);
  if (v.points < min_points) return UnknownReason::kTooFewPoints;
  const std::vector<bool> agrees = agrees_with_common(points);
  std::vector<PointDisplacement> kept;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (agrees[i]) kept.push_back(points[i]);
  }
  // A rigid machine has no parts: its points that leave the common
  // displacement are mismatches (repeated texture moves them across the
  // image as much as motion would).
  const std::vector<PointDisplacement> part =
      kind.working ? moving_part(points, agrees) : std::vector<PointDisplacement>{};
  if (!part.empty()) {
    v.part_statistic = pooled_statistic(part);
    v.score = quantile(statistics, config.static_inlier_fraction);
    v.pooled_statistic = pooled_statistic(kept);
    v.raw = MotionState::kMoving;
    return UnknownReason::kNone;
  }
  const bool parts_disagree =
      kind.working && static_cast<double>(points.size() - kept.size()) >= part_points_needed(points.size());
  if (parts_disagree ||
      static_cast<double>(kept.size()) <= kMinConsistentFraction * static_cast<double>(points.size())) {
    v.raw = MotionState::kUnknown;  // no common displacement: the points contradict each other
    return UnknownReason::kAmbiguous;
  }
  v.points = static_cast<int>(kept.size());
  if (v.points < min_points) return UnknownReason::kTooFewPoints;  // too few agreeing points to tell
  statistics = mahalanobis2_of(kept);
  v.score = quantile(statistics, config.static_inlier_fraction);
  v.pooled_statistic = pooled_statistic(kept);
  const bool points_agree = is_static_at(statistics, config.chi2_static_3dof, config.static_inlier_fraction);
  const bool object_still = v.pooled_statistic <= (points_agree ? kPooledGate : kPooledGateWithPoints);
  v.raw = !object_still ? MotionState::kMoving : points_agree ? MotionState::kStatic : MotionState::kUnknown;
  if (v.raw == MotionState::kStatic && kind.undercarriage_from_v_px) {
    // Static on the tracks alone says nothing about the house: too few
    // points to tell, as for an object with few points (not doubt: a parked
    // machine whose house is hidden for a frame stays unmasked through it).
    const int upper = points_above(kept, *kind.undercarriage_from_v_px);
    if (upper < std::max(static_cast<double>(kMinUpperStructurePoints),
                         kMinUpperStructureShare * static_cast<double>(kept.size()))) {
      v.points = upper;
      v.raw = MotionState::kUnknown;
      return UnknownReason::kTooFewPoints;
    }
  }
  return v.raw == MotionState::kUnknown ? UnknownReason::kAmbiguous : UnknownReason::kNone;
}

std::vector<double> errors_m_of(const std::vector<PointDisplacement>& points) {
  std::vector<double> out;
  out.reserve(points.size());
  for (const PointDisplacement& p : points) out.push_back(p.d.norm());
  return out;
}

}  // namespace sitepose::dynamic::detail
