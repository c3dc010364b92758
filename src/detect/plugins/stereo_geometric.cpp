#include "stereo_geometric.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <tuple>

#include <Eigen/Dense>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace sitepose::detect::plugin {
namespace {

double iou(const cv::Rect& a, const cv::Rect& b) {
  const double inter = (a & b).area();
  const double uni = a.area() + b.area() - inter;
  return uni > 0.0 ? inter / uni : 0.0;
}

// The detector's pinhole at its working scale (`scale` of the input).
struct ScaledCamera {
  double scale, fx, fy, cx, cy, bf;
};

ScaledCamera scaled_camera(const StereoGeometricOptions& o) {
  const double s = o.scale;
  const double fx = o.fx * s;
  return {s, fx, o.fy * s, (o.cx + 0.5) * s - 0.5, (o.cy + 0.5) * s - 0.5, fx * o.baseline_m};
}

// 3D points (camera frame, m) of the pixels with a disparity; `valid` marks them.
cv::Mat points_from_disparity(const cv::Mat& disp, const ScaledCamera& cam, cv::Mat& valid) {
  cv::Mat points(disp.size(), CV_32FC3, cv::Scalar::all(0));
  valid = cv::Mat(disp.size(), CV_8U, cv::Scalar(0));
  for (int v = 0; v < disp.rows; ++v) {
    const float* d = disp.ptr<float>(v);
    auto* p = points.ptr<cv::Vec3f>(v);
    auto* ok = valid.ptr<std::uint8_t>(v);
    for (int u = 0; u < disp.cols; ++u) {
      if (!(d[u] > 0.5f)) continue;
      const double z = cam.bf / d[u];
      p[u] = cv::Vec3f(static_cast<float>((u - cam.cx) * z / cam.fx),
                       static_cast<float>((v - cam.cy) * z / cam.fy), static_cast<float>(z));
      ok[u] = 1;
    }
  }
  return points;
}

// Pixels by their height above the ground plane: `grow` between
// grow_height_m and max_height_m (opened and closed), `high` above
// min_height_m (the seeds), `heights` in m (-1 where no object pixel).
struct HeightMasks {
  cv::Mat grow, high, heights;
};

HeightMasks height_masks(const cv::Mat& points, const cv::Mat& valid, const Eigen::Vector4d& plane,
                         const StereoGeometricOptions& o) {
  const Eigen::Vector3d n = plane.head<3>();
  const double d0 = plane[3];
  HeightMasks m{cv::Mat(points.size(), CV_8U, cv::Scalar(0)), cv::Mat(points.size(), CV_8U, cv::Scalar(0)),
                cv::Mat(points.size(), CV_32F, cv::Scalar(-1.0f))};
  for (int v = 0; v < points.rows; ++v) {
    const auto* p = points.ptr<cv::Vec3f>(v);
    const auto* ok = valid.ptr<std::uint8_t>(v);
    auto* g = m.grow.ptr<std::uint8_t>(v);
    auto* h = m.high.ptr<std::uint8_t>(v);
    auto* hm = m.heights.ptr<float>(v);
    for (int u = 0; u < points.cols; ++u) {
      if (ok[u] == 0 || p[u][2] > o.max_range_m) continue;
      const double height = n.x() * p[u][0] + n.y() * p[u][1] + n.z() * p[u][2] + d0;
      if (height > o.grow_height_m && height < o.max_height_m) {
        g[u] = 255;
        hm[u] = static_cast<float>(height);
        if (height > o.min_height_m) h[u] = 255;
      }
    }
  }
  const cv::Mat kernel3 = cv::getStructuringElement(cv::MORPH_RECT, {3, 3});
  const cv::Mat kernel5 = cv::getStructuringElement(cv::MORPH_ELLIPSE, {5, 5});
  cv::morphologyEx(m.grow, m.grow, cv::MORPH_OPEN, kernel3);
  cv::morphologyEx(m.grow, m.grow, cv::MORPH_CLOSE, kernel5);
  return m;
}

// Per connected component: seed pixels, and count, depth sum and lowest
// height of its 3D points.
struct ComponentPoints {
  std::vector<int> seeds, n_points;
  std::vector<double> depth_sum, lowest;
};

ComponentPoints component_points(const cv::Mat& labels, int n_labels, const HeightMasks& m,
                                 const cv::Mat& points) {
  const auto n_comp = static_cast<std::size_t>(n_labels);
  ComponentPoints c{std::vector<int>(n_comp, 0), std::vector<int>(n_comp, 0),
                    std::vector<double>(n_comp, 0.0),
                    std::vector<double>(n_comp, std::numeric_limits<double>::infinity())};
  for (int v = 0; v < labels.rows; ++v) {
    const int* l = labels.ptr<int>(v);
    const auto* h = m.high.ptr<std::uint8_t>(v);
    const auto* hm = m.heights.ptr<float>(v);
    const auto* p = points.ptr<cv::Vec3f>(v);
    for (int u = 0; u < labels.cols; ++u) {
      const auto k = static_cast<std::size_t>(l[u]);
      if (k == 0) continue;
      c.seeds[k] += h[u] != 0;
      if (hm[u] < 0.0f) continue;  // filled in by the morphology: no 3D point
      ++c.n_points[k];
      c.depth_sum[k] += p[u][2];
      c.lowest[k] = std::min(c.lowest[k], static_cast<double>(hm[u]));
    }
  }
  return c;
}

struct Candidate {
  int label;
  cv::Rect box;  // in input pixels
  double score;
};

// The components that are large, seeded, tall enough and standing on the
// ground, with their boxes in input pixels.
std::vector<Candidate> select_candidates(const cv::Mat& stats, int n_labels, const ComponentPoints& c,
                                         const ScaledCamera& cam, cv::Size working_size, cv::Size input_size,
                                         const StereoGeometricOptions& o) {
  const double min_area = o.min_area_fraction * working_size.height * working_size.width;
  const double s = cam.scale;
  std::vector<Candidate> candidates;
  for (int i = 1; i < n_labels; ++i) {
    const int area = stats.at<int>(i, cv::CC_STAT_AREA);
    if (area < min_area || c.seeds[static_cast<std::size_t>(i)] < o.min_seed_fraction * area) {
      continue;
    }
    const cv::Rect small(stats.at<int>(i, cv::CC_STAT_LEFT), stats.at<int>(i, cv::CC_STAT_TOP),
                         stats.at<int>(i, cv::CC_STAT_WIDTH), stats.at<int>(i, cv::CC_STAT_HEIGHT));
    const auto k = static_cast<std::size_t>(i);
    if (c.n_points[k] == 0) continue;
    // An object is as tall as "clearly above the ground" (thin stripes of
    // disparity noise along far walls are not) ...
    const double depth_m = c.depth_sum[k] / c.n_points[k];
    if (small.height * depth_m / cam.fy < o.min_height_m) continue;
    // ... and stands on the ground: its lowest points are near the plane
    // unless it is cut by the bottom image border. Mismatched repetitive
    // texture (windows of far facades) floats above the ground.
    const bool at_bottom = small.br().y >= working_size.height - 1;
    if (!at_bottom && c.lowest[k] > o.max_foot_height_m) continue;
    const cv::Point tl(static_cast<int>(std::floor(small.x / s)), static_cast<int>(std::floor(small.y / s)));
    const cv::Point br(static_cast<int>(std::ceil(small.br().x / s)),
                       static_cast<int>(std::ceil(small.br().y / s)));
    const cv::Rect box = cv::Rect(tl, br) & cv::Rect(0, 0, input_size.width, input_size.height);
    if (box.empty()) continue;
    candidates.push_back({i, box, static_cast<double>(area) / small.area()});
  }
  return candidates;
}

// Greedy IoU association with the previous frame, best pairs first: the
// previous object's id per candidate, 0 where none matches.
std::vector<std::uint16_t> ids_from_previous(const std::vector<Candidate>& candidates,
                                             const std::vector<GeometricObject>& previous, double min_iou) {
  std::vector<std::tuple<double, std::size_t, std::size_t>> pairs;
  for (std::size_t c = 0; c < candidates.size(); ++c) {
    for (std::size_t p = 0; p < previous.size(); ++p) {
      const double o = iou(candidates[c].box, previous[p].box);
      if (o >= min_iou) pairs.emplace_back(o, c, p);
    }
  }
  std::sort(pairs.begin(), pairs.end(),
            [](const auto& a, const auto& b) { return std::get<0>(a) > std::get<0>(b); });
  std::vector<std::uint16_t> ids(candidates.size(), 0);
  std::vector<bool> prev_used(previous.size(), false);
  for (const auto& [o, c, p] : pairs) {
    if (ids[c] != 0 || prev_used[p]) continue;
    ids[c] = previous[p].instance;
    prev_used[p] = true;
  }
  return ids;
}

}  // namespace

