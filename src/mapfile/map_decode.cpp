#include <cmath>
#include <map>
#include <string>

#include "sitepose/mapfile/byte_io.hpp"
#include "sitepose/mapfile/framed_file.hpp"
#include "sitepose/mapfile/map_file.hpp"

namespace sitepose::mapfile {
namespace {

Unexpected refuse(const std::string& why) { return refuse_file(map_file_kind(), why); }

std::string tag_name(std::uint32_t tag) {
  std::string name;
  for (int i = 0; i < 4; ++i) {
    const char c = static_cast<char>((tag >> (8 * i)) & 0xFFU);
    name += (c >= 0x20 && c < 0x7f) ? c : '?';
  }
  return name;
}

Expected<std::map<std::uint32_t, std::span<const std::uint8_t>>> split_sections(
    std::span<const std::uint8_t> payload) {
  std::map<std::uint32_t, std::span<const std::uint8_t>> sections;
  ByteReader in(payload);
  while (in.remaining() > 0) {
    const std::uint32_t tag = in.u32();
    const std::uint64_t length = in.u64();
    if (!in.ok() || length > in.remaining())
      return refuse("section " + tag_name(tag) + " runs past the payload");
    const auto body = in.raw(static_cast<std::size_t>(length));
    if (!sections.emplace(tag, body).second) return refuse("section " + tag_name(tag) + " appears twice");
  }
  for (const std::uint32_t tag : {kMetaTag, kKeyFramesTag, kPointsTag, kCovisibilityTag}) {
    if (sections.count(tag) == 0) return refuse("section " + tag_name(tag) + " is missing");
  }
  return sections;
}

// Far beyond any site, and near enough that differences, squares and sums
// of coordinates (path lengths, projections) stay finite.
constexpr double kMaxCoordinateM = 1e9;

// Rotations need no check here: ByteReader::pose() refuses a quaternion
// that does not normalise.
bool finite_position(const Eigen::Vector3d& p) {
  return p.allFinite() && p.cwiseAbs().maxCoeff() <= kMaxCoordinateM;
}

struct Meta {
  map::ScalePyramid pyramid;
  MapFileMeta file;
  map::KeyFrameId first = map::kNoKeyFrame;
  map::KeyFrameId last = map::kNoKeyFrame;
};

Expected<Meta> read_meta(std::span<const std::uint8_t> body) {
  ByteReader in(body);
  Meta meta;
  meta.pyramid.n_levels = static_cast<int>(in.u32());
  meta.pyramid.scale_factor = in.f64();
  meta.file.vocabulary_id = in.text();
  const bool has_anchor = in.u8() != 0;
  SiteAnchorRecord anchor;
  anchor.latitude_deg = in.f64();
  anchor.longitude_deg = in.f64();
  anchor.height_m = in.f64();
  anchor.T_site_slam = in.pose();
  if (has_anchor) meta.file.anchor = anchor;
  meta.first = in.i64();
  meta.last = in.i64();
  if (!in.ok()) return refuse("section META ends early or holds a broken anchor pose");
  if (meta.pyramid.n_levels < 1 || meta.pyramid.n_levels > 32 || !(meta.pyramid.scale_factor > 1.0) ||
      !std::isfinite(meta.pyramid.scale_factor)) {
    return refuse("section META: scale pyramid " + std::to_string(meta.pyramid.n_levels) +
                  " levels, factor " + std::to_string(meta.pyramid.scale_factor) + " is out of range");
  }
  if (has_anchor && (!std::isfinite(anchor.latitude_deg) || !std::isfinite(anchor.longitude_deg) ||
                     !std::isfinite(anchor.height_m) || !finite_position(anchor.T_site_slam.translation()))) {
    return refuse("section META: the site anchor is not finite (or beyond 1e9 m)");
  }
  return meta;
}

// Leaves the descriptor as it is when the bytes end early (in.ok() says so).
void read_descriptor(ByteReader& in, map::Descriptor& descriptor) {
  const auto d = in.raw(descriptor.size());
  if (in.ok()) std::copy(d.begin(), d.end(), descriptor.begin());
}

map::KeyPointData read_keypoint(ByteReader& in) {
  map::KeyPointData kp;
  kp.uv_px.x() = in.f64();
  kp.uv_px.y() = in.f64();
  kp.octave = in.u8();
  kp.u_right_px = in.f64();
  kp.depth_m = in.f64();
  read_descriptor(in, kp.descriptor);
  kp.instance = in.u16();
  return kp;
}

void read_keyframe(ByteReader& in, map::KeyFrame& kf) {
  kf.id = in.i64();
  kf.frame_seq = in.i64();
  kf.t_ns = in.i64();
  kf.T_world_cam = in.pose();
  kf.parent = in.i64();
  kf.keypoints.resize(in.count(kKeyPointBytes));
  for (map::KeyPointData& kp : kf.keypoints) kp = read_keypoint(in);
}

void read_point(ByteReader& in, map::MapPoint& p) {
  p.id = in.i64();
  p.p_world = in.vec3();
  read_descriptor(in, p.descriptor);
  p.normal = in.vec3();
  p.min_distance_m = in.f64();
  p.max_distance_m = in.f64();
  p.reference_keyframe = in.i64();
  p.first_keyframe = in.i64();
  p.n_visible = in.i32();
  p.n_found = in.i32();
  const std::size_t n_observations = in.count(kObservationBytes);
  for (std::size_t k = 0; k < n_observations; ++k) {
    const map::KeyFrameId kf = in.i64();
    p.observations[kf] = in.i32();
  }
}

// A section of records (map_codec.cpp's write_records): their count, then
// each record; `refusal` says what a short or broken section is.
template <typename Record>
Expected<std::vector<Record>> read_records(std::span<const std::uint8_t> body, std::size_t min_record_bytes,
                                           void (*read_one)(ByteReader&, Record&), const char* refusal) {
  ByteReader in(body);
  std::vector<Record> records(in.count(min_record_bytes));
  for (std::size_t i = 0; i < records.size() && in.ok(); ++i) read_one(in, records[i]);
  if (!in.ok()) return refuse(refusal);
  return records;
}

// The records read so far, by id, for the sections that refer to them.
std::unordered_map<map::KeyFrameId, map::KeyFrame*> keyframes_by_id(std::vector<map::KeyFrame>& keyframes) {
  std::unordered_map<map::KeyFrameId, map::KeyFrame*> index;
  for (map::KeyFrame& kf : keyframes) index[kf.id] = &kf;
  return index;
}

// A section of per-keyframe edge lists (COVI, LOOP): records of keyframe
// id, edge count, edges of `edge_bytes` each, read by `read_edge`.
template <typename ReadEdge>
Status read_keyframe_edges(std::span<const std::uint8_t> body, std::uint32_t tag, std::size_t edge_bytes,
                           std::vector<map::KeyFrame>& keyframes, ReadEdge read_edge) {
  const std::unordered_map<map::KeyFrameId, map::KeyFrame*> index = keyframes_by_id(keyframes);
  ByteReader in(body);
  const std::size_t n = in.count(16);
  for (std::size_t i = 0; i < n && in.ok(); ++i) {
    const map::KeyFrameId id = in.i64();
    const std::size_t n_edges = in.count(edge_bytes);
    auto it = index.find(id);
    if (in.ok() && it == index.end())
      return refuse("section " + tag_name(tag) + " names keyframe " + std::to_string(id));
    for (std::size_t e = 0; e < n_edges && in.ok(); ++e) read_edge(in, *it->second);
  }
  if (!in.ok()) return refuse("section " + tag_name(tag) + " ends early");
  return ok_status();
}

Status read_covisibility(std::span<const std::uint8_t> body, std::vector<map::KeyFrame>& keyframes) {
  return read_keyframe_edges(body, kCovisibilityTag, kCovisibilityBytes, keyframes,
                             [](ByteReader& in, map::KeyFrame& kf) {
                               const map::KeyFrameId other = in.i64();
                               kf.covisibility[other] = in.i32();
                             });
}

// Optional: a map saved before any loop has none.
Status read_loop_edges(const std::map<std::uint32_t, std::span<const std::uint8_t>>& sections,
                       std::vector<map::KeyFrame>& keyframes) {
  const auto it = sections.find(kLoopEdgesTag);
  if (it == sections.end()) return ok_status();
  return read_keyframe_edges(it->second, kLoopEdgesTag, kLoopEdgeBytes, keyframes,
                             [](ByteReader& in, map::KeyFrame& kf) { kf.loop_edges.insert(in.i64()); });
}

// Optional: a map saved before it was added has none (false is returned;
// decode_map then derives the distances from the spanning tree).
Expected<bool> read_map_travel(const std::map<std::uint32_t, std::span<const std::uint8_t>>& sections,
                               std::vector<map::KeyFrame>& keyframes) {
  const auto it = sections.find(kMapTravelTag);
  if (it == sections.end()) return false;
  const std::unordered_map<map::KeyFrameId, map::KeyFrame*> index = keyframes_by_id(keyframes);
  ByteReader in(it->second);
  const std::size_t n = in.count(kMapTravelBytes);
  for (std::size_t i = 0; i < n && in.ok(); ++i) {
    const map::KeyFrameId id = in.i64();
    const double travel_m = in.f64();
    if (!in.ok()) break;
    const auto kf = index.find(id);
    if (kf == index.end()) return refuse("section TRVL names keyframe " + std::to_string(id));
    if (!(travel_m >= 0.0 && travel_m <= kMaxCoordinateM)) {
      return refuse("section TRVL: keyframe " + std::to_string(id) +
                    "'s map travel is negative, not finite or beyond 1e9 m");
    }
    kf->second->map_travel_m = travel_m;
  }
  if (!in.ok()) return refuse("section TRVL ends early");
  return true;
}

// What the sections' bounds do not catch: a NaN, infinite or absurdly far
// pose or position, a NaN or infinite measurement, or a keypoint on a level
// the pyramid lacks,
// would pass restore() and only go wrong in the tracker or the mapper.
Status check_values(const map::ScalePyramid& pyramid, const std::vector<map::KeyFrame>& keyframes,
                    const std::vector<map::MapPoint>& points) {
  for (const map::KeyFrame& kf : keyframes) {
    const std::string name = "keyframe " + std::to_string(kf.id);
    if (!finite_position(kf.T_world_cam.translation()))
      return refuse(name + ": the pose is not finite (or beyond 1e9 m)");
    for (std::size_t i = 0; i < kf.keypoints.size(); ++i) {
      const map::KeyPointData& kp = kf.keypoints[i];
      if (!kp.uv_px.allFinite() || !std::isfinite(kp.u_right_px) || !std::isfinite(kp.depth_m))
        return refuse(name + ": keypoint " + std::to_string(i) + " is not finite");
      if (kp.octave >= pyramid.n_levels) {
        return refuse(name + ": keypoint " + std::to_string(i) + " is on level " + std::to_string(kp.octave) +
                      ", the pyramid has " + std::to_string(pyramid.n_levels));
      }
    }
  }
  for (const map::MapPoint& p : points) {
    if (!finite_position(p.p_world) || !p.normal.allFinite() || !std::isfinite(p.min_distance_m) ||
        !std::isfinite(p.max_distance_m))
      return refuse("point " + std::to_string(p.id) +
                    ": position, normal or scale range is not finite (or beyond 1e9 m)");
    // found_ratio() divides by n_visible; the mapper culls points by it.
    if (p.n_visible < 1 || p.n_found < 0) {
      return refuse("point " + std::to_string(p.id) + ": seen " + std::to_string(p.n_visible) +
                    " and found " + std::to_string(p.n_found) + " times (seen must be >= 1, found >= 0)");
    }
  }
  return ok_status();
}

}  // namespace

Expected<LoadedMap> decode_map(std::span<const std::uint8_t> bytes) {
  std::uint32_t version = 0;
  SITEPOSE_TRY(const auto payload, check_frame(map_file_kind(), bytes, version));
  SITEPOSE_TRY(const auto sections, split_sections(payload));
  SITEPOSE_TRY(Meta meta, read_meta(sections.at(kMetaTag)));
  SITEPOSE_TRY(std::vector<map::KeyFrame> keyframes,
               read_records(sections.at(kKeyFramesTag), kKeyFrameBytes, read_keyframe,
                            "section KFRM ends early or holds a broken keyframe"));
  SITEPOSE_TRY(std::vector<map::MapPoint> points,
               read_records(sections.at(kPointsTag), kPointBytes, read_point,
                            "section PNTS ends early or holds a broken point"));
  SITEPOSE_TRY_STATUS(read_covisibility(sections.at(kCovisibilityTag), keyframes));
  SITEPOSE_TRY_STATUS(read_loop_edges(sections, keyframes));
  SITEPOSE_TRY(const bool has_map_travel, read_map_travel(sections, keyframes));
  SITEPOSE_TRY_STATUS(check_values(meta.pyramid, keyframes, points));
  auto restored =
      map::MapData::restore(meta.pyramid, std::move(keyframes), std::move(points), meta.first, meta.last);
  if (!restored) return refuse("inconsistent map: " + restored.error().message);
  if (!has_map_travel) restored->set_map_travel_along_spanning_tree();
  return LoadedMap{std::move(restored).value(), std::move(meta.file), version};
}

}  // namespace sitepose::mapfile
