#include "sitepose/sim/scenario.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "detail/texture_gen.hpp"
#include "sitepose/config/yaml_reader.hpp"

namespace sitepose::sim {
namespace {

namespace fs = std::filesystem;
using config::at_least;
using config::at_most;
using config::in_range;
using config::one_of;
using config::positive;
using config::YamlMap;

// 4 km/h is the paper's range; 11 km/h its maximum.
constexpr double kMaxSpeedMps = 11.0 / 3.6;

// `waypoints` of an ego or a machine: [x, y] each, at least 2, a path of
// nonzero length (reported on `m`). True when the key was given.
bool read_waypoints(const YamlMap& m, std::vector<std::vector<double>>& waypoints) {
  const auto two_numbers = config::make_rule(
      [](const std::vector<std::vector<double>>& pts) {
        return std::all_of(pts.begin(), pts.end(), [](const auto& p) { return p.size() == 2; });
      },
      "every waypoint must be [x, y]");
  const auto at_least_two =
      config::make_rule([](const std::vector<std::vector<double>>& pts) { return pts.size() >= 2; },
                        "needs at least 2 waypoints");
  if (!m.read("waypoints", waypoints, two_numbers, at_least_two)) return false;
  double length = 0.0;
  for (size_t i = 1; i < waypoints.size(); ++i)
    length += std::hypot(waypoints[i][0] - waypoints[i - 1][0], waypoints[i][1] - waypoints[i - 1][1]);
  if (!(length > 0.0)) m.report("waypoints", "the path has zero length");
  return true;
}

void read_camera(const YamlMap& m, CameraSpec& c) {
  m.read("width", c.width, in_range(16, 8192));
  m.read("height", c.height, in_range(16, 8192));
  m.read("fx", c.fx, positive());
  m.read("fy", c.fy, positive());
  m.read("baseline_m", c.baseline_m, positive(), at_most(5.0));
  m.read("height_m", c.height_m, in_range(0.3, 10.0));
  m.read("pitch_down_deg", c.pitch_down_deg, in_range(-30.0, 60.0));
  m.read("side", c.side, one_of({"right", "left"}));
}

void read_ego(const YamlMap& m, EgoSpec& e) {
  m.read("start_x_m", e.start_x_m);
  m.read("start_y_m", e.start_y_m);
  if (read_waypoints(m, e.waypoints)) {
    if (m.has("start_x_m") || m.has("start_y_m")) {
      m.report("waypoints",
               "give either waypoints or a start on the +x lane (start_x_m, start_y_m), not both");
    }
  }
  m.read("turn_radius_m", e.turn_radius_m, in_range(0.0, 100.0));
  if (m.has("turn_radius_m") && e.waypoints.empty()) m.report("turn_radius_m", "needs waypoints");
  m.read("accel_mps2", e.accel_mps2, positive(), at_most(3.0));
  for (const YamlMap& s : m.maps("segments")) {
    EgoSegment seg;
    s.read_required("speed_mps", seg.speed_mps, in_range(-kMaxSpeedMps, kMaxSpeedMps));
    s.read_required("duration_s", seg.duration_s, positive());
    e.segments.push_back(seg);
  }
  YamlMap v = m.map("vibration");
  v.read("amplitude_m", e.vibration.amplitude_m, in_range(0.0, 0.05));
  v.read("amplitude_deg", e.vibration.amplitude_deg, in_range(0.0, 2.0));
  v.read("frequency_hz", e.vibration.frequency_hz, positive(), at_most(200.0));
}

void read_realism(const YamlMap& m, RealismSpec& r) {
  m.read("exposure_variation", r.exposure_variation, in_range(0.0, 0.5));
  m.read("noise_sigma", r.noise_sigma, in_range(0.0, 30.0));
  m.read("contrast", r.contrast, in_range(0.1, 2.0));
  m.read("brightness", r.brightness, in_range(0.2, 3.0));
  m.read("motion_blur_samples", r.motion_blur_samples, in_range(1, 15),
         config::make_rule([](int n) { return n % 2 == 1; },
                           "must be odd (labels come from the middle render)"));
  m.read("exposure_time_s", r.exposure_time_s, in_range(0.0, 0.2));
  m.read("right_gain", r.right_gain, in_range(0.5, 1.5));
  m.read("distorted", r.distorted);
  YamlMap d = m.map("distortion");
  d.read("k1", r.distortion.k1, in_range(-1.0, 1.0));
  d.read("k2", r.distortion.k2, in_range(-1.0, 1.0));
  d.read("p1", r.distortion.p1, in_range(-0.05, 0.05));
  d.read("p2", r.distortion.p2, in_range(-0.05, 0.05));
  double last_end_s = -1.0;
  for (const YamlMap& c : m.maps("lens_covered")) {
    LensCoverSpec cover;
    c.read_required("at_s", cover.at_s, at_least(0.0));
    c.read_required("duration_s", cover.duration_s, positive());
    c.read("transmission", cover.transmission, in_range(0.0, 1.0));
    if (cover.at_s <= last_end_s) c.report("at_s", "covers must be in time order and not overlap");
    last_end_s = cover.at_s + cover.duration_s;
    r.lens_covered.push_back(cover);
  }
}

void read_world(const YamlMap& m, WorldSpec& w) {
  m.read("structures_min_m", w.structures_min_m, in_range(8.0, 100.0));
  m.read("structures_max_m", w.structures_max_m, in_range(10.0, 300.0));
  m.read("tyre_tracks", w.tyre_tracks);
  if (w.structures_max_m < w.structures_min_m + 5.0) {
    m.report("structures_max_m", "must be >= structures_min_m + 5");
  }
}

void read_work(const YamlMap& m, MachineSpec& s) {
  double last = -1.0;
  for (const YamlMap& w : m.maps("work")) {
    WorkSpec work;
    w.read_required("at_s", work.at_s, at_least(0.0));
    w.read_required("duration_s", work.duration_s, positive());
    w.read("slew_deg", work.slew_deg, in_range(-360.0, 360.0));
    w.read("dig_deg", work.dig_deg, in_range(-40.0, 40.0));
    w.read("period_s", work.period_s, positive());
    if (work.at_s <= last) w.report("at_s", "work intervals must be in time order and not overlap");
    last = work.at_s + work.duration_s;
    s.work.push_back(work);
  }
  if (m.has("work") && s.class_name != "excavator" && s.class_name != "loader") {
    m.report("work", "only an excavator or a loader works in place");
  }
  if (m.has("work") && !s.waypoints.empty()) m.report("work", "a working machine is parked (no waypoints)");
  m.read("pose", s.pose, one_of({"standing", "crouching"}));
  if (m.has("pose") && s.class_name != "person") m.report("pose", "only a person has a pose");
}

void read_machine(const YamlMap& m, MachineSpec& s) {
  m.read_required("class", s.class_name, one_of({"roller", "truck", "excavator", "loader", "person"}));
  m.read("paint", s.paint, one_of(detail::paint_names()));
  m.read("label", s.label);
  m.read("x_m", s.x_m);
  m.read("y_m", s.y_m);
  m.read("yaw_deg", s.yaw_deg, in_range(-360.0, 360.0));
  if (read_waypoints(m, s.waypoints)) {
    if (m.has("x_m") || m.has("y_m") || m.has("yaw_deg")) {
      m.report("waypoints", "give either waypoints or a parked pose (x_m, y_m, yaw_deg), not both");
    }
  }
  m.read("speed_mps", s.speed_mps, positive(), at_most(kMaxSpeedMps));
  m.read("start_s", s.start_s, at_least(0.0));
  m.read("accel_mps2", s.accel_mps2, positive(), at_most(3.0));
  m.read("reverse", s.reverse);
  double last = -1.0;
  for (const YamlMap& st : m.maps("stops")) {
    StopSpec stop;
    st.read_required("at_s", stop.at_s, at_least(0.0));
    st.read_required("duration_s", stop.duration_s, positive());
    if (stop.at_s <= last) st.report("at_s", "stops must be in time order and not overlap");
    last = stop.at_s + stop.duration_s;
    s.stops.push_back(stop);
  }
  read_work(m, s);
  if (s.waypoints.empty() && (m.has("stops") || m.has("speed_mps") || m.has("start_s"))) {
    m.report_here("speed_mps, start_s and stops need waypoints (a machine without them is parked)");
  }
}

}  // namespace

int Scenario::frame_count() const { return static_cast<int>(std::lround(duration_s * fps)); }

std::string default_scenario_dir() {
  if (const char* env = std::getenv("SITEPOSE_SCENARIO_DIR"); env && *env) return env;
  return SITEPOSE_SCENARIO_DIR;
}

Expected<Scenario> parse_scenario(const std::string& yaml_text, const std::string& source_name) {
  SITEPOSE_TRY(auto reader, config::YamlReader::from_string(yaml_text, source_name));
  Scenario s;
  s.source_path = source_name;
  YamlMap root = reader.root();
  root.read_required("name", s.name, config::non_empty());
  root.read_required("description", s.description, config::non_empty());
  root.read("fps", s.fps, positive(), at_most(120.0));
  root.read_required("duration_s", s.duration_s, positive(), at_most(3600.0));
  root.read("seed", s.seed, at_least(0));
  read_camera(root.map("camera"), s.camera);
  read_ego(root.map("ego"), s.ego);
  read_realism(root.map("realism"), s.realism);
  read_world(root.map("world"), s.world);
  for (const YamlMap& m : root.maps("machines")) {
    MachineSpec spec;
    read_machine(m, spec);
    s.machines.push_back(std::move(spec));
  }
  for (const YamlMap& c : root.maps("cones")) {
    ConeSpec cone;
    c.read_required("x_m", cone.x_m);
    c.read_required("y_m", cone.y_m);
    s.cones.push_back(cone);
  }
  if (s.machines.size() + s.cones.size() > 60000) root.report_here("too many objects (ids are 16-bit)");
  SITEPOSE_TRY_STATUS(reader.finish());
  return s;
}

Expected<Scenario> load_scenario(const std::string& name_or_path, const std::string& dir_in) {
  const std::string dir = dir_in.empty() ? default_scenario_dir() : dir_in;
  const bool is_path =
      name_or_path.find('/') != std::string::npos ||
      (name_or_path.size() > 5 && name_or_path.compare(name_or_path.size() - 5, 5, ".yaml") == 0);
  const std::string path = is_path ? name_or_path : dir + "/" + name_or_path + ".yaml";
  std::ifstream in(path);
  if (!in) {
    std::string known;
    if (auto list = list_scenarios(dir); list) {
      for (const auto& e : *list) known += (known.empty() ? "" : ", ") + e.name;
    }
    return make_error(ErrorCode::kNotFound,
                      "scenario '" + name_or_path + "': cannot read " + path +
                          (is_path ? "" : " (known scenarios: " + (known.empty() ? "none" : known) + ")"));
  }
  std::stringstream text;
  text << in.rdbuf();
  return parse_scenario(text.str(), path);
}

Expected<std::vector<ScenarioEntry>> list_scenarios(const std::string& dir_in) {
  const std::string dir = dir_in.empty() ? default_scenario_dir() : dir_in;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    return make_error(ErrorCode::kNotFound, "scenario folder " + dir + " does not exist");
  }
  std::vector<ScenarioEntry> out;
  // increment(ec): a listing error ends the list instead of throwing.
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const fs::path& path = it->path();
    if (path.extension() != ".yaml") continue;
    ScenarioEntry e{path.stem().string(), "", path.string()};
    if (auto s = load_scenario(e.path, dir); s) {
      e.description = s->description;
    } else {
      e.description = "(invalid: " + s.error().message + ")";
    }
    out.push_back(std::move(e));
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.name < b.name; });
  return out;
}

}  // namespace sitepose::sim
