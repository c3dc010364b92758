#pragma once
// Smooth 1-D motion for the ego roller and the other machines.
//
// A SpeedProfile is a list of speed changes; each change starts at its time
// and ramps from the current speed to the target with a half-cosine whose
// length is |dv| / accel (so the acceleration peaks at pi/2 * accel and is
// continuous at both ends). Distance is the exact integral of the speed.
// Units: seconds, metres, m/s; negative speed = reversing.

#include <Eigen/Core>
#include <vector>

namespace sitepose::sim {

struct SpeedChange {
  double t_s = 0.0;
  double target_mps = 0.0;
};

class SpeedProfile {
 public:
  SpeedProfile() = default;
  // `changes` sorted by time; accel_mps2 > 0. The speed is 0 before the first.
  SpeedProfile(std::vector<SpeedChange> changes, double accel_mps2);

  double speed_mps(double t_s) const;
  double distance_m(double t_s) const;  // 0 at t = 0 (and before the first change)

 private:
  struct Piece {
    double t0_s, x0_m, v0_mps, v1_mps, ramp_s;
  };
  const Piece* piece_at(double t_s) const;
  static double piece_speed(const Piece& p, double tau_s);
  static double piece_distance(const Piece& p, double tau_s);
  std::vector<Piece> pieces_;
};

// The polyline through `points` with each interior corner replaced by a
// circular arc of `radius_m` tangent to both segments, sampled every
// `step_m` (at most half of each segment is taken by one corner's arc, so
// a tight corner gets a smaller radius). radius_m = 0: the points as given.
std::vector<Eigen::Vector2d> rounded_corners(const std::vector<Eigen::Vector2d>& points, double radius_m,
                                             double step_m = 0.05);

// A polyline on the ground (site frame, metres) walked by arc length.
class Polyline {
 public:
  Polyline() = default;
  explicit Polyline(std::vector<Eigen::Vector2d> points);  // >= 2 distinct points

  double length_m() const { return cumulative_.empty() ? 0.0 : cumulative_.back(); }
  // Position and heading (rad, atan2 of the segment direction) at arc length
  // s, clamped to [0, length].
  Eigen::Vector2d position(double s_m) const;
  double heading_rad(double s_m) const;

 private:
  size_t segment(double s_m) const;
  std::vector<Eigen::Vector2d> points_;
  std::vector<double> cumulative_;
};

}  // namespace sitepose::sim
