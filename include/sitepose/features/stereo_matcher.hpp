#pragma once
// Stereo matching of ORB keypoints on a rectified pair (left = reference).
//
// For each left keypoint: right keypoints on rows within +-row_band_px *
// scale(level) of its row, on neighbouring pyramid levels, with disparity
// u_l - u_r in [min_disparity_px, max_disparity_px], best by Hamming
// distance (<= max_descriptor_distance); then sub-pixel refinement on the
// left keypoint's level: zero-mean SAD of a (2w+1)^2 window over
// +-kSadSearchRadiusPx shifts and a parabola through the three costs around
// the minimum (rejected when the minimum is at the search border or the
// parabola is degenerate); finally matches whose SAD exceeds 1.5 * 1.4 *
// median SAD (a robust sigma times 1.5, as ORB-SLAM2) are rejected.
//
// Units: u_right in level-0 right-image pixels, depth_m = bf / disparity.
// Thread-safe: match() is const and keeps no state.

#include <cstdint>
#include <vector>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/core/expected.hpp"
#include "sitepose/features/orb_extractor.hpp"
#include "sitepose/features/task_pool.hpp"

namespace sitepose::features {

// Shifts tried on each side of the descriptor match during refinement (px at
// the keypoint's level); ORB-SLAM2 uses 5.
inline constexpr int kSadSearchRadiusPx = 5;
// Outlier rule: reject SAD > kSadOutlierFactor * median (1.4826 ~ 1.4 turns
// a median into a sigma; 1.5 sigma as in ORB-SLAM2's stereo matcher).
inline constexpr double kSadOutlierFactor = 1.5 * 1.4;
// A match is ambiguous when another right keypoint at least
// kAmbiguityMinSeparationPx away along the row matched almost as well
// (best >= kAmbiguityRatio * second best Hamming distance): repeated texture
// such as a facade of equal windows. Ambiguous matches are kept (motion-only
// BA rejects wrong ones by their residual) and flagged for callers that
// cannot, e.g. the motion-state test of one object's few points.
inline constexpr double kAmbiguityRatio = 0.8;
inline constexpr double kAmbiguityMinSeparationPx = 3.0;
// Value of u_right / depth_m for left keypoints without a stereo match.
inline constexpr double kNoMatch = -1.0;

// Why left keypoints did or did not get a match (counts add up to n_left).
struct StereoMatchStats {
  int n_left = 0;
  int n_matched = 0;
  int n_no_candidate = 0;        // nothing within band, level and disparity range
  int n_descriptor_too_far = 0;  // best Hamming distance > max_descriptor_distance
  int n_window_outside = 0;      // SAD window or search left the image
  int n_refinement_failed = 0;   // minimum at the search border / degenerate parabola
  int n_out_of_range = 0;        // refined disparity outside [min, max]
  int n_sad_outlier = 0;         // rejected by the median SAD rule
};

struct StereoMatches {
  std::vector<double> u_right;          // per left keypoint; kNoMatch (< 0) if none
  std::vector<double> depth_m;          // per left keypoint; kNoMatch (< 0) if none
  std::vector<std::uint8_t> ambiguous;  // per left keypoint; 1 = see kAmbiguityRatio
  StereoMatchStats stats;
};

// Checks every StereoMatchConfig field; the message names key, value, rule.
Status validate(const config::StereoMatchConfig& config);

class StereoMatcher {
 public:
  // Preconditions: validate(config) passed and bf_px_m = fx * baseline > 0
  // (aborts otherwise); create() checks both and returns the error instead.
  StereoMatcher(const config::StereoMatchConfig& config, double bf_px_m);
  static Expected<StereoMatcher> create(const config::StereoMatchConfig& config, double bf_px_m);

  // left/right: extractions of the two rectified images with the same
  // pyramid geometry (same image size and level count), else an error.
  // pool: lent threads for runs of the left keypoints (nullptr = all on the
  // caller's thread); the matches are the same either way.
  Expected<StereoMatches> match(const OrbFeatures& left, const OrbFeatures& right,
                                TaskPool* pool = nullptr) const;

  const config::StereoMatchConfig& config() const { return config_; }
  double bf_px_m() const { return bf_px_m_; }

 private:
  config::StereoMatchConfig config_;
  double bf_px_m_;
};

// SAD rejection threshold of a set of per-match SAD costs:
// kSadOutlierFactor * median (upper median for even counts); 0 when empty.
double sad_outlier_threshold(std::vector<double> sad_costs);

}  // namespace sitepose::features
