#pragma once
// Site-map keyframe culling: the map keeps the site, not a window.
//
// The rule. When keyframe K has been processed, every keyframe X of the
// whole map (not only K's covisible window) whose centre is within
// radius_m of K's and whose viewing direction (optical axis in the world)
// is within angle_deg of K's is a candidate. A candidate is removed when
//   1. it is redundant by observation (keyframe_culling.hpp: at least
//      mapping.keyframe_redundancy of its close points are seen by
//      kRedundantObservers other keyframes at the same or a finer scale),
//   2. another keyframe stays in its site cell (below): a cell of the
//      driven area that has a keyframe keeps one, whatever is culled later,
//   3. it is not protected: the map's first keyframe, K itself and any
//      keyframe inserted after K (still queued), and the keyframes the
//      tracker works from (MapData::tracker_keyframes()).
// Candidates are tested newest first, so a place driven again keeps its
// older keyframes and sheds the new duplicates; each removal is checked
// again on the live map (removing one lowers the redundancy of the rest).
// Points left with fewer than two observations become bad with the
// keyframe (MapData::erase_observation) and are purged by the mapper.
//
// Site cell: the keyframe centre's position quantised to cubes of radius_m
// and its viewing direction's azimuth and elevation (world frame: the first
// keyframe's camera, y down, z forward) quantised to bins of angle_deg, all
// bins centred on 0 (the first keyframe's place and heading).
//
// Pure functions on MapData: call under SharedMap::read() (candidates) or
// write() (removal).

#include <array>
#include <vector>

#include "sitepose/map/map_data.hpp"

namespace sitepose::mapping {

struct SiteNeighbourhood {
  double radius_m = 1.0;
  double angle_deg = 15.0;
};

using SiteCell = std::array<long, 5>;  // x, y, z cube; azimuth, elevation bin

// Optical axis of the keyframe's left camera in the world frame (unit).
Eigen::Vector3d viewing_direction(const map::KeyFrame& keyframe);

SiteCell site_cell_of(const map::KeyFrame& keyframe, const SiteNeighbourhood& neighbourhood);

// Centres within radius_m and viewing directions within angle_deg.
bool within_neighbourhood(const map::KeyFrame& a, const map::KeyFrame& b,
                          const SiteNeighbourhood& neighbourhood);

// Another good keyframe shares `keyframe`'s site cell.
bool has_cell_mate(const map::MapData& map, map::KeyFrameId keyframe, const SiteNeighbourhood& neighbourhood);

// Rule 3: the keyframe must stay while `current` is being processed.
bool is_protected(const map::MapData& map, map::KeyFrameId keyframe, map::KeyFrameId current);

// Keyframes of the whole map in `current`'s neighbourhood that are not
// protected; newest first.
std::vector<map::KeyFrameId> site_candidates(const map::MapData& map, map::KeyFrameId current,
                                             const SiteNeighbourhood& neighbourhood);

// Up to n keyframes of the whole map in `current`'s neighbourhood other
// than `current`, nearest centre first (the mapper fuses with them).
std::vector<map::KeyFrameId> site_neighbours(const map::MapData& map, map::KeyFrameId current,
                                             const SiteNeighbourhood& neighbourhood, int n);

// Rules 1-3 for one candidate on the live map.
bool may_cull_from_site(const map::MapData& map, map::KeyFrameId keyframe, map::KeyFrameId current,
                        const SiteNeighbourhood& neighbourhood, double redundancy, double close_depth_m);

}  // namespace sitepose::mapping
