#include "sitepose/mapping/new_points.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "sitepose/optim/triangulation.hpp"

namespace sitepose::mapping {
namespace {

// ORB-SLAM2 SearchForTriangulation: a monocular pair closer to the epipole
// than 10 px (at level 0, squared distance 100 * scale) has no depth.
constexpr double kEpipoleRadius2Px2 = 100.0;
// ORB-SLAM2 CreateNewMapPoints: distance ratio vs octave ratio slack.
constexpr double kScaleRatioSlack = 1.5;

bool has_stereo(const map::KeyPointData& kp) { return kp.u_right_px >= 0.0 && kp.depth_m > 0.0; }

// A keypoint of keyframe 2 that may match along an epipolar line.
struct EpipolarCandidate {
  int index;  // keypoint index in keyframe 2
  Eigen::Vector2d uv;
  map::Descriptor descriptor;  // a copy: the loop reads candidates in cell order
  double gate2;                // epipolar gate, squared px (chi^2 * level sigma^2)
  bool stereo;
  bool near_epipole;
};

// The candidates bucketed in square cells, so that a line visits the cells
// along it rather than every candidate (keyframes hold 1000-2000 unmatched
// keypoints each, and each has 10 neighbours to search).
class CandidateGrid {
 public:
  explicit CandidateGrid(const std::vector<EpipolarCandidate>& candidates) {
    if (candidates.empty()) return;
    double max_gate2 = 0.0;
    Eigen::Vector2d lo = candidates.front().uv;
    Eigen::Vector2d hi = lo;
    for (const EpipolarCandidate& c : candidates) {
      lo = lo.cwiseMin(c.uv);
      hi = hi.cwiseMax(c.uv);
      max_gate2 = std::max(max_gate2, c.gate2);
    }
    origin_ = lo;
    max_gate_px_ = std::sqrt(max_gate2);
    // At most kMaxCellsPerAxis a side, whatever the keypoints' extent.
    cell_px_ = std::max(kCellPx, (hi - lo).maxCoeff() / kMaxCellsPerAxis);
    columns_ = static_cast<int>((hi.x() - lo.x()) / cell_px_) + 1;
    rows_ = static_cast<int>((hi.y() - lo.y()) / cell_px_) + 1;
    // Counting sort by cell; within a cell, candidates keep their order.
    cell_start_.assign(static_cast<std::size_t>(columns_ * rows_) + 1, 0);
    std::vector<int> cell_of(candidates.size());
    for (std::size_t k = 0; k < candidates.size(); ++k) {
      cell_of[k] = cell(column_of(candidates[k].uv.x()), row_of(candidates[k].uv.y()));
      ++cell_start_[static_cast<std::size_t>(cell_of[k]) + 1];
    }
    for (std::size_t c = 1; c < cell_start_.size(); ++c) cell_start_[c] += cell_start_[c - 1];
    members_.resize(candidates.size());
    std::vector<int> next(cell_start_.begin(), cell_start_.end() - 1);
    for (std::size_t k = 0; k < candidates.size(); ++k) {
      members_[static_cast<std::size_t>(next[static_cast<std::size_t>(cell_of[k])]++)] = static_cast<int>(k);
    }
  }

