#pragma once
// Meshes of the site: machines, cones and the static background. Model
// frames: x forward, y left, z up, origin on the ground at the centre of the
// footprint (metres). Deterministic in the Rng.

#include <string>

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

struct BackgroundLayout {
  double x_min_m = -50.0;  // lane extent the ego camera travels over (site x)
  double x_max_m = 50.0;
  double view_sign = -1.0;  // -1: the camera looks towards -y (right of +x travel), +1: +y
  double structures_min_m = 18.0;  // nearest structure row (lateral distance)
  double structures_max_m = 60.0;  // farthest building faces
  bool tyre_tracks = true;
};

// Ground (asphalt lane, gravel, soil haul road with tyre tracks) and the
// structures along the viewed side: hoarding, containers, site offices,
// soil piles, building faces. Everything in the site frame.
Mesh make_background(Rng& rng, const BackgroundLayout& layout);

}  // namespace sitepose::sim::detail
