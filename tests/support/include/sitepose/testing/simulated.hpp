#pragma once
// Small simulated sites for tests: a scenario rendered at a reduced size,
// and its frames as a frame source would deliver them. Needs sitepose::sim.

#include <gtest/gtest.h>

#include <optional>
#include <string>
#include <vector>

#include "sitepose/core/expected.hpp"
#include "sitepose/core/stereo_frame.hpp"
#include "sitepose/sim/scenario.hpp"
#include "sitepose/sim/sequence_writer.hpp"
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

// small_simulator's rendering written as a sequence folder at `folder`
// (FORMATS.md), for tests that run a reader or the binary on it.
inline Expected<sim::WriteSummary> write_small_sequence(const std::string& scenario, int width, int height,
                                                        int frames, const std::string& folder,
                                                        const std::string& scenario_dir = "") {
  SITEPOSE_TRY(sim::Simulator simulator, small_simulator(scenario, width, height, frames, scenario_dir));
  return sim::write_sequence(simulator, folder);
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

// A fixture that renders one scenario once per test suite, for suites that
// check many properties of the same frames. `Rendering` names it:
//   struct Small { static sim::Scenario scenario(); static sim::SimOptions options(); };
//   using SimulatorTest = RenderedScenarioTest<Small>;
template <typename Rendering>
class RenderedScenarioTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto sim = sim::Simulator::create(Rendering::scenario(), Rendering::options());
    ASSERT_TRUE(sim) << sim.error().message;
    sim_.emplace(std::move(*sim));
    for (int k = 0; k < sim_->frame_count(); ++k) frames_.push_back(sim_->render(k));
  }
  static void TearDownTestSuite() {
    sim_.reset();
    frames_.clear();
  }
  static inline std::optional<sim::Simulator> sim_;
  static inline std::vector<sim::SimFrame> frames_;
};

}  // namespace sitepose::testing
