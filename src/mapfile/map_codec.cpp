#include <algorithm>
#include <string>

#include "sitepose/mapfile/byte_io.hpp"
#include "sitepose/mapfile/framed_file.hpp"
#include "sitepose/mapfile/map_file.hpp"

namespace sitepose::mapfile {
namespace {

template <typename Value>
std::vector<const Value*> by_id(const std::unordered_map<std::int64_t, Value>& items) {
  std::vector<const Value*> sorted;
  sorted.reserve(items.size());
  for (const auto& [id, item] : items) sorted.push_back(&item);
  std::sort(sorted.begin(), sorted.end(), [](const Value* a, const Value* b) { return a->id < b->id; });
  return sorted;
}

// Starts a section; returns where its length goes (patched by end_section).
std::size_t begin_section(ByteWriter& out, std::uint32_t tag) {
  out.u32(tag);
  const std::size_t at = out.size();
  out.u64(0);
  return at;
}

void end_section(ByteWriter& out, std::size_t length_at) {
  out.patch_u64(length_at, out.size() - length_at - 8);
}

void write_meta(ByteWriter& out, const map::MapData& map, const MapFileMeta& meta) {
  const std::size_t at = begin_section(out, kMetaTag);
  out.u32(static_cast<std::uint32_t>(map.pyramid().n_levels));
  out.f64(map.pyramid().scale_factor);
  out.text(meta.vocabulary_id);
  out.u8(meta.anchor ? 1 : 0);
  const SiteAnchorRecord anchor = meta.anchor.value_or(SiteAnchorRecord{});
  out.f64(anchor.latitude_deg);
  out.f64(anchor.longitude_deg);
  out.f64(anchor.height_m);
  out.pose(anchor.T_site_slam);
  out.i64(map.first_keyframe());
  out.i64(map.last_keyframe());
  end_section(out, at);
}

// A section of records (map_decode.cpp's read_records): their count, then
// each record as `write_one` writes it.
template <typename Record>
void write_records(ByteWriter& out, std::uint32_t tag, const std::vector<const Record*>& records,
                   void (*write_one)(ByteWriter&, const Record&)) {
  const std::size_t at = begin_section(out, tag);
  out.u64(records.size());
  for (const Record* record : records) write_one(out, *record);
  end_section(out, at);
}

void write_keyframe(ByteWriter& out, const map::KeyFrame& kf) {
  out.i64(kf.id);
  out.i64(kf.frame_seq);
  out.i64(kf.t_ns);
  out.pose(kf.T_world_cam);
  out.i64(kf.parent);
  out.u64(kf.keypoints.size());
  for (const map::KeyPointData& kp : kf.keypoints) {
    out.f64(kp.uv_px.x());
    out.f64(kp.uv_px.y());
    out.u8(static_cast<std::uint8_t>(kp.octave));
    out.f64(kp.u_right_px);
    out.f64(kp.depth_m);
    out.raw(kp.descriptor);
    out.u16(kp.instance);
  }
}

void write_point(ByteWriter& out, const map::MapPoint& p) {
  out.i64(p.id);
  out.vec3(p.p_world);
  out.raw(p.descriptor);
  out.vec3(p.normal);
  out.f64(p.min_distance_m);
  out.f64(p.max_distance_m);
  out.i64(p.reference_keyframe);
  out.i64(p.first_keyframe);
  out.i32(p.n_visible);
  out.i32(p.n_found);
  out.u64(p.observations.size());
  for (const auto& [kf, index] : p.observations) {
    out.i64(kf);
    out.i32(index);
  }
}

void write_covisibility(ByteWriter& out, const map::KeyFrame& kf) {
  out.i64(kf.id);
  out.u64(kf.covisibility.size());
  for (const auto& [other, weight] : kf.covisibility) {
    out.i64(other);
    out.i32(weight);
  }
}

void write_loop_edges(ByteWriter& out, const map::KeyFrame& kf) {
  out.i64(kf.id);
  out.u64(kf.loop_edges.size());
  for (const map::KeyFrameId other : kf.loop_edges) out.i64(other);
}

void write_map_travel(ByteWriter& out, const map::KeyFrame& kf) {
  out.i64(kf.id);
  out.f64(kf.map_travel_m);
}

}  // namespace

std::vector<std::uint8_t> encode_map(const map::MapData& map, const MapFileMeta& meta) {
  // A provisional map stands where dead reckoning put it, a joined one not
  // yet confirmed where the join alone put it: a later start must not
  // relocalise in it and call the pose OK. The site map is saved alone:
  // everything from the earliest mark on (dropping clears both marks).
  map::KeyFrameId first_unsaved = map::kNoKeyFrame;
  for (const map::KeyFrameId first : {map.provisional_since(), map.joined_unconfirmed_since()}) {
    if (first != map::kNoKeyFrame && (first_unsaved == map::kNoKeyFrame || first < first_unsaved))
      first_unsaved = first;
  }
  if (first_unsaved != map::kNoKeyFrame) {
    map::MapData site_map = map;
    site_map.drop_keyframes_from(first_unsaved);
    return encode_map(site_map, meta);
  }
  const auto keyframes = by_id(map.keyframes());
  std::vector<const map::MapPoint*> points = by_id(map.points());
  std::erase_if(points, [](const map::MapPoint* p) { return p->bad; });
  ByteWriter out;
  out.raw(std::vector<std::uint8_t>(kHeaderBytes, 0));
  write_meta(out, map, meta);
  write_records(out, kKeyFramesTag, keyframes, write_keyframe);
  write_records(out, kPointsTag, points, write_point);
  write_records(out, kCovisibilityTag, keyframes, write_covisibility);
  std::vector<const map::KeyFrame*> looped = keyframes;
  std::erase_if(looped, [](const map::KeyFrame* kf) { return kf->loop_edges.empty(); });
  if (!looped.empty()) write_records(out, kLoopEdgesTag, looped, write_loop_edges);
  write_records(out, kMapTravelTag, keyframes, write_map_travel);
  write_frame_header(map_file_kind(), out.bytes());
  return std::move(out.bytes());
}

}  // namespace sitepose::mapfile
