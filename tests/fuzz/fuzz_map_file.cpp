// The site map file (mapping.map_file; siteposed loads it at start, the
// relocaliser and the tracker then walk it). An accepted map is consistent
// both ways (every observation names an existing keyframe and keypoint that
// names the point back, parents and covisible keyframes exist), holds
// finite poses and positions and keypoints on the pyramid's levels, can
// grow with fresh ids, and saves to a file that loads to the same summary.
#include <cmath>
#include <limits>

#include "fuzz_check.hpp"
#include "fuzz_frame.hpp"
#include "fuzz_input.hpp"
#include "sitepose/mapfile/map_file.hpp"

namespace {

using namespace sitepose;

bool finite(double v) { return std::isfinite(v); }

void check_keyframes(const map::MapData& m) {
  const map::ScalePyramid& pyramid = m.pyramid();
  for (const auto& [id, kf] : m.keyframes()) {
    fuzz::require(id == kf.id && id >= 0 && id < std::numeric_limits<map::KeyFrameId>::max(),
                  "keyframe id: its key, >= 0, room for the next");
    fuzz::require(!kf.bad, "no bad keyframe");
    fuzz::require_pose(kf.T_world_cam);
    fuzz::require(kf.point_of_keypoint.size() == kf.keypoints.size(), "one point slot per keypoint");
    for (std::size_t i = 0; i < kf.keypoints.size(); ++i) {
      const map::KeyPointData& kp = kf.keypoints[i];
      fuzz::require(kp.uv_px.allFinite() && finite(kp.u_right_px) && finite(kp.depth_m), "finite keypoint");
      fuzz::require(kp.octave >= 0 && kp.octave < pyramid.n_levels, "keypoint octave on the pyramid");
      const map::PointId pid = kf.point_of_keypoint[i];
      if (pid == map::kNoPoint) continue;
      const map::MapPoint* p = m.point(pid);
      fuzz::require(p != nullptr, "keypoint names an existing point");
      const auto obs = p->observations.find(id);
      fuzz::require(obs != p->observations.end() && obs->second == static_cast<int>(i),
                    "the point observes the keypoint back");
    }
    for (const auto& [other, weight] : kf.covisibility) {
      fuzz::require(m.keyframe(other) != nullptr, "covisible keyframe exists");
    }
    if (kf.parent != map::kNoKeyFrame) {
      const map::KeyFrame* parent = m.keyframe(kf.parent);
      fuzz::require(parent != nullptr && kf.parent != id, "parent exists and is another keyframe");
      fuzz::require(parent->children.count(id) == 1, "parent lists the child");
    }
    for (const map::KeyFrameId child : kf.children) {
      const map::KeyFrame* c = m.keyframe(child);
      fuzz::require(c != nullptr && c->parent == id, "child names the parent");
    }
  }
}

void check_points(const map::MapData& m) {
  for (const auto& [id, p] : m.points()) {
    fuzz::require(id == p.id && id >= 0 && id < std::numeric_limits<map::PointId>::max(),
                  "point id: its key, >= 0, room for the next");
    fuzz::require(!p.bad, "no bad point");
    fuzz::require(p.p_world.allFinite() && p.normal.allFinite(), "finite point position and normal");
    fuzz::require(finite(p.min_distance_m) && finite(p.max_distance_m), "finite scale range");
    fuzz::require(p.n_visible >= 1 && p.n_found >= 0 && finite(p.found_ratio()), "a found ratio");
    for (const auto& [kf_id, index] : p.observations) {
      const map::KeyFrame* kf = m.keyframe(kf_id);
      fuzz::require(kf != nullptr, "observation names an existing keyframe");
      fuzz::require(index >= 0 && static_cast<std::size_t>(index) < kf->keypoints.size(),
                    "observation names an existing keypoint");
      fuzz::require(kf->point_of_keypoint[static_cast<std::size_t>(index)] == id,
                    "the keypoint names the point back");
    }
  }
}

void check_meta(const mapfile::MapFileMeta& meta) {
  if (!meta.anchor) return;
  const mapfile::SiteAnchorRecord& a = *meta.anchor;
  fuzz::require(finite(a.latitude_deg) && finite(a.longitude_deg) && finite(a.height_m), "finite anchor");
  fuzz::require_pose(a.T_site_slam);
}

bool same(const mapfile::MapSummary& a, const mapfile::MapSummary& b) {
  return a.version == b.version && a.keyframes == b.keyframes && a.points == b.points &&
         a.keypoints == b.keypoints && a.observations == b.observations &&
         a.covisibility_edges == b.covisibility_edges && a.centre_min_m == b.centre_min_m &&
         a.centre_max_m == b.centre_max_m && a.path_length_m == b.path_length_m &&
         a.largest_map_travel_m == b.largest_map_travel_m && a.meta.vocabulary_id == b.meta.vocabulary_id &&
         a.meta.anchor.has_value() == b.meta.anchor.has_value();
}

void check(const std::vector<std::uint8_t>& bytes) {
  auto loaded = mapfile::decode_map(bytes);
  if (!loaded) return;
  const map::MapData& m = loaded->map;
  fuzz::require(m.pyramid().n_levels >= 1 && m.pyramid().n_levels <= 32, "pyramid levels 1..32");
  fuzz::require(finite(m.pyramid().scale_factor) && m.pyramid().scale_factor > 1.0,
                "finite scale factor > 1");
  fuzz::require((m.first_keyframe() == map::kNoKeyFrame) == (m.keyframe_count() == 0) &&
                    (m.last_keyframe() == map::kNoKeyFrame) == (m.keyframe_count() == 0),
                "first/last keyframe set exactly when there are keyframes");
  if (m.keyframe_count() > 0) {
    fuzz::require(m.keyframe(m.first_keyframe()) != nullptr && m.keyframe(m.last_keyframe()) != nullptr,
                  "first/last keyframe exist");
  }
  check_keyframes(m);
  check_points(m);
  check_meta(loaded->meta);

  const mapfile::MapSummary summary = mapfile::summarise(*loaded, bytes.size());
  fuzz::require(summary.keyframes == m.keyframe_count() && summary.points == m.point_count(),
                "summary counts");
  fuzz::require(summary.centre_min_m.allFinite() && summary.centre_max_m.allFinite() &&
                    std::isfinite(summary.path_length_m) && std::isfinite(summary.largest_map_travel_m),
                "finite summary geometry");

  const std::vector<std::uint8_t> again = mapfile::encode_map(m, loaded->meta);
  auto reloaded = mapfile::decode_map(again);
  fuzz::require(reloaded.has_value(), "a saved accepted map loads");
  fuzz::require(same(summary, mapfile::summarise(*reloaded, again.size())), "save and load keep the summary");

  // A loaded map grows (the mapper adds keyframes and points after it).
  map::KeyFrame kf;
  kf.keypoints.resize(1);
  const map::KeyFrameId id = loaded->map.add_keyframe(kf);
  fuzz::require(loaded->map.keyframe(id) != nullptr, "a keyframe can be added");
  loaded->map.add_point(Eigen::Vector3d(0.0, 0.0, 1.0), id, 0);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  check(std::vector<std::uint8_t>(data, data + size));
  check(sitepose::fuzz::reframed(data, size));
  return 0;
}
