#pragma once
// Small simulated sites for tests: a scenario rendered at a reduced size,
// and its frames as a frame source would deliver them. Needs sitepose::sim.

#include <string>

#include "sitepose/core/expected.hpp"
#include "sitepose/core/stereo_frame.hpp"
#include "sitepose/sim/scenario.hpp"
#include "sitepose/sim/simulator.hpp"

namespace sitepose::testing {

// `scenario` (a name, or a path to a .yaml) from `scenario_dir` (empty: the
// simulator's default) rendered at width x height with the field of view
// kept; `frames` > 0 shortens it.
inline Expected<sim::Simulator> small_simulator(const std::string& scenario, int width, int height,
                                                int frames = 0, const std::string& scenario_dir = "") {
  SITEPOSE_TRY(sim::Scenario loaded, sim::load_scenario(scenario, scenario_dir));
  sim::SimOptions options;
  options.width = width;
  options.height = height;
  if (frames > 0) options.frames = frames;
  return sim::Simulator::create(loaded, options);
}

// A rendered frame as the StereoFrame a source delivers (seq = frame index).
inline StereoFrame stereo_frame(const sim::SimFrame& f, const std::string& source_id = "") {
  StereoFrame frame;
  frame.seq = f.index;
  frame.t_left_ns = frame.t_right_ns = f.t_ns;
  frame.left = f.left;
  frame.right = f.right;
  frame.source_id = source_id;
  return frame;
}

}  // namespace sitepose::testing
