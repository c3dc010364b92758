#pragma once
// Stereo cameras for tests: a centred rig of any size and the named rigs the
// synthetic scenes use.

#include "sitepose/core/centred_camera.hpp"

namespace sitepose::testing {

// Rectified rig with square pixels and the principal point at the image
// centre (as the simulator makes them).
using sitepose::centred_camera;

// The simulator's default rig: 960 x 540, f 700 px, 1 m baseline.
inline StereoCamera test_camera() { return centred_camera(960, 540, 700.0, 1.0); }

// 1280 x 720, f 700 px, 0.5 m baseline: stereo out to 20 m (40 baselines).
inline StereoCamera hd_camera() { return centred_camera(1280, 720, 700.0, 0.5); }

}  // namespace sitepose::testing
