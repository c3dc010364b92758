#include "sitepose/sim/motion.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <Eigen/Geometry>

#include "sitepose/core/expected.hpp"

namespace sitepose::sim {

SpeedProfile::SpeedProfile(std::vector<SpeedChange> changes, double accel_mps2) {
  SITEPOSE_CHECK(accel_mps2 > 0.0);
  double v = 0.0;
  double x = 0.0;
  double t = changes.empty() ? 0.0 : std::min(0.0, changes.front().t_s);
  pieces_.push_back({t, 0.0, 0.0, 0.0, 0.0});
  for (const SpeedChange& c : changes) {
    SITEPOSE_CHECK(c.t_s >= pieces_.back().t0_s);
    const Piece& last = pieces_.back();
    x = piece_distance(last, c.t_s - last.t0_s);
    v = piece_speed(last, c.t_s - last.t0_s);
    const double ramp_s = std::abs(c.target_mps - v) / accel_mps2;
    pieces_.push_back({c.t_s, x, v, c.target_mps, ramp_s});
  }
}

double SpeedProfile::piece_speed(const Piece& p, double tau_s) {
  if (tau_s >= p.ramp_s) return p.v1_mps;
  if (tau_s <= 0.0) return p.v0_mps;
  const double phase = std::numbers::pi * tau_s / p.ramp_s;
  return p.v0_mps + (p.v1_mps - p.v0_mps) * 0.5 * (1.0 - std::cos(phase));
}

double SpeedProfile::piece_distance(const Piece& p, double tau_s) {
  tau_s = std::max(0.0, tau_s);
  const double dv = p.v1_mps - p.v0_mps;
  if (tau_s <= p.ramp_s) {
    if (p.ramp_s <= 0.0) return p.x0_m;
    const double k = std::numbers::pi / p.ramp_s;
    return p.x0_m + p.v0_mps * tau_s + 0.5 * dv * (tau_s - std::sin(k * tau_s) / k);
  }
  const double x_ramp = p.x0_m + p.v0_mps * p.ramp_s + 0.5 * dv * p.ramp_s;
  return x_ramp + p.v1_mps * (tau_s - p.ramp_s);
}

const SpeedProfile::Piece* SpeedProfile::piece_at(double t_s) const {
  if (pieces_.empty()) return nullptr;
  auto it = std::upper_bound(pieces_.begin(), pieces_.end(), t_s,
                             [](double t, const Piece& p) { return t < p.t0_s; });
  if (it == pieces_.begin()) return nullptr;
  return &*(it - 1);
}

double SpeedProfile::speed_mps(double t_s) const {
  const Piece* p = piece_at(t_s);
  return p ? piece_speed(*p, t_s - p->t0_s) : 0.0;
}

double SpeedProfile::distance_m(double t_s) const {
  const Piece* p = piece_at(t_s);
  return p ? piece_distance(*p, t_s - p->t0_s) : 0.0;
}

Polyline::Polyline(std::vector<Eigen::Vector2d> points) : points_(std::move(points)) {
  SITEPOSE_CHECK(points_.size() >= 2);
  cumulative_.push_back(0.0);
  for (size_t i = 1; i < points_.size(); ++i) {
    cumulative_.push_back(cumulative_.back() + (points_[i] - points_[i - 1]).norm());
  }
  SITEPOSE_CHECK(cumulative_.back() > 0.0);
}

size_t Polyline::segment(double s_m) const {
  // Last segment whose start is <= s, skipping zero-length segments.
  size_t i = 0;
  while (i + 2 < points_.size() && cumulative_[i + 1] <= s_m) ++i;
  while (i + 2 < points_.size() && cumulative_[i + 1] - cumulative_[i] <= 0.0) ++i;
  return i;
}

Eigen::Vector2d Polyline::position(double s_m) const {
  s_m = std::clamp(s_m, 0.0, length_m());
  const size_t i = segment(s_m);
  const double len = cumulative_[i + 1] - cumulative_[i];
  const double a = len > 0.0 ? (s_m - cumulative_[i]) / len : 0.0;
  return points_[i] + a * (points_[i + 1] - points_[i]);
}

std::vector<Eigen::Vector2d> rounded_corners(const std::vector<Eigen::Vector2d>& points, double radius_m,
                                             double step_m) {
  if (points.size() < 3 || !(radius_m > 0.0)) return points;
  std::vector<Eigen::Vector2d> out{points.front()};
  for (std::size_t i = 1; i + 1 < points.size(); ++i) {
    const Eigen::Vector2d in = points[i] - points[i - 1];
    const Eigen::Vector2d next = points[i + 1] - points[i];
    const double turn = std::atan2(in.x() * next.y() - in.y() * next.x(), in.dot(next));  // left > 0
    if (in.norm() <= 0.0 || next.norm() <= 0.0 || std::abs(turn) < 1e-9) {
      out.push_back(points[i]);
      continue;
    }
    // Tangent length r tan(|turn| / 2), at most half of either segment.
    const double tangent_m =
        std::min({radius_m * std::tan(0.5 * std::abs(turn)), 0.5 * in.norm(), 0.5 * next.norm()});
    const double r = tangent_m / std::tan(0.5 * std::abs(turn));
    const Eigen::Vector2d u_in = in.normalized();
    const Eigen::Vector2d start = points[i] - tangent_m * u_in;
    const Eigen::Vector2d left(-u_in.y(), u_in.x());
    const Eigen::Vector2d centre = start + (turn > 0.0 ? r : -r) * left;
    const double arc_m = r * std::abs(turn);
    const int n = std::max(2, static_cast<int>(std::ceil(arc_m / step_m)));
    const Eigen::Vector2d from_centre = start - centre;
    for (int k = 0; k <= n; ++k) out.push_back(centre + Eigen::Rotation2Dd(turn * k / n) * from_centre);
  }
  out.push_back(points.back());
  // Where two arcs meet (each took half the segment between them) the same
  // point comes twice: a zero-length segment has no heading.
  out.erase(
      std::unique(out.begin(), out.end(),
                  [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return (a - b).norm() < 1e-9; }),
      out.end());
  return out;
}

double Polyline::heading_rad(double s_m) const {
  s_m = std::clamp(s_m, 0.0, length_m());
  const size_t i = segment(s_m);
  const Eigen::Vector2d d = points_[i + 1] - points_[i];
  return std::atan2(d.y(), d.x());
}

}  // namespace sitepose::sim
