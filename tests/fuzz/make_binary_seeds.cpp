// Writes the seed corpora of the binary-file harnesses (map_file,
// vocabulary): a small valid file of each, one cut short, one of another
// format version, so the seeds stay a few kB (run once; the output is
// committed under tests/fuzz/corpus):
//   fuzz_make_binary_seeds tests/fuzz/corpus
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>

#include "sitepose/mapfile/byte_io.hpp"
#include "sitepose/mapfile/map_file.hpp"
#include "sitepose/placerec/vocabulary.hpp"
#include "sitepose/testing/framed_bytes.hpp"

namespace {

using namespace sitepose;
using Bytes = std::vector<std::uint8_t>;

void write(const std::filesystem::path& path, const Bytes& bytes) {
  std::filesystem::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  std::printf("%s: %zu bytes\n", path.c_str(), bytes.size());
}

// The same file claiming another format version (header checksum fitting).
Bytes other_version(Bytes bytes) {
  bytes[8] = 2;
  testing::refit_frame(bytes);
  return bytes;
}

// A map file as saved before the optional TRVL section existed (it is
// written last): read with distances derived from the spanning tree.
Bytes without_map_travel(Bytes bytes, std::size_t keyframes) {
  bytes.resize(bytes.size() - (12 + 8 + mapfile::kMapTravelBytes * keyframes));
  testing::refit_frame(bytes);
  return bytes;
}

Bytes cut(const Bytes& bytes) {
  return Bytes(bytes.begin(), bytes.begin() + static_cast<long>(bytes.size() / 2));
}

map::Descriptor random_descriptor(std::mt19937& rng) {
  map::Descriptor d;
  for (auto& b : d) b = static_cast<std::uint8_t>(rng() & 0xFFU);
  return d;
}

// Three keyframes of six keypoints, five points seen from two or three of
// them, a spanning tree, map travel, covisibility and an anchor; with_loop_edge joins
// keyframes 0 and 2 by a loop edge (the file's optional LOOP section).
Bytes small_map(bool with_loop_edge) {
  std::mt19937 rng(7);
  map::MapData m;
  for (int k = 0; k < 3; ++k) {
    map::KeyFrame kf;
    kf.frame_seq = 10 * k;
    kf.t_ns = 100'000'000LL * k;
    kf.T_world_cam = SE3(so3_exp(Eigen::Vector3d(0.0, 0.05 * k, 0.0)), Eigen::Vector3d(0.5 * k, 0.0, 0.0));
    for (int i = 0; i < 6; ++i) {
      map::KeyPointData kp;
      kp.uv_px = Eigen::Vector2d(100.0 + 50 * i, 200.0 - 10 * k);
      kp.octave = i % 3;
      kp.u_right_px = i % 2 == 0 ? kp.uv_px.x() - 20.0 : -1.0;
      kp.depth_m = i % 2 == 0 ? 5.0 + i : -1.0;
      kp.descriptor = random_descriptor(rng);
      kp.instance = i == 5 ? 3 : 0;
      kf.keypoints.push_back(kp);
    }
    kf.map_travel_m = 0.5 * k;
    const map::KeyFrameId id = m.add_keyframe(kf);
    if (id > 0) m.keyframe(id)->parent = id - 1;
  }
  for (int i = 0; i < 5; ++i) {
    const map::PointId pid = m.add_point(Eigen::Vector3d(0.3 * i, -0.2, 5.0 + i), 0, i);
    m.add_observation(pid, 1, i);
    if (i % 2 == 0) m.add_observation(pid, 2, i + 1);
    m.update_point_appearance(pid);
  }
  for (map::KeyFrameId a = 0; a < 3; ++a) {
    for (map::KeyFrameId b = 0; b < 3; ++b) {
      if (a != b) m.keyframe(a)->covisibility[b] = 3;
    }
  }
  if (with_loop_edge) m.add_loop_edge(0, 2);
  mapfile::MapFileMeta meta;
  meta.vocabulary_id = "orb-kmajority-2x2-test";
  mapfile::SiteAnchorRecord anchor;
  anchor.latitude_deg = 47.3769;
  anchor.longitude_deg = 8.5417;
  anchor.height_m = 408.25;
  anchor.T_site_slam = SE3(so3_exp(Eigen::Vector3d(0.0, 0.0, 1.3)), Eigen::Vector3d(12.5, -3.0, 0.75));
  meta.anchor = anchor;
  auto restored = mapfile::decode_map(mapfile::encode_map(m, meta));
  if (!restored) {
    std::fprintf(stderr, "the small map does not load: %s\n", restored.error().message.c_str());
    std::exit(1);
  }
  return mapfile::encode_map(m, meta);
}

Bytes tiny_vocabulary() {
  std::mt19937 rng(3);
  std::vector<cv::Mat> images;
  for (int image = 0; image < 3; ++image) {
    cv::Mat d(6, 32, CV_8UC1);
    for (int r = 0; r < d.rows; ++r) {
      const map::Descriptor row = random_descriptor(rng);
      std::copy(row.begin(), row.end(), d.ptr<std::uint8_t>(r));
    }
    images.push_back(d);
  }
  placerec::VocabularyParams params;
  params.branching = 2;
  params.levels = 2;
  auto v = placerec::Vocabulary::train(images, params);
  if (!v) {
    std::fprintf(stderr, "training failed: %s\n", v.error().message.c_str());
    std::exit(1);
  }
  return v->encode();
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: fuzz_make_binary_seeds CORPUS_DIR\n");
    return 2;
  }
  const std::filesystem::path corpus = argv[1];
  const Bytes map_bytes = small_map(false);
  write(corpus / "map_file" / "small_map", map_bytes);
  write(corpus / "map_file" / "small_map_loop_edge", small_map(true));
  write(corpus / "map_file" / "small_map_without_travel", without_map_travel(map_bytes, 3));
  write(corpus / "map_file" / "empty_map", mapfile::encode_map(map::MapData{}, {}));
  write(corpus / "map_file" / "truncated", cut(map_bytes));
  write(corpus / "map_file" / "version_2", other_version(map_bytes));
  const Bytes vocabulary = tiny_vocabulary();
  write(corpus / "vocabulary" / "k2_l2", vocabulary);
  write(corpus / "vocabulary" / "truncated", cut(vocabulary));
  write(corpus / "vocabulary" / "version_2", other_version(vocabulary));
  return 0;
}
