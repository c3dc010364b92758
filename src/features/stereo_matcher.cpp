#include "sitepose/features/stereo_matcher.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>

#include <fmt/format.h>
#include <utility>

#include "detail/subpixel.hpp"
#include "sitepose/features/hamming.hpp"

namespace sitepose::features {
namespace {

template <typename T>
Status invalid(const char* key, T value, const std::string& rule) {
  return make_error(ErrorCode::kInvalidArgument, fmt::format("stereo.{} = {}: {}", key, value, rule));
}

constexpr int kMaxSadHalfWindowPx = 15;
// Jobs one match() splits its keypoints into when it has a pool: a few per
// thread, so a slow run does not leave the other thread idle.
constexpr int kMatchRunsOnPool = 8;

// Right keypoint indices by level-0 row: a keypoint of level l is listed on
// every row within +-row_band_px * scale(l) of its own (ORB-SLAM2's
// per-level search band), stored as one flat array with row offsets.
struct RowIndex {
  std::vector<int> begin;  // rows + 1 offsets into `ids`
  std::vector<int> ids;

  RowIndex(const std::vector<cv::KeyPoint>& keypoints, int rows, double row_band_px, double scale_factor) {
    std::vector<std::pair<int, int>> spans(keypoints.size());
    begin.assign(rows + 1, 0);
    for (size_t i = 0; i < keypoints.size(); ++i) {
      const double band = row_band_px * std::pow(scale_factor, keypoints[i].octave);
      const double v = keypoints[i].pt.y;
      const int lo = std::max(0, static_cast<int>(std::floor(v - band)));
      const int hi = std::min(rows - 1, static_cast<int>(std::ceil(v + band)));
      spans[i] = {lo, hi};
      for (int r = lo; r <= hi; ++r) ++begin[r + 1];
    }
    for (int r = 0; r < rows; ++r) begin[r + 1] += begin[r];
    ids.resize(begin[rows]);
    std::vector<int> fill(begin.begin(), begin.end() - 1);
    for (size_t i = 0; i < keypoints.size(); ++i) {
      for (int r = spans[i].first; r <= spans[i].second; ++r) ids[fill[r]++] = static_cast<int>(i);
    }
  }
};

// The left window of one refinement, as int16 (rows of `side` pixels), so
// the cost of each shift is one pass of SIMD-friendly loops.
struct LeftWindow {
  int side = 0;
  std::array<std::int16_t, (2 * kMaxSadHalfWindowPx + 1) * (2 * kMaxSadHalfWindowPx + 1)> pixels{};

  LeftWindow(const cv::Mat& left, int xl, int y, int w) : side(2 * w + 1) {
    int k = 0;
    for (int dy = -w; dy <= w; ++dy) {
      const std::uint8_t* row = left.ptr<std::uint8_t>(y + dy) + xl - w;
      for (int dx = 0; dx < side; ++dx) pixels[k++] = row[dx];
    }
  }
};

// Zero-mean SAD per pixel between the left window and the right window
// centred at (xr, y) of one level: removing each window's mean makes the
// cost insensitive to a gain offset between the two cameras.
double zero_mean_sad(const LeftWindow& left, const cv::Mat& right, int xr, int y) {
  const int side = left.side;
  const int w = side / 2;
  const int n = side * side;
  std::array<std::int16_t, (2 * kMaxSadHalfWindowPx + 1) * (2 * kMaxSadHalfWindowPx + 1)> diff;  // n used
  int k = 0;
  for (int dy = -w; dy <= w; ++dy) {
    const std::uint8_t* rrow = right.ptr<std::uint8_t>(y + dy) + xr - w;
    for (int dx = 0; dx < side; ++dx, ++k) diff[k] = static_cast<std::int16_t>(left.pixels[k] - rrow[dx]);
  }
  int sum = 0;
  for (k = 0; k < n; ++k) sum += diff[k];
  // sum |n * d_k - sum| / n^2 = mean |d_k - mean(d)|, kept in integers
  // (|n * d_k - sum| <= 2 * 961 * 255 fits an int).
  int total = 0;
  for (k = 0; k < n; ++k) total += std::abs(n * diff[k] - sum);
  return double(total) / (double(n) * n);
}

Status check_inputs(const OrbFeatures& left, const OrbFeatures& right) {
  const ImagePyramid& lp = left.pyramid;
  const ImagePyramid& rp = right.pyramid;
  if (lp.n_levels() == 0 || lp.n_levels() != rp.n_levels() || lp.levels[0].size() != rp.levels[0].size()) {
    return make_error(ErrorCode::kInvalidArgument,
                      "stereo matching: left and right pyramids differ (levels " +
                          std::to_string(lp.n_levels()) + " vs " + std::to_string(rp.n_levels()) +
                          ", level-0 size " + std::to_string(lp.n_levels() ? lp.levels[0].cols : 0) + "x" +
                          std::to_string(lp.n_levels() ? lp.levels[0].rows : 0) + " vs " +
                          std::to_string(rp.n_levels() ? rp.levels[0].cols : 0) + "x" +
                          std::to_string(rp.n_levels() ? rp.levels[0].rows : 0) + ")");
  }
  const int n_left = static_cast<int>(left.keypoints.size());
  if (left.descriptors.rows != n_left || static_cast<int>(right.keypoints.size()) != right.descriptors.rows) {
    return make_error(ErrorCode::kInvalidArgument,
                      "stereo matching: descriptor rows do not match keypoint counts (left " +
                          std::to_string(left.descriptors.rows) + "/" + std::to_string(n_left) + ", right " +
                          std::to_string(right.descriptors.rows) + "/" +
                          std::to_string(right.keypoints.size()) + ")");
  }
  return ok_status();
}

constexpr int kL = kSadSearchRadiusPx;

// What the search of one left keypoint found before its refinement: the
// descriptor match and the SAD cost of every shift around it.
struct SadScan {
  enum class Outcome : std::uint8_t { kNoCandidate, kDescriptorTooFar, kWindowOutside, kScanned };
  Outcome outcome = Outcome::kNoCandidate;
  int xr0 = 0;                             // the descriptor match's column at the keypoint's level
  double y_level = 0.0;                    // the keypoint's row at its level
  std::array<double, 2 * kL + 1> costs{};  // costs[s + kL]: shift s
};

// The matching of one pair in two steps: scan() each left keypoint on its
// own (any keypoints, any thread), then refine() every scanned keypoint in
// keypoint order, which carries one cost from keypoint to keypoint (see
// Refinement).
class PairMatcher {
 public:
  PairMatcher(const config::StereoMatchConfig& config, const OrbFeatures& left, const OrbFeatures& right,
              const RowIndex& index)
      : config_(config), left_(left), right_(right), rows_(left.pyramid.levels[0].rows), index_(index) {}

