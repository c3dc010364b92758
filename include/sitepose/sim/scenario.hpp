#pragma once
// Simulator scenarios (config/scenarios/<name>.yaml): the site, the ego
// roller's drive, the other machines and their paths, image realism.
// Each YAML key maps to one field below (same name); defaults here are the
// documented defaults. Units in names; times in seconds from the start of
// the sequence; site frame: x along the ego lane, y left of +x, z up (m).

#include <optional>
#include <string>
#include <vector>

#include "sitepose/core/expected.hpp"

namespace sitepose::sim {

struct CameraSpec {
  int width = 960;
  int height = 540;
  double fx = 700.0;  // cx, cy = width / 2, height / 2
  double fy = 700.0;
  double baseline_m = 1.0;  // right camera at +x of the left one
  double height_m = 2.0;    // optical centre above the ground
  double pitch_down_deg = 10.0;
  std::string side = "right";  // looks to the right (-y) or left (+y) of +x travel
};

struct VibrationSpec {
  double amplitude_m = 0.002;   // vertical, while driving (25 % when stopped)
  double amplitude_deg = 0.05;  // roll and pitch
  double frequency_hz = 31.0;   // drum vibration; a second component at 1.37x
};

struct EgoSegment {
  double speed_mps = 0.0;  // along +x (or the path); negative = reversing; |v| <= 3.1
  double duration_s = 1.0;
};

struct EgoSpec {
  double start_x_m = 0.0;
  double start_y_m = 0.0;
  // Optional: the ego drives this path (site frame, [x, y] each, >= 2)
  // instead of the lane along +x, heading along it; its corners rounded to
  // circular arcs of turn_radius_m (0 = sharp), the segments' speeds along
  // the path's arc length from its first point (clamped to the path).
  std::vector<std::vector<double>> waypoints;
  double turn_radius_m = 0.0;
  double accel_mps2 = 0.25;
  std::vector<EgoSegment> segments;  // after the last one the roller stops
  VibrationSpec vibration;
};

struct DistortionSpec {  // OpenCV plumb-bob, both cameras
  double k1 = 0.0, k2 = 0.0, p1 = 0.0, p2 = 0.0;
};

// Dirt or a hand over the camera housing: both lenses pass only
// `transmission` of the light for the interval (near-black frames while the
// scene, the ego and the ground truth go on).
struct LensCoverSpec {
  double at_s = 0.0;
  double duration_s = 0.0;
  double transmission = 0.03;
};

struct RealismSpec {
  double exposure_variation = 0.06;  // relative gain, smooth random per frame
  double noise_sigma = 1.5;          // gray levels, Gaussian, per pixel
  double contrast = 1.0;             // scales deviations from mid-gray (fast: < 1)
  double brightness = 1.0;           // overall gain
  int motion_blur_samples = 1;       // odd; > 1: average renders over the exposure
  double exposure_time_s = 0.01;
  double right_gain = 1.0;  // right camera gain relative to the left
  bool distorted = false;   // write unrectified images with `distortion`
  DistortionSpec distortion;
  std::vector<LensCoverSpec> lens_covered;  // in time order, not overlapping
};

struct WorldSpec {
  double structures_min_m = 18.0;  // hoarding line, lateral distance from the lane
  double structures_max_m = 60.0;  // building faces
  bool tyre_tracks = true;
};

struct StopSpec {
  double at_s = 0.0;        // braking starts
  double duration_s = 0.0;  // standing still after braking
};

// Work of a machine that stands (excavator, loader): during the interval its
// joints follow (1 - cos(2 pi tau / period_s)) / 2 of their amplitudes
// (tau = time since at_s) and keep the pose they reached afterwards. slew:
// the excavator's house about its vertical axis; dig: boom, arm and bucket
// (excavator) or lift arms and bucket (loader).
struct WorkSpec {
  double at_s = 0.0;
  double duration_s = 0.0;
  double slew_deg = 0.0;
  double dig_deg = 0.0;
  double period_s = 8.0;
};

struct MachineSpec {
  std::string class_name;  // roller | truck | excavator | loader | person
  std::string paint = "yellow";
  std::string label;  // painted text; empty = model default
  // Without a path: parked at (x, y) with yaw. With a path: starts at its
  // first waypoint, facing along it (reverse: backwards).
  double x_m = 0.0, y_m = 0.0, yaw_deg = 0.0;
  std::vector<std::vector<double>> waypoints;  // [[x, y], ...] (>= 2 when set)
  double speed_mps = 1.0;
  double start_s = 0.0;
  double accel_mps2 = 0.4;
  bool reverse = false;
  std::vector<StopSpec> stops;
  // excavator, loader: joint motion while standing (an excavator with work
  // is rendered from its parts; without, as one rigid mesh).
  std::vector<WorkSpec> work;
  std::string pose = "standing";  // person: standing | crouching (with waypoints: walking)
};

struct ConeSpec {
  double x_m = 0.0, y_m = 0.0;
};

struct Scenario {
  std::string name;
  std::string description;
  std::string source_path;  // the YAML file it came from ("" if built in code)
  double fps = 6.0;
  double duration_s = 30.0;  // frames = round(duration_s * fps)
  int seed = 1;
  CameraSpec camera;
  EgoSpec ego;
  RealismSpec realism;
  WorldSpec world;
  std::vector<MachineSpec> machines;
  std::vector<ConeSpec> cones;

  int frame_count() const;
};

// Folder of the shipped scenarios: $SITEPOSE_SCENARIO_DIR if set, else the
// source tree's config/scenarios.
std::string default_scenario_dir();

// `name_or_path`: a file path (contains '/' or ends in .yaml) or a scenario
// name looked up in `dir` (default_scenario_dir() when empty). Errors:
// kNotFound naming the file and the known names; kInvalidArgument with every
// problem as "file:line: key.path = value: expectation".
Expected<Scenario> load_scenario(const std::string& name_or_path, const std::string& dir = "");
Expected<Scenario> parse_scenario(const std::string& yaml_text, const std::string& source_name);

struct ScenarioEntry {
  std::string name;
  std::string description;
  std::string path;
};
// Every *.yaml in `dir`, sorted by name; description read from the file
// (files that fail to load are listed with the error as description).
Expected<std::vector<ScenarioEntry>> list_scenarios(const std::string& dir = "");

}  // namespace sitepose::sim