StereoGeometric::StereoGeometric(const StereoGeometricOptions& options) : options_(options) {}

Status StereoGeometric::validate(const StereoGeometricOptions& o) {
  const auto bad = [](const std::string& what) {
    return make_error(ErrorCode::kInvalidArgument, "stereo-geometric config: " + what);
  };
  if (!(o.fx > 0 && o.fy > 0 && o.baseline_m > 0)) return bad("fx, fy, baseline_m must be > 0");
  if (!(o.scale > 0.05 && o.scale <= 1.0)) return bad("scale must be in (0.05, 1]");
  if (!(o.min_depth_m > 0)) return bad("min_depth_m must be > 0");
  if (!(o.max_range_m > o.min_depth_m)) return bad("max_range_m must be > min_depth_m");
  if (!(o.grow_height_m > 0 && o.min_height_m >= o.grow_height_m && o.max_height_m > o.min_height_m)) {
    return bad("need 0 < grow_height_m <= min_height_m < max_height_m");
  }
  if (!(o.max_foot_height_m >= o.grow_height_m)) {
    return bad("max_foot_height_m must be >= grow_height_m");
  }
  if (!(o.min_area_fraction >= 0 && o.min_area_fraction < 1)) {
    return bad("min_area_fraction must be in [0, 1)");
  }
  if (!(o.min_seed_fraction >= 0 && o.min_seed_fraction <= 1)) {
    return bad("min_seed_fraction must be in [0, 1]");
  }
  if (!(o.plane_inlier_m > 0)) return bad("plane_inlier_m must be > 0");
  if (!(o.max_plane_tilt_deg > 0 && o.max_plane_tilt_deg < 90)) {
    return bad("max_plane_tilt_deg must be in (0, 90)");
  }
  if (!(o.track_iou > 0 && o.track_iou <= 1)) return bad("track_iou must be in (0, 1]");
  return ok_status();
}