  // Left keypoint i: its descriptor match (`ambiguous` as kAmbiguityRatio
  // says) and the SAD costs around it.
  SadScan scan(int i, std::uint8_t& ambiguous) {
    SadScan out;
    int best_distance = kDescriptorBits + 1;
    const int best_j = nearest_right(i, best_distance, ambiguous);
    if (best_j < 0) return out;
    if (best_distance > config_.max_descriptor_distance) {
      out.outcome = SadScan::Outcome::kDescriptorTooFar;
      return out;
    }
    const cv::KeyPoint& kl = left_.keypoints[i];
    const int level = kl.octave;
    const cv::Mat& limg = left_.pyramid.levels[level];
    const cv::Mat& rimg = right_.pyramid.levels[level];
    const int w = config_.sad_half_window_px;
    const cv::Point2d pl = left_.pyramid.from_level0(level, cv::Point2d(kl.pt.x, kl.pt.y));
    const int xl = static_cast<int>(std::lround(pl.x));
    const int yl = static_cast<int>(std::lround(pl.y));
    const cv::Point2d pr =
        right_.pyramid.from_level0(level, cv::Point2d(right_.keypoints[best_j].pt.x, kl.pt.y));
    out.xr0 = static_cast<int>(std::lround(pr.x));
    out.y_level = pl.y;
    if (yl - w < 0 || yl + w >= limg.rows || xl - w < 0 || xl + w >= limg.cols || out.xr0 - kL - w < 0 ||
        out.xr0 + kL + w >= rimg.cols) {
      out.outcome = SadScan::Outcome::kWindowOutside;
      return out;
    }
    const LeftWindow window(limg, xl, yl, w);
    for (int s = -kL; s <= kL; ++s) out.costs[s + kL] = zero_mean_sad(window, rimg, out.xr0 + s, yl);
    out.outcome = SadScan::Outcome::kScanned;
    return out;
  }

