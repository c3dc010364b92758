#include "sitepose/mapfile/map_file.hpp"

#include <algorithm>
#include <map>

#include "sitepose/mapfile/atomic_file.hpp"
#include "sitepose/mapfile/byte_io.hpp"
#include "sitepose/mapfile/framed_file.hpp"

namespace sitepose::mapfile {

const FileKind& map_file_kind() {
  static const FileKind kind{kMagic, kFormatVersion, "map file"};
  return kind;
}

Status save_map(const std::filesystem::path& path, const map::MapData& map, const MapFileMeta& meta) {
  const std::vector<std::uint8_t> bytes = encode_map(map, meta);
  return write_file_atomically(path, bytes);
}

Expected<LoadedMap> load_map(const std::filesystem::path& path) {
  SITEPOSE_TRY(const std::vector<std::uint8_t> bytes, read_file_bytes(map_file_kind(), path));
  auto loaded = decode_map(bytes);
  if (!loaded) return make_error(loaded.error().code, path.string() + ": " + loaded.error().message);
  return loaded;
}

MapSummary summarise(const LoadedMap& loaded, std::uint64_t file_bytes) {
  MapSummary s;
  s.version = loaded.version;
  s.file_bytes = file_bytes;
  s.meta = loaded.meta;
  const map::MapData& map = loaded.map;
  s.keyframes = map.keyframe_count();
  s.points = map.point_count();
  std::map<map::KeyFrameId, Eigen::Vector3d> centres;
  for (const auto& [id, kf] : map.keyframes()) {
    s.keypoints += kf.keypoints.size();
    s.covisibility_edges += kf.covisibility.size();
    s.loop_edges += kf.loop_edges.size();
    centres[id] = kf.camera_center();
    s.largest_map_travel_m = std::max(s.largest_map_travel_m, kf.map_travel_m);
  }
  for (const auto& [id, p] : map.points()) s.observations += p.observations.size();
  s.covisibility_edges /= 2;  // each edge is kept on both keyframes
  s.loop_edges /= 2;
  bool first = true;
  Eigen::Vector3d previous = Eigen::Vector3d::Zero();
  for (const auto& [id, c] : centres) {
    s.centre_min_m = first ? c : s.centre_min_m.cwiseMin(c);
    s.centre_max_m = first ? c : s.centre_max_m.cwiseMax(c);
    if (!first) s.path_length_m += (c - previous).norm();
    previous = c;
    first = false;
  }
  return s;
}

}  // namespace sitepose::mapfile