cv::Mat StereoGeometric::disparity(const cv::Mat& left, const cv::Mat& right) const {
  cv::Mat l, r;
  cv::resize(left, l, cv::Size(), options_.scale, options_.scale, cv::INTER_AREA);
  cv::resize(right, r, cv::Size(), options_.scale, options_.scale, cv::INTER_AREA);
  const double bf = options_.fx * options_.scale * options_.baseline_m;
  const int max_disp =
      std::clamp(static_cast<int>(std::ceil(bf / options_.min_depth_m / 16.0)) * 16, 16, 512);
  constexpr int kBlock = 5;
  auto sgbm = cv::StereoSGBM::create(0, max_disp, kBlock, 8 * kBlock * kBlock, 32 * kBlock * kBlock, 1, 0, 10,
                                     100, 2, cv::StereoSGBM::MODE_SGBM_3WAY);
  // SGBM leaves the first max_disp columns without disparity; a left margin
  // gives them a partial search range instead (near objects at the left
  // border are the ones that matter).
  cv::Mat lp, rp;
  cv::copyMakeBorder(l, lp, 0, 0, max_disp, 0, cv::BORDER_REPLICATE);
  cv::copyMakeBorder(r, rp, 0, 0, max_disp, 0, cv::BORDER_REPLICATE);
  cv::Mat disp16;
  sgbm->compute(lp, rp, disp16);
  cv::Mat out;
  disp16(cv::Rect(max_disp, 0, l.cols, l.rows)).convertTo(out, CV_32F, 1.0 / 16.0);
  return out;
}