 private:
  // The right keypoint nearest by descriptor to left keypoint i among those
  // in its row band, on levels +-1 and in the disparity range (-1 if none);
  // `ambiguous` as kAmbiguityRatio says.
  int nearest_right(int i, int& best_distance, std::uint8_t& ambiguous) {
    const cv::KeyPoint& kl = left_.keypoints[i];
    const int level = kl.octave;
    const int row = std::clamp(static_cast<int>(std::lround(kl.pt.y)), 0, rows_ - 1);
    const double min_u = kl.pt.x - config_.max_disparity_px;
    const double max_u = kl.pt.x - config_.min_disparity_px;
    int best_j = -1;
    const std::uint8_t* dl = left_.descriptors.ptr<std::uint8_t>(i);
    candidates_.clear();
    for (int k = index_.begin[row]; k < index_.begin[row + 1]; ++k) {
      const int j = index_.ids[k];
      const cv::KeyPoint& kr = right_.keypoints[j];
      if (kr.octave < level - 1 || kr.octave > level + 1) continue;
      if (kr.pt.x < min_u || kr.pt.x > max_u) continue;
      const int distance = hamming_distance(dl, right_.descriptors.ptr<std::uint8_t>(j));
      candidates_.push_back({kr.pt.x, distance});
      if (distance < best_distance) {
        best_distance = distance;
        best_j = j;
      }
    }
    if (best_j >= 0) {
      // Second best among candidates away from the best one (the same
      // corner is often detected twice, a pixel apart).
      const double best_u = right_.keypoints[best_j].pt.x;
      int second_distance = kDescriptorBits + 1;
      for (const auto& [u, distance] : candidates_) {
        if (std::abs(u - best_u) >= kAmbiguityMinSeparationPx)
          second_distance = std::min(second_distance, distance);
      }
      ambiguous = best_distance >= kAmbiguityRatio * second_distance ? 1 : 0;
    }
    return best_j;
  }

  const config::StereoMatchConfig& config_;
  const OrbFeatures& left_;
  const OrbFeatures& right_;
  int rows_;
  const RowIndex& index_;
  // Right column and Hamming distance of each candidate of the current left
  // keypoint (reused; the ambiguity check needs them after the best is known).
  std::vector<std::pair<float, int>> candidates_;
};

// The sub-pixel step, keypoint after keypoint in keypoint order. The shift
// with the least cost wins, except that shifts -kL..-1 are compared with the
// previous scanned keypoint's cost at shift 0 while no shift of this
// keypoint has won yet: the refinement always behaved so, and measured, the
// plain minimum is worse (docs/tracking/extraction.md, "The stereo
// refinement's carried cost": ATE 0.0057 -> 0.0081 m on parallel 1-3).
class Refinement {
 public:
  Refinement(const config::StereoMatchConfig& config, double bf_px_m, const OrbFeatures& left,
             const OrbFeatures& right)
      : config_(config), bf_px_m_(bf_px_m), left_(left), right_(right) {}

  // Left keypoint i from its scan: right column and depth into `out`, or
  // the reason it has none into out.stats; a match's SAD into sad_of_match.
  void refine(int i, const SadScan& scan, StereoMatches& out,
              std::vector<std::pair<double, int>>& sad_of_match) {
    switch (scan.outcome) {
      case SadScan::Outcome::kNoCandidate: ++out.stats.n_no_candidate; return;
      case SadScan::Outcome::kDescriptorTooFar: ++out.stats.n_descriptor_too_far; return;
      case SadScan::Outcome::kWindowOutside: ++out.stats.n_window_outside; return;
      case SadScan::Outcome::kScanned: break;
    }
    const int best_shift = winning_shift(scan.costs);
    if (best_shift == -kL || best_shift == kL) {
      ++out.stats.n_refinement_failed;
      return;
    }
    const auto& costs = scan.costs;
    const auto offset = detail::parabola_vertex_offset(costs[best_shift + kL - 1], costs[best_shift + kL],
                                                       costs[best_shift + kL + 1]);
    if (!offset) {
      ++out.stats.n_refinement_failed;
      return;
    }
    const int level = left_.keypoints[i].octave;
    const double xr_level = scan.xr0 + best_shift + *offset;
    const double u_right = right_.pyramid.to_level0(level, cv::Point2d(xr_level, scan.y_level)).x;
    const double disparity = left_.keypoints[i].pt.x - u_right;
    if (disparity < config_.min_disparity_px || disparity > config_.max_disparity_px) {
      ++out.stats.n_out_of_range;
      return;
    }
    out.u_right[i] = u_right;
    out.depth_m[i] = bf_px_m_ / disparity;
    sad_of_match.emplace_back(costs[best_shift + kL], i);
  }

 private:
  int winning_shift(const std::array<double, 2 * kL + 1>& costs) {
    int best = 0;
    for (int s = -kL; s <= kL; ++s) {
      const double to_beat = (best == 0 && s < 0) ? previous_cost_at_zero_ : costs[best + kL];
      if (costs[s + kL] < to_beat) best = s;
    }
    previous_cost_at_zero_ = costs[kL];
    return best;
  }

