#pragma once
// Meshes of the site: machines, cones and the static background. Model
// frames: x forward, y left, z up, origin on the ground at the centre of the
// footprint (metres). Deterministic in the Rng.

#include <string>
#include <vector>

#include "detail/rng.hpp"
#include "sitepose/sim/scene.hpp"

namespace sitepose::sim::detail {

struct MachineLook {
  std::string paint = "yellow";  // paint_level() name
  std::string label;             // text painted on the sides (model name / fleet number)
};

Mesh make_roller(Rng& rng, const MachineLook& look);
Mesh make_truck(Rng& rng, const MachineLook& look);
Mesh make_excavator(Rng& rng, const MachineLook& look);
Mesh make_cone(Rng& rng);

// What drives a joint of an articulated machine (see JointPart::drive).
enum class JointDrive { kFixed, kSlew, kDig };

// One rigid part of an articulated machine. Its patches are in the model
// frame at rest (every joint angle 0); it turns by gain * (drive angle)
// about `axis` through `pivot` (model frame, rest) relative to its parent
// part (-1: the machine's base pose).
struct JointPart {
  std::string name;  // undercarriage, house, boom, arm, bucket, body, ...
  Mesh mesh;
  int parent = -1;
  Eigen::Vector3d pivot = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  JointDrive drive = JointDrive::kFixed;
  double gain = 0.0;
};

// The excavator of make_excavator split at its joints (same Rng draws in
// the same order, so merge_parts() of it is make_excavator's mesh):
// undercarriage, house (slews about z), boom, arm, bucket (dig).
std::vector<JointPart> make_excavator_parts(Rng& rng, const MachineLook& look);
// Wheel loader: body, lift arms and bucket (dig raises the arms and curls
// the bucket).
std::vector<JointPart> make_loader_parts(Rng& rng, const MachineLook& look);
// The parts' patches at rest, in part order.
Mesh merge_parts(const std::vector<JointPart>& parts);
// A worker on foot (hi-vis vest, helmet), 1.75 m standing; crouching
// folds the legs (about 1.1 m).
Mesh make_person(Rng& rng, const MachineLook& look, bool crouching);

struct BackgroundLayout {
  double x_min_m = -50.0;  // lane extent the ego camera travels over (site x)
  double x_max_m = 50.0;
  double view_sign = -1.0;         // -1: the camera looks towards -y (right of +x travel), +1: +y
  double structures_min_m = 18.0;  // nearest structure row (lateral distance)
  double structures_max_m = 60.0;  // farthest building faces
  bool tyre_tracks = true;
};

// Ground (asphalt lane, gravel, soil haul road with tyre tracks) and the
// structures along the viewed side: hoarding, containers, site offices,
// soil piles, building faces. Everything in the site frame.
Mesh make_background(Rng& rng, const BackgroundLayout& layout);

}  // namespace sitepose::sim::detail
