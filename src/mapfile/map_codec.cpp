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

void write_keyframes(ByteWriter& out, const std::vector<const map::KeyFrame*>& keyframes) {
  const std::size_t at = begin_section(out, kKeyFramesTag);
  out.u64(keyframes.size());
  for (const map::KeyFrame* kf : keyframes) {
    out.i64(kf->id);
    out.i64(kf->frame_seq);
    out.i64(kf->t_ns);
    out.pose(kf->T_world_cam);
    out.i64(kf->parent);
    out.u64(kf->keypoints.size());
    for (const map::KeyPointData& kp : kf->keypoints) {
      out.f64(kp.uv_px.x());
      out.f64(kp.uv_px.y());
      out.u8(static_cast<std::uint8_t>(kp.octave));
      out.f64(kp.u_right_px);
      out.f64(kp.depth_m);
      out.raw(kp.descriptor);
      out.u16(kp.instance);
    }
  }
  end_section(out, at);
}

void write_points(ByteWriter& out, const std::vector<const map::MapPoint*>& points) {
  const std::size_t at = begin_section(out, kPointsTag);
  out.u64(points.size());
  for (const map::MapPoint* p : points) {
    out.i64(p->id);
    out.vec3(p->p_world);
    out.raw(p->descriptor);
    out.vec3(p->normal);
    out.f64(p->min_distance_m);
    out.f64(p->max_distance_m);
    out.i64(p->reference_keyframe);
    out.i64(p->first_keyframe);
    out.i32(p->n_visible);
    out.i32(p->n_found);
    out.u64(p->observations.size());
    for (const auto& [kf, index] : p->observations) {
      out.i64(kf);
      out.i32(index);
    }
  }
  end_section(out, at);
}

void write_covisibility(ByteWriter& out, const std::vector<const map::KeyFrame*>& keyframes) {
  const std::size_t at = begin_section(out, kCovisibilityTag);
  out.u64(keyframes.size());
  for (const map::KeyFrame* kf : keyframes) {
    out.i64(kf->id);
    out.u64(kf->covisibility.size());
    for (const auto& [other, weight] : kf->covisibility) {
      out.i64(other);
      out.i32(weight);
    }
  }
  end_section(out, at);
}

}  // namespace

std::vector<std::uint8_t> encode_map(const map::MapData& map, const MapFileMeta& meta) {
  const auto keyframes = by_id(map.keyframes());
  std::vector<const map::MapPoint*> points = by_id(map.points());
  std::erase_if(points, [](const map::MapPoint* p) { return p->bad; });
  ByteWriter out;
  out.raw(std::vector<std::uint8_t>(kHeaderBytes, 0));
  write_meta(out, map, meta);
  write_keyframes(out, keyframes);
  write_points(out, points);
  write_covisibility(out, keyframes);
  write_frame_header(map_file_kind(), out.bytes());
  return std::move(out.bytes());
}

}  // namespace sitepose::mapfile
