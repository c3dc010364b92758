#pragma once
// The site map on disk: keyframes (pose, keypoints with stereo depth and
// descriptors, parent), map points (position, descriptor, normal, scale
// range, observations, tracking statistics), covisibility, the site anchor
// and the id of the place-recognition vocabulary the map was built with.
// Layout (little-endian; this comment is its specification):
//
//   header  32 bytes: magic "SPMAP\r\n\x1a", u32 version, u32 flags (0),
//           u64 payload bytes, u32 CRC-32 of the payload, u32 CRC-32 of the
//           header's first 28 bytes
//   payload sections, each: 4-byte tag, u64 body bytes, body. Tags META,
//           KFRM, PNTS, COVI are required; LOOP (loop edges, as COVI's
//           records with bare i64 keyframe ids) only when the map has a
//           loop; TRVL (per keyframe: i64 id, f64 map_travel_m) in maps
//           saved since it was added, derived from the spanning tree when
//           missing; unknown tags are skipped, so a later minor addition
//           does not need a new version.
//
// Reading checks, in order, and names the first that fails: size (a file
// shorter than its header says is truncated), magic, header checksum,
// version, payload checksum, then every section's bounds, the values
// (finite poses, positions, measurements and anchor, coordinates within
// 1e9 m; keypoints on the
// pyramid's levels) and the map's consistency (map::MapData::restore). A
// file that fails is refused whole.
//
// Saving writes atomically (atomic_file.hpp): a failed or killed save
// leaves the previous file as it was.
//
// Thread: free functions on values; save_map reads a MapData the caller
// copied out of the SharedMap (or holds under its read lock).

#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "sitepose/core/expected.hpp"
#include "sitepose/core/se3.hpp"
#include "sitepose/map/map_data.hpp"

namespace sitepose::mapfile {

inline constexpr std::uint32_t kFormatVersion = 1;
inline constexpr std::size_t kHeaderBytes = 32;  // framed_file.hpp kFrameHeaderBytes

// Where the SLAM world frame sits on the site: the geodetic origin of the
// site ENU frame and T_site_slam (geo::SiteFrame's inputs, as plain values
// so the map file needs no geo module).
struct SiteAnchorRecord {
  double latitude_deg = 0.0;
  double longitude_deg = 0.0;
  double height_m = 0.0;
  SE3 T_site_slam;
};

struct MapFileMeta {
  std::optional<SiteAnchorRecord> anchor;  // none: the map is in its own frame only
  std::string vocabulary_id;               // empty: no vocabulary
};

struct LoadedMap {
  map::MapData map;
  MapFileMeta meta;
  std::uint32_t version = 0;
};

// What `sitepose map info` prints.
struct MapSummary {
  std::uint32_t version = 0;
  std::uint64_t file_bytes = 0;
  std::size_t keyframes = 0;
  std::size_t points = 0;
  std::size_t keypoints = 0;     // over all keyframes
  std::size_t observations = 0;  // over all points
  std::size_t covisibility_edges = 0;
  std::size_t loop_edges = 0;
  // Axis-aligned box of the keyframes' camera centres (zero when empty).
  Eigen::Vector3d centre_min_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d centre_max_m = Eigen::Vector3d::Zero();
  double path_length_m = 0.0;  // keyframe centres in id order
  // Largest KeyFrame::map_travel_m: how far the map was built out from its
  // origin, the published drift term's distance at its farthest place.
  double largest_map_travel_m = 0.0;
  MapFileMeta meta;
};

// The file's bytes for the good keyframes and points of `map` (bad points
// are left out; they hold no observations). A provisional map
// (MapData::provisional_since), joined or not (joined_unconfirmed_since), is
// left out too: only the confirmed site map is saved.
std::vector<std::uint8_t> encode_map(const map::MapData& map, const MapFileMeta& meta);
Expected<LoadedMap> decode_map(std::span<const std::uint8_t> bytes);

Status save_map(const std::filesystem::path& path, const map::MapData& map, const MapFileMeta& meta);
// kNotFound when the file is missing, kParseError naming why it is refused.
Expected<LoadedMap> load_map(const std::filesystem::path& path);

MapSummary summarise(const LoadedMap& loaded, std::uint64_t file_bytes);

}  // namespace sitepose::mapfile