  // Positions (in the candidates vector) of every candidate within its
  // largest possible gate (plus a pixel) of the line l = (a, b, c),
  // a u + b v + c = 0; the caller applies each candidate's own gate. Along the
  // axis the line runs closer to, each column (row) of cells is searched
  // over the span the line crosses it plus the band's extent on that axis.
  void near_line(const Eigen::Vector3d& line, std::vector<int>& out) const {
    out.clear();
    if (members_.empty()) return;
    const double a = line.x();
    const double b = line.y();
    const double norm = std::hypot(a, b);
    const bool mostly_horizontal = std::abs(b) >= std::abs(a);
    const int n_major = mostly_horizontal ? columns_ : rows_;
    const int n_minor = mostly_horizontal ? rows_ : columns_;
    const double major_origin = mostly_horizontal ? origin_.x() : origin_.y();
    const double minor_origin = mostly_horizontal ? origin_.y() : origin_.x();
    // minor = slope * major + offset; the band's half-width on the minor axis.
    const double along = mostly_horizontal ? b : a;
    const double across = mostly_horizontal ? a : b;
    const double slope = -across / along;
    const double offset = -line.z() / along;
    const double half_band = (max_gate_px_ + kMarginPx) * norm / std::abs(along);
    for (int major = 0; major < n_major; ++major) {
      const double m0 = major_origin + major * cell_px_;
      const double v0 = slope * m0 + offset;
      const double v1 = slope * (m0 + cell_px_) + offset;
      const double low = std::min(v0, v1) - half_band - minor_origin;
      const double high = std::max(v0, v1) + half_band - minor_origin;
      if (high < 0.0 || low >= n_minor * cell_px_) continue;
      const int first = static_cast<int>(std::max(0.0, std::floor(low / cell_px_)));
      const int last = static_cast<int>(std::min(n_minor - 1.0, std::floor(high / cell_px_)));
      for (int minor = first; minor <= last; ++minor) {
        const int c = mostly_horizontal ? cell(major, minor) : cell(minor, major);
        out.insert(out.end(), members_.begin() + cell_start_[static_cast<std::size_t>(c)],
                   members_.begin() + cell_start_[static_cast<std::size_t>(c) + 1]);
      }
    }
  }

 private:
  static constexpr double kCellPx = 48.0;  // the fastest of 24-120 px (docs/tracking/issue24-measurements.md)
  static constexpr double kMaxCellsPerAxis = 256.0;
  static constexpr double kMarginPx = 1.0;  // round-off at the band's edge

  int column_of(double u) const {
    return std::clamp(static_cast<int>((u - origin_.x()) / cell_px_), 0, columns_ - 1);
  }
  int row_of(double v) const {
    return std::clamp(static_cast<int>((v - origin_.y()) / cell_px_), 0, rows_ - 1);
  }
  int cell(int column, int row) const { return row * columns_ + column; }