std::optional<Eigen::Vector4d> StereoGeometric::fit_ground(const cv::Mat& points, const cv::Mat& valid) {
  // Candidate ground points: lower half of the image, within range.
  std::vector<Eigen::Vector3d> pts;
  const int step = 2;
  for (int v = points.rows / 2; v < points.rows; v += step) {
    const auto* p = points.ptr<cv::Vec3f>(v);
    const auto* ok = valid.ptr<std::uint8_t>(v);
    for (int u = 0; u < points.cols; u += step) {
      if (ok[u] != 0 && p[u][2] < options_.max_range_m) pts.emplace_back(p[u][0], p[u][1], p[u][2]);
    }
  }
  if (pts.size() < 50) return std::nullopt;
  std::mt19937 rng(static_cast<unsigned>(options_.seed));
  std::uniform_int_distribution<std::size_t> pick(0, pts.size() - 1);
  const double cos_tilt = std::cos(options_.max_plane_tilt_deg * std::numbers::pi / 180.0);
  const Eigen::Vector3d up(0.0, -1.0, 0.0);  // camera y points down
  Eigen::Vector4d best(0, 0, 0, 0);
  std::size_t best_inliers = 0;
  constexpr int kIterations = 150;
  for (int it = 0; it < kIterations; ++it) {
    const Eigen::Vector3d& a = pts[pick(rng)];
    const Eigen::Vector3d& b = pts[pick(rng)];
    const Eigen::Vector3d& c = pts[pick(rng)];
    Eigen::Vector3d n = (b - a).cross(c - a);
    if (n.norm() < 1e-9) continue;
    n.normalize();
    if (n.dot(up) < 0) n = -n;
    if (n.dot(up) < cos_tilt) continue;
    const double d = -n.dot(a);  // height of the camera origin above the plane
    if (d < 0.3) continue;       // the camera stands above the ground
    std::size_t inliers = 0;
    for (const auto& p : pts) inliers += std::abs(n.dot(p) + d) < options_.plane_inlier_m;
    if (inliers > best_inliers) {
      best_inliers = inliers;
      best << n, d;
    }
  }
  if (best_inliers < std::max<std::size_t>(30, pts.size() / 10)) return std::nullopt;
  // Least-squares refinement on the inliers (smallest-eigenvalue normal).
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> in;
  for (const auto& p : pts) {
    if (std::abs(best.head<3>().dot(p) + best[3]) < options_.plane_inlier_m) in.push_back(p);
  }
  for (const auto& p : in) mean += p;
  mean /= static_cast<double>(in.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : in) cov += (p - mean) * (p - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  Eigen::Vector3d n = eig.eigenvectors().col(0);
  if (n.dot(up) < 0) n = -n;
  Eigen::Vector4d plane;
  plane << n, -n.dot(mean);
  return plane;
}

std::uint16_t StereoGeometric::next_id() {
  for (;;) {
    last_id_ = static_cast<std::uint16_t>(last_id_ + 1);
    if (last_id_ == 0) continue;
    const bool used = std::any_of(previous_.begin(), previous_.end(),
                                  [&](const GeometricObject& o) { return o.instance == last_id_; });
    if (!used) return last_id_;
  }
}

Expected<std::vector<GeometricObject>> StereoGeometric::detect(const cv::Mat& left, const cv::Mat& right,
                                                               std::int64_t seq) {
  const cv::Mat disp = disparity(left, right);
  const ScaledCamera cam = scaled_camera(options_);
  cv::Mat valid;
  const cv::Mat points = points_from_disparity(disp, cam, valid);
  if (auto plane = fit_ground(points, valid)) plane_ = plane;

  std::vector<GeometricObject> objects;
  last_seq_ = seq;
  last_input_size_ = left.size();
  last_instance_label_.clear();
  last_labels_ = cv::Mat();
  if (!plane_) {  // no ground seen yet: nothing can stand on it
    previous_.clear();
    return objects;
  }
  const HeightMasks masks = height_masks(points, valid, *plane_, options_);
  cv::Mat labels, stats, centroids;
  const int n_labels = cv::connectedComponentsWithStats(masks.grow, labels, stats, centroids, 8, CV_32S);
  const ComponentPoints components = component_points(labels, n_labels, masks, points);
  const std::vector<Candidate> candidates =
      select_candidates(stats, n_labels, components, cam, disp.size(), left.size(), options_);

  std::vector<std::uint16_t> ids = ids_from_previous(candidates, previous_, options_.track_iou);
  for (std::size_t c = 0; c < candidates.size(); ++c) {
    if (ids[c] == 0) ids[c] = next_id();
    objects.push_back({candidates[c].box, ids[c], candidates[c].score});
    last_instance_label_.emplace_back(ids[c], candidates[c].label);
  }
  previous_ = objects;
  last_labels_ = labels;
  return objects;
}

Status StereoGeometric::paint(std::int64_t seq, std::uint16_t instance, cv::Mat& mask) const {
  if (seq != last_seq_ || mask.size() != last_input_size_) {
    return make_error(ErrorCode::kInvalidArgument,
                      "stereo-geometric: segment for frame " + std::to_string(seq) +
                          " must follow detect of the same frame (last detect: frame " +
                          std::to_string(last_seq_) + ")");
  }
  int label = -1;
  for (const auto& [id, l] : last_instance_label_) {
    if (id == instance) label = l;
  }
  if (label < 0) return ok_status();  // not an object of this frame: nothing to paint
  cv::Mat object_small = last_labels_ == label;
  cv::Mat object;
  cv::resize(object_small, object, mask.size(), 0, 0, cv::INTER_NEAREST);
  mask.setTo(instance, object);
  return ok_status();
}

}  // namespace sitepose::detect::plugin