  const config::StereoMatchConfig& config_;
  double bf_px_m_;
  const OrbFeatures& left_;
  const OrbFeatures& right_;
  double previous_cost_at_zero_ = 0.0;
};

// Rejects the matches whose SAD exceeds sad_outlier_threshold(); counts the rest as matched.
void reject_sad_outliers(const std::vector<std::pair<double, int>>& sad_of_match, StereoMatches& out) {
  std::vector<double> sads(sad_of_match.size());
  for (size_t k = 0; k < sad_of_match.size(); ++k) sads[k] = sad_of_match[k].first;
  const double threshold = sad_outlier_threshold(std::move(sads));
  for (const auto& [sad, i] : sad_of_match) {
    if (sad > threshold) {
      out.u_right[i] = kNoMatch;
      out.depth_m[i] = kNoMatch;
      ++out.stats.n_sad_outlier;
    } else {
      ++out.stats.n_matched;
    }
  }
}

}  // namespace

Status validate(const config::StereoMatchConfig& c) {
  if (!(c.min_disparity_px > 0.0)) {
    return invalid("min_disparity_px", c.min_disparity_px, "must be > 0");
  }
  if (!(c.max_disparity_px > c.min_disparity_px)) {
    return invalid("max_disparity_px", c.max_disparity_px,
                   fmt::format("must be > min_disparity_px = {}", c.min_disparity_px));
  }
  if (c.max_descriptor_distance < 0 || c.max_descriptor_distance > kDescriptorBits) {
    return invalid("max_descriptor_distance", c.max_descriptor_distance, "must be in [0, 256]");
  }
  if (c.sad_half_window_px < 1 || c.sad_half_window_px > kMaxSadHalfWindowPx) {
    return invalid("sad_half_window_px", c.sad_half_window_px,
                   "must be in [1, " + std::to_string(kMaxSadHalfWindowPx) + "]");
  }
  if (c.row_band_px < 0 || c.row_band_px > 50) {
    return invalid("row_band_px", c.row_band_px, "must be in [0, 50]");
  }
  return ok_status();
}

StereoMatcher::StereoMatcher(const config::StereoMatchConfig& config, double bf_px_m)
    : config_(config), bf_px_m_(bf_px_m) {
  SITEPOSE_CHECK(validate(config).has_value());
  SITEPOSE_CHECK(bf_px_m > 0.0);
}

Expected<StereoMatcher> StereoMatcher::create(const config::StereoMatchConfig& config, double bf_px_m) {
  SITEPOSE_TRY_STATUS(validate(config));
  if (!(bf_px_m > 0.0)) {
    return make_error(ErrorCode::kInvalidArgument,
                      fmt::format("stereo matcher: bf = fx * baseline = {}: must be > 0", bf_px_m));
  }
  return StereoMatcher(config, bf_px_m);
}

double sad_outlier_threshold(std::vector<double> sad_costs) {
  if (sad_costs.empty()) return 0.0;
  const auto mid = sad_costs.begin() + static_cast<std::ptrdiff_t>(sad_costs.size() / 2);
  std::nth_element(sad_costs.begin(), mid, sad_costs.end());
  return kSadOutlierFactor * *mid;
}

Expected<StereoMatches> StereoMatcher::match(const OrbFeatures& left, const OrbFeatures& right,
                                             TaskPool* pool) const {
  SITEPOSE_TRY_STATUS(check_inputs(left, right));
  const int n_left = static_cast<int>(left.keypoints.size());
  StereoMatches out;
  out.u_right.assign(n_left, kNoMatch);
  out.ambiguous.assign(n_left, 0);
  out.depth_m.assign(n_left, kNoMatch);
  out.stats.n_left = n_left;
  if (n_left == 0) return out;
  // Nominal level scale, recovered from the pyramid (level 1 ratio) so the
  // matcher needs no OrbConfig; exact per-level ratios are used for pixels.
  const RowIndex index(right.keypoints, left.pyramid.levels[0].rows, config_.row_band_px,
                       left.pyramid.n_levels() > 1 ? left.pyramid.ratio_x[1] : 1.0);
  // The scans, in runs of consecutive keypoints (one job each on the pool).
  std::vector<SadScan> scans(n_left);
  const int n_runs = pool != nullptr ? std::min(n_left, kMatchRunsOnPool) : 1;
  const auto scan_run = [&](int run) {
    PairMatcher pair(config_, left, right, index);
    const int first = static_cast<int>(static_cast<long>(n_left) * run / n_runs);
    const int last = static_cast<int>(static_cast<long>(n_left) * (run + 1) / n_runs);
    for (int i = first; i < last; ++i) scans[i] = pair.scan(i, out.ambiguous[i]);
  };
  if (pool != nullptr && n_runs > 1) {
    pool->run(n_runs, scan_run);
  } else {
    scan_run(0);
  }
  Refinement refinement(config_, bf_px_m_, left, right);
  std::vector<std::pair<double, int>> sad_of_match;
  sad_of_match.reserve(n_left);
  for (int i = 0; i < n_left; ++i) refinement.refine(i, scans[i], out, sad_of_match);
  reject_sad_outliers(sad_of_match, out);
  return out;
}

}  // namespace sitepose::features