  Eigen::Vector2d origin_ = Eigen::Vector2d::Zero();
  double cell_px_ = kCellPx;
  double max_gate_px_ = 0.0;
  int columns_ = 0;
  int rows_ = 0;
  std::vector<int> cell_start_;  // CSR offsets into members_, one past the last cell
  std::vector<int> members_;     // candidate positions, grouped by cell
};

// Reprojection chi^2 (unit: level sigma^2) of p_world in a keyframe's keypoint.
double reprojection_chi2(const StereoCamera& camera, const map::ScalePyramid& pyramid,
                         const KeyFrameSnapshot& kf, const map::KeyPointData& kp,
                         const Eigen::Vector3d& p_world) {
  const Eigen::Vector3d p_cam = kf.T_cam_world * p_world;
  if (!(p_cam.z() > 0.0)) return std::numeric_limits<double>::infinity();
  const Eigen::Vector2d uv = camera.project(p_cam);
  double e2 = (uv - kp.uv_px).squaredNorm();
  if (kp.u_right_px >= 0.0) {
    const double er = camera.project_right_u(p_cam) - kp.u_right_px;
    e2 += er * er;
  }
  const double scale = pyramid.scale(kp.octave);
  return e2 / (scale * scale);
}

}  // namespace

Eigen::Matrix3d fundamental_2_1(const StereoCamera& camera, const SE3& T_cam1_world,
                                const SE3& T_cam2_world) {
  const SE3 T_cam2_cam1 = T_cam2_world * T_cam1_world.inverse();
  const Eigen::Matrix3d E = hat(T_cam2_cam1.translation()) * T_cam2_cam1.rotation_matrix();
  Eigen::Matrix3d K_inv = Eigen::Matrix3d::Identity();
  K_inv(0, 0) = 1.0 / camera.fx;
  K_inv(1, 1) = 1.0 / camera.fy;
  K_inv(0, 2) = -camera.cx / camera.fx;
  K_inv(1, 2) = -camera.cy / camera.fy;
  return K_inv.transpose() * E * K_inv;
}

std::vector<KeypointMatch> search_for_triangulation(const StereoCamera& camera,
                                                    const map::ScalePyramid& pyramid,
                                                    const KeyFrameSnapshot& kf1, const KeyFrameSnapshot& kf2,
                                                    const NewPointParams& params,
                                                    const std::vector<bool>& used1,
                                                    const std::vector<bool>& used2) {
  const Eigen::Matrix3d F21 = fundamental_2_1(camera, kf1.T_cam_world, kf2.T_cam_world);
  // Epipole: keyframe 1's centre seen from keyframe 2 (absent when behind).
  const Eigen::Vector3d c1_in_2 = kf2.T_cam_world * kf1.camera_center();
  const bool has_epipole = c1_in_2.z() > 0.0;
  const Eigen::Vector2d epipole = has_epipole ? camera.project(c1_in_2) : Eigen::Vector2d::Zero();

  // Unmatched keypoints of keyframe 2, in index order.
  std::vector<EpipolarCandidate> candidates;
  for (int j = 0; j < static_cast<int>(kf2.keypoints.size()); ++j) {
    if (kf2.point_of_keypoint[j] != map::kNoPoint) continue;
    if (!used2.empty() && used2[j]) continue;
    const map::KeyPointData& kp = kf2.keypoints[j];
    const double scale = pyramid.scale(kp.octave);
    const bool near_epipole = has_epipole && (kp.uv_px - epipole).squaredNorm() < kEpipoleRadius2Px2 * scale;
    candidates.push_back(
        {j, kp.uv_px, kp.descriptor, params.epipolar_chi2 * scale * scale, has_stereo(kp), near_epipole});
  }
  const CandidateGrid grid(candidates);

  std::vector<KeypointMatch> proposals;
  std::vector<int> in_band;
  for (int i = 0; i < static_cast<int>(kf1.keypoints.size()); ++i) {
    if (kf1.point_of_keypoint[i] != map::kNoPoint) continue;
    if (!used1.empty() && used1[i]) continue;
    const map::KeyPointData& kp1 = kf1.keypoints[i];
    const bool stereo1 = has_stereo(kp1);
    const Eigen::Vector3d line = F21 * Eigen::Vector3d(kp1.uv_px.x(), kp1.uv_px.y(), 1.0);
    const double line_norm2 = line.head<2>().squaredNorm();
    if (!(line_norm2 > 0.0)) continue;
    grid.near_line(line, in_band);
    // Best and second-best distance over the gated candidates; of equal
    // best distances the first candidate (lowest keypoint index) wins,
    // whatever order the grid lists them in.
    int best = std::numeric_limits<int>::max();
    int second = std::numeric_limits<int>::max();
    int best_position = -1;
    for (const int position : in_band) {
      const EpipolarCandidate& c = candidates[position];
      if (!stereo1 && !c.stereo && c.near_epipole) continue;
      const double num = line.x() * c.uv.x() + line.y() * c.uv.y() + line.z();
      if (num * num > c.gate2 * line_norm2) continue;
      const int d = map::descriptor_distance(kp1.descriptor, c.descriptor);
      if (d < best) {
        second = best;
        best = d;
        best_position = position;
      } else {
        if (d == best && position < best_position) best_position = position;
        if (d < second) second = d;
      }
    }
    if (best_position < 0 || best > params.max_descriptor_distance) continue;
    if (second != std::numeric_limits<int>::max() &&
        !(static_cast<double>(best) < params.ratio * static_cast<double>(second))) {
      continue;
    }
    proposals.push_back({i, candidates[best_position].index, best});
  }

  // One keypoint of keyframe 2 per match: the lowest distance keeps it.
  std::sort(proposals.begin(), proposals.end(), [](const KeypointMatch& a, const KeypointMatch& b) {
    return a.distance != b.distance ? a.distance < b.distance : a.index1 < b.index1;
  });
  std::vector<bool> taken(kf2.keypoints.size(), false);
  std::vector<KeypointMatch> matches;
  for (const KeypointMatch& m : proposals) {
    if (taken[m.index2]) continue;
    taken[m.index2] = true;
    matches.push_back(m);
  }
  std::sort(matches.begin(), matches.end(),
            [](const KeypointMatch& a, const KeypointMatch& b) { return a.index1 < b.index1; });
  return matches;
}

std::vector<NewPoint> triangulate_matches(const StereoCamera& camera, const map::ScalePyramid& pyramid,
                                          const KeyFrameSnapshot& kf1, const KeyFrameSnapshot& kf2,
                                          const std::vector<KeypointMatch>& matches,
                                          const NewPointParams& params) {
  const Eigen::Matrix3d R_world_cam1 = kf1.T_world_cam.rotation_matrix();
  const Eigen::Matrix3d R_world_cam2 = kf2.T_world_cam.rotation_matrix();
  const Eigen::Vector3d center1 = kf1.camera_center();
  const Eigen::Vector3d center2 = kf2.camera_center();
  const double ratio_factor = kScaleRatioSlack * pyramid.scale_factor;
  // "No stereo" compares as a cosine above any real one (ORB-SLAM2 uses +1).
  constexpr double kNoStereoCos = 2.0;

  std::vector<NewPoint> points;
  for (const KeypointMatch& m : matches) {
    const map::KeyPointData& kp1 = kf1.keypoints[m.index1];
    const map::KeyPointData& kp2 = kf2.keypoints[m.index2];
    const bool stereo1 = has_stereo(kp1);
    const bool stereo2 = has_stereo(kp2);
    const Eigen::Vector3d ray1 = optim::normalised_ray(camera, kp1.uv_px);
    const Eigen::Vector3d ray2 = optim::normalised_ray(camera, kp2.uv_px);
    const Eigen::Vector3d d1 = R_world_cam1 * ray1;
    const Eigen::Vector3d d2 = R_world_cam2 * ray2;
    const double cos_rays = d1.dot(d2) / (d1.norm() * d2.norm());
    // Parallax of the stereo pair itself: the baseline seen from the point.
    const double cos_stereo1 =
        stereo1 ? std::cos(2.0 * std::atan2(camera.baseline_m / 2.0, kp1.depth_m)) : kNoStereoCos;
    const double cos_stereo2 =
        stereo2 ? std::cos(2.0 * std::atan2(camera.baseline_m / 2.0, kp2.depth_m)) : kNoStereoCos;
    const double cos_stereo = std::min(cos_stereo1, cos_stereo2);

    NewPoint point{m.index1, m.index2, Eigen::Vector3d::Zero(), false};
    if (cos_rays < cos_stereo && cos_rays > 0.0 &&
        (stereo1 || stereo2 || cos_rays < optim::kOrbSlamMaxCosParallax)) {
      // The decision on parallax is made above; 1.0 disables the helper's own test.
      const optim::TwoViewTriangulation t =
          optim::triangulate_two_view(kf1.T_cam_world, ray1, kf2.T_cam_world, ray2, 1.0);
      if (t.status != optim::TriangulationStatus::kOk) continue;
      point.p_world = t.p_world;
    } else if (stereo1 && cos_stereo1 < cos_stereo2) {
      point.p_world = kf1.T_world_cam * camera.unproject(kp1.uv_px, kp1.depth_m);
      point.from_stereo = true;
    } else if (stereo2 && cos_stereo2 < cos_stereo1) {
      point.p_world = kf2.T_world_cam * camera.unproject(kp2.uv_px, kp2.depth_m);
      point.from_stereo = true;
    } else {
      continue;  // neither two views nor stereo constrain the depth
    }
    if (!point.p_world.allFinite()) continue;
    if (!((kf1.T_cam_world * point.p_world).z() > 0.0) || !((kf2.T_cam_world * point.p_world).z() > 0.0)) {
      continue;
    }
    // The right column enters the residual whenever it was measured.
    const double gate1 = kp1.u_right_px >= 0.0 ? params.chi2_stereo : params.chi2_mono;
    const double gate2 = kp2.u_right_px >= 0.0 ? params.chi2_stereo : params.chi2_mono;
    if (reprojection_chi2(camera, pyramid, kf1, kp1, point.p_world) > gate1) continue;
    if (reprojection_chi2(camera, pyramid, kf2, kp2, point.p_world) > gate2) continue;
    // Scale consistency: a point seen at a coarser octave must be farther.
    const double dist1 = (point.p_world - center1).norm();
    const double dist2 = (point.p_world - center2).norm();
    if (!(dist1 > 0.0) || !(dist2 > 0.0)) continue;
    const double ratio_dist = dist2 / dist1;
    const double ratio_octave = pyramid.scale(kp1.octave) / pyramid.scale(kp2.octave);
    if (ratio_dist * ratio_factor < ratio_octave || ratio_dist > ratio_octave * ratio_factor) continue;
    points.push_back(point);
  }
  return points;
}

}  // namespace sitepose::mapping
