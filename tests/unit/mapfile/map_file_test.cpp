#include "sitepose/mapfile/map_file.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <limits>
#include <set>
#include <string>
#include <tuple>

#include "map_fixture.hpp"
#include "sitepose/mapfile/atomic_file.hpp"
#include "sitepose/mapfile/byte_io.hpp"
#include "sitepose/mapfile/crc32.hpp"
#include "sitepose/testing/file_size_limit.hpp"
#include "sitepose/testing/files.hpp"
#include "sitepose/testing/framed_bytes.hpp"

namespace sitepose::mapfile {
namespace {

using Bytes = std::vector<std::uint8_t>;

Bytes read_bytes(const std::string& path) {
  const std::string text = testing::read_text(path);
  return Bytes(text.begin(), text.end());
}

MapFileMeta anchored_meta() {
  MapFileMeta meta;
  meta.vocabulary_id = "orb-km-6x10-test";
  SiteAnchorRecord anchor;
  anchor.latitude_deg = 47.3769;
  anchor.longitude_deg = 8.5417;
  anchor.height_m = 408.25;
  anchor.T_site_slam = SE3(so3_exp(Eigen::Vector3d(0.1, -0.2, 1.3)), Eigen::Vector3d(12.5, -3.0, 0.75));
  meta.anchor = anchor;
  return meta;
}

Bytes encoded_test_map(int keyframes = 8) {
  map::SharedMap shared;
  test::build_map(shared, keyframes);
  return shared.read([](const map::MapData& m) { return encode_map(m, anchored_meta()); });
}

std::string refusal(const Bytes& bytes) {
  auto loaded = decode_map(bytes);
  return loaded ? std::string("accepted") : loaded.error().message;
}

TEST(Crc32, MatchesTheStandardCheckValue) {
  const std::string text = "123456789";
  const Bytes bytes(text.begin(), text.end());
  EXPECT_EQ(crc32(bytes), 0xCBF43926U);
  // Continuing a checksum equals one pass over the whole.
  const std::span<const std::uint8_t> all(bytes);
  EXPECT_EQ(crc32(all.subspan(4), crc32(all.first(4))), 0xCBF43926U);
}

void expect_same_keyframes(const map::MapData& a, const map::MapData& b) {
  ASSERT_EQ(a.keyframe_count(), b.keyframe_count());
  for (const auto& [id, kf] : a.keyframes()) {
    const map::KeyFrame* other = b.keyframe(id);
    ASSERT_NE(other, nullptr) << id;
    EXPECT_EQ(other->frame_seq, kf.frame_seq);
    EXPECT_EQ(other->t_ns, kf.t_ns);
    EXPECT_EQ(other->T_world_cam.matrix(), kf.T_world_cam.matrix());
    EXPECT_EQ(other->parent, kf.parent);
    EXPECT_EQ(other->children, kf.children);
    EXPECT_EQ(other->covisibility, kf.covisibility);
    EXPECT_EQ(other->loop_edges, kf.loop_edges);
    EXPECT_EQ(other->map_travel_m, kf.map_travel_m);
    EXPECT_EQ(other->point_of_keypoint, kf.point_of_keypoint);
    ASSERT_EQ(other->keypoints.size(), kf.keypoints.size());
    for (std::size_t i = 0; i < kf.keypoints.size(); ++i) {
      const map::KeyPointData& p = kf.keypoints[i];
      const map::KeyPointData& q = other->keypoints[i];
      EXPECT_TRUE(p.uv_px == q.uv_px && p.octave == q.octave && p.u_right_px == q.u_right_px &&
                  p.depth_m == q.depth_m && p.descriptor == q.descriptor && p.instance == q.instance)
          << "keyframe " << id << " keypoint " << i;
    }
  }
}

void expect_same_points(const map::MapData& a, const map::MapData& b) {
  std::size_t good = 0;
  for (const auto& [id, p] : a.points()) {
    if (p.bad) {
      EXPECT_EQ(b.point(id), nullptr) << "bad point " << id << " was saved";
      continue;
    }
    ++good;
    const map::MapPoint* q = b.point(id);
    ASSERT_NE(q, nullptr) << id;
    EXPECT_EQ(q->p_world, p.p_world);
    EXPECT_EQ(q->descriptor, p.descriptor);
    EXPECT_EQ(q->normal, p.normal);
    EXPECT_EQ(q->min_distance_m, p.min_distance_m);
    EXPECT_EQ(q->max_distance_m, p.max_distance_m);
    EXPECT_EQ(q->observations, p.observations);
    EXPECT_EQ(q->reference_keyframe, p.reference_keyframe);
    EXPECT_EQ(q->first_keyframe, p.first_keyframe);
    EXPECT_EQ(q->n_visible, p.n_visible);
    EXPECT_EQ(q->n_found, p.n_found);
  }
  EXPECT_EQ(b.point_count(), good);
}

TEST(MapFile, RoundTripKeepsEveryField) {
  map::SharedMap shared;
  test::build_map(shared, 8);
  const Bytes bytes = shared.read([](const map::MapData& m) { return encode_map(m, anchored_meta()); });
  auto loaded = decode_map(bytes);
  ASSERT_TRUE(loaded) << loaded.error().message;
  EXPECT_EQ(loaded->version, kFormatVersion);
  EXPECT_EQ(loaded->meta.vocabulary_id, "orb-km-6x10-test");
  ASSERT_TRUE(loaded->meta.anchor.has_value());
  EXPECT_EQ(loaded->meta.anchor->latitude_deg, 47.3769);
  EXPECT_EQ(loaded->meta.anchor->height_m, 408.25);
  EXPECT_LT((loaded->meta.anchor->T_site_slam.matrix() - anchored_meta().anchor->T_site_slam.matrix()).norm(),
            1e-12);
  EXPECT_EQ(testing::check_consistency(loaded->map), "");
  shared.read([&](const map::MapData& m) {
    EXPECT_EQ(m.keyframe_count(), 7U);  // one culled
    EXPECT_EQ(loaded->map.first_keyframe(), m.first_keyframe());
    EXPECT_EQ(loaded->map.last_keyframe(), m.last_keyframe());
    EXPECT_EQ(loaded->map.pyramid().n_levels, m.pyramid().n_levels);
    expect_same_keyframes(m, loaded->map);
    expect_same_points(m, loaded->map);
  });
  // The file is a function of the map: saving the loaded map gives the same bytes.
  EXPECT_EQ(encode_map(loaded->map, loaded->meta), bytes);
}

// Loop edges go in the optional LOOP section: a map without loops has none
// (and reads as before), one with a loop keeps it.
TEST(MapFile, LoopEdgesRoundTripInTheirOwnSection) {
  map::SharedMap shared;
  test::build_map(shared, 8);
  const Bytes without = shared.read([](const map::MapData& m) { return encode_map(m, {}); });
  const std::uint32_t loop_tag = kLoopEdgesTag;
  const auto has_loop_section = [&](const Bytes& bytes) {
    return std::search(bytes.begin(), bytes.end(), reinterpret_cast<const std::uint8_t*>(&loop_tag),
                       reinterpret_cast<const std::uint8_t*>(&loop_tag) + 4) != bytes.end();
  };
  EXPECT_FALSE(has_loop_section(without));
  const auto [a, b] = shared.write([](map::MapData& m) {
    const map::KeyFrameId first = m.first_keyframe();
    const map::KeyFrameId last = m.last_keyframe();
    EXPECT_TRUE(m.add_loop_edge(last, first));
    return std::pair{first, last};
  });
  const Bytes with = shared.read([](const map::MapData& m) { return encode_map(m, {}); });
  EXPECT_TRUE(has_loop_section(with));
  auto loaded = decode_map(with);
  ASSERT_TRUE(loaded) << loaded.error().message;
  EXPECT_EQ(loaded->map.keyframe(a)->loop_edges, (std::set<map::KeyFrameId>{b}));
  EXPECT_EQ(loaded->map.keyframe(b)->loop_edges, (std::set<map::KeyFrameId>{a}));
  shared.read([&](const map::MapData& m) { expect_same_keyframes(m, loaded->map); });
  EXPECT_EQ(encode_map(loaded->map, loaded->meta), with);
}

// The keyframes' map travel (the published drift term's distance) goes in
// the optional TRVL section, written last. A file saved before it existed
// lacks it and is read with each keyframe's path along the spanning tree.
TEST(MapFile, MapTravelRoundTripsAndIsDerivedFromTheSpanningTreeWhenMissing) {
  map::SharedMap shared;
  test::build_map(shared, 8);
  Bytes bytes = shared.read([](const map::MapData& m) { return encode_map(m, {}); });
  const std::size_t keyframes = shared.read([](const map::MapData& m) { return m.keyframe_count(); });
  const std::size_t section_bytes = 12 + 8 + kMapTravelBytes * keyframes;
  ASSERT_GT(bytes.size(), kHeaderBytes + section_bytes);
  const std::size_t section_at = bytes.size() - section_bytes;
  const std::uint32_t tag = kMapTravelTag;
  ASSERT_TRUE(std::equal(bytes.begin() + section_at, bytes.begin() + section_at + 4,
                         reinterpret_cast<const std::uint8_t*>(&tag)))
      << "TRVL is not the last section";
  auto loaded = decode_map(bytes);
  ASSERT_TRUE(loaded) << loaded.error().message;
  EXPECT_EQ(loaded->map.keyframe(5)->map_travel_m, 0.75 * 5 + 0.125);

  bytes.resize(section_at);  // as saved before TRVL existed
  testing::refit_frame(bytes);
  auto old = decode_map(bytes);
  ASSERT_TRUE(old) << old.error().message;
  // The fixture drives along x from 0 in a chain of keyframes (keyframe 2
  // culled): the tree's path to each keyframe is its x.
  for (const auto& [id, kf] : old->map.keyframes()) {
    EXPECT_NEAR(kf.map_travel_m, kf.camera_center().x(), 1e-9) << "keyframe " << id;
  }
  EXPECT_EQ(old->map.keyframe(old->map.first_keyframe())->map_travel_m, 0.0);
}

// A provisional map is placed by dead reckoning: a file keeps the site map
// alone, and saving leaves the running map as it is.
TEST(MapFile, AProvisionalMapIsNotSaved) {
  map::SharedMap shared;
  test::build_map(shared, 11);
  constexpr map::KeyFrameId kFirstProvisional = 8;
  const auto [keyframes_before, site_keyframes, site_points] = shared.write([](map::MapData& m) {
    m.set_provisional_since(kFirstProvisional);
    std::size_t kfs = 0;
    for (const auto& [id, kf] : m.keyframes()) kfs += id < kFirstProvisional ? 1 : 0;
    // Points the site map keeps: untouched, or left with two views (a
    // point losing views below two becomes bad, MapData::erase_observation).
    std::set<map::PointId> points;
    for (const auto& [id, p] : m.points()) {
      int site_views = 0;
      int provisional_views = 0;
      for (const auto& [kf, index] : p.observations)
        (kf < kFirstProvisional ? site_views : provisional_views)++;
      if (!p.bad && site_views > 0 && (provisional_views == 0 || site_views >= 2)) points.insert(id);
    }
    return std::tuple{m.keyframe_count(), kfs, points};
  });
  ASSERT_GT(keyframes_before, site_keyframes);
  const Bytes bytes = shared.read([](const map::MapData& m) { return encode_map(m, {}); });
  auto loaded = decode_map(bytes);
  ASSERT_TRUE(loaded) << loaded.error().message;
  EXPECT_EQ(loaded->map.keyframe_count(), site_keyframes);
  for (const auto& [id, kf] : loaded->map.keyframes()) EXPECT_LT(id, kFirstProvisional);
  std::set<map::PointId> loaded_points;
  for (const auto& [id, p] : loaded->map.points()) loaded_points.insert(id);
  EXPECT_EQ(loaded_points, site_points) << "exactly the points the site map's keyframes observe";
  EXPECT_EQ(loaded->map.provisional_since(), map::kNoKeyFrame);
  shared.read([&](const map::MapData& m) {
    EXPECT_EQ(m.keyframe_count(), keyframes_before);
    EXPECT_EQ(m.provisional_since(), kFirstProvisional);
  });
}

// A provisional map joined to the site map stands where the join put it
// until a relocalisation hold confirms the join: not saved before that.
TEST(MapFile, AJoinedMapNotYetConfirmedIsNotSaved) {
  map::SharedMap shared;
  test::build_map(shared, 11);
  constexpr map::KeyFrameId kFirstJoined = 8;
  const auto [all_keyframes, site_keyframes] = shared.write([](map::MapData& m) {
    m.set_joined_unconfirmed_since(kFirstJoined);
    std::size_t site = 0;
    for (const auto& [id, kf] : m.keyframes()) site += id < kFirstJoined ? 1 : 0;
    return std::pair{m.keyframe_count(), site};
  });
  ASSERT_GT(all_keyframes, site_keyframes);
  const Bytes bytes = shared.read([](const map::MapData& m) { return encode_map(m, {}); });
  auto loaded = decode_map(bytes);
  ASSERT_TRUE(loaded) << loaded.error().message;
  EXPECT_EQ(loaded->map.keyframe_count(), site_keyframes);
  for (const auto& [id, kf] : loaded->map.keyframes()) EXPECT_LT(id, kFirstJoined);
  EXPECT_EQ(loaded->map.joined_unconfirmed_since(), map::kNoKeyFrame);
  shared.read([&](const map::MapData& m) {
    EXPECT_EQ(m.keyframe_count(), all_keyframes) << "the running map keeps them";
    EXPECT_EQ(m.joined_unconfirmed_since(), kFirstJoined);
  });
  // Confirmed, they are saved.
  shared.write([](map::MapData& m) { m.set_joined_unconfirmed_since(map::kNoKeyFrame); });
  auto confirmed = decode_map(shared.read([](const map::MapData& m) { return encode_map(m, {}); }));
  ASSERT_TRUE(confirmed) << confirmed.error().message;
  EXPECT_EQ(confirmed->map.keyframe_count(), all_keyframes);
}

// Both marks at once (a provisional map begun after a join not yet
// confirmed; the tracker drops such a join when lost, so this is the
// encoder's own contract): nothing from the earlier mark on is saved.
TEST(MapFile, WithBothMarksNothingFromTheEarlierOneIsSaved) {
  map::SharedMap shared;
  test::build_map(shared, 11);
  constexpr map::KeyFrameId kFirstJoined = 6;
  constexpr map::KeyFrameId kFirstProvisional = 9;
  shared.write([](map::MapData& m) {
    m.set_joined_unconfirmed_since(kFirstJoined);
    m.set_provisional_since(kFirstProvisional);
  });
  auto loaded = decode_map(shared.read([](const map::MapData& m) { return encode_map(m, {}); }));
  ASSERT_TRUE(loaded) << loaded.error().message;
  ASSERT_GT(loaded->map.keyframe_count(), 0u);
  for (const auto& [id, kf] : loaded->map.keyframes()) EXPECT_LT(id, kFirstJoined);
}

TEST(MapFile, LoadedMapGrowsWithFreshIds) {
  map::SharedMap shared;
  test::build_map(shared, 5);
  const Bytes bytes = shared.read([](const map::MapData& m) { return encode_map(m, {}); });
  auto loaded = decode_map(bytes);
  ASSERT_TRUE(loaded) << loaded.error().message;
  EXPECT_FALSE(loaded->meta.anchor.has_value());
  EXPECT_EQ(loaded->meta.vocabulary_id, "");
  map::MapData& m = loaded->map;
  std::int64_t max_id = -1;
  for (const auto& [existing, p] : m.points()) max_id = std::max(max_id, existing);
  map::KeyFrame kf;
  kf.keypoints.resize(3);
  const map::KeyFrameId id = m.add_keyframe(kf);
  EXPECT_EQ(id, 5);
  const map::PointId pid = m.add_point(Eigen::Vector3d(1, 2, 10), id, 0);
  EXPECT_EQ(pid, max_id + 1);
  EXPECT_EQ(m.last_keyframe(), id);
}

TEST(MapFile, EmptyMapRoundTrips) {
  const Bytes bytes = encode_map(map::MapData{}, {});
  auto loaded = decode_map(bytes);
  ASSERT_TRUE(loaded) << loaded.error().message;
  EXPECT_EQ(loaded->map.keyframe_count(), 0U);
  EXPECT_EQ(loaded->map.first_keyframe(), map::kNoKeyFrame);
}

TEST(MapFile, TruncatedFileIsRefused) {
  const Bytes bytes = encoded_test_map();
  for (const std::size_t size : {std::size_t{0}, std::size_t{10}, kHeaderBytes - 1, kHeaderBytes,
                                 kHeaderBytes + 7, bytes.size() / 2, bytes.size() - 1}) {
    const std::string why = refusal(Bytes(bytes.begin(), bytes.begin() + static_cast<long>(size)));
    EXPECT_NE(why.find("truncated"), std::string::npos) << size << ": " << why;
  }
  Bytes longer = bytes;
  longer.push_back(0);
  EXPECT_NE(refusal(longer).find("after the announced end"), std::string::npos) << refusal(longer);
}

TEST(MapFile, FlippedBitIsRefused) {
  const Bytes bytes = encoded_test_map();
  // Every part of the payload, and the header.
  for (const std::size_t at :
       {kHeaderBytes, kHeaderBytes + 13, bytes.size() / 3, bytes.size() / 2, bytes.size() - 1}) {
    Bytes flipped = bytes;
    flipped[at] ^= 0x10;
    const std::string why = refusal(flipped);
    EXPECT_NE(why.find("payload checksum mismatch"), std::string::npos) << at << ": " << why;
  }
  for (const std::size_t at : {std::size_t{16}, std::size_t{24}, std::size_t{29}}) {
    Bytes flipped = bytes;
    flipped[at] ^= 0x01;
    const std::string why = refusal(flipped);
    EXPECT_NE(why.find("checksum"), std::string::npos) << at << ": " << why;
  }
  Bytes magic = bytes;
  magic[0] = 'X';
  EXPECT_NE(refusal(magic).find("not a sitepose map file"), std::string::npos) << refusal(magic);
}

TEST(MapFile, WrongVersionIsRefused) {
  Bytes bytes = encoded_test_map();
  bytes[8] = 2;  // version, with a header checksum that matches it
  testing::refit_frame(bytes);
  EXPECT_NE(refusal(bytes).find("format version 2, this build reads version 1"), std::string::npos)
      << refusal(bytes);
}

// The first point of the map that is not bad: the one a test changes.
map::MapPoint* first_good_point(map::MapData& m) {
  for (auto& [id, p] : m.points()) {
    if (!p.bad) return m.point(id);
  }
  return nullptr;
}

// The map the test changes one field of, encoded.
template <typename Change>
Bytes encoded_changed_map(Change change, const MapFileMeta& meta = anchored_meta()) {
  map::SharedMap shared;
  test::build_map(shared, 4);
  shared.write(change);
  return shared.read([&](const map::MapData& m) { return encode_map(m, meta); });
}

// Found by fuzzing (tests/fuzz/corpus/map_file/octave_off_pyramid,
// infinite_pose): values the bounds checks let through.
TEST(MapFile, KeypointOffThePyramidIsRefused) {
  const Bytes bytes = encoded_changed_map(
      [](map::MapData& m) { m.keyframe(1)->keypoints.at(3).octave = m.pyramid().n_levels; });
  EXPECT_NE(refusal(bytes).find("keyframe 1: keypoint 3 is on level 8, the pyramid has 8"), std::string::npos)
      << refusal(bytes);
}

TEST(MapFile, NonFiniteValuesAreRefused) {
  const double inf = std::numeric_limits<double>::infinity();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(refusal(encoded_changed_map([&](map::MapData& m) {
              m.keyframe(1)->T_world_cam = SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(inf, 0, 0));
            })).find("keyframe 1: the pose is not finite"),
            std::string::npos);
  EXPECT_NE(refusal(encoded_changed_map([&](map::MapData& m) {
              m.keyframe(0)->keypoints.at(0).depth_m = nan;
            })).find("keyframe 0: keypoint 0 is not finite"),
            std::string::npos);
  EXPECT_NE(refusal(encoded_changed_map([&](map::MapData& m) {
              first_good_point(m)->p_world.y() = nan;
            })).find("position, normal or scale range is not finite"),
            std::string::npos);
  MapFileMeta meta = anchored_meta();
  meta.anchor->height_m = inf;
  EXPECT_NE(refusal(encoded_changed_map([](map::MapData&) {}, meta)).find("the site anchor is not finite"),
            std::string::npos);
}

// A point never seen would give found_ratio() 0 / 0, which the mapper's
// culling reads.
TEST(MapFile, PointNeverSeenIsRefused) {
  EXPECT_NE(refusal(encoded_changed_map([&](map::MapData& m) {
              first_good_point(m)->n_visible = 0;
            })).find("seen 0 and found"),
            std::string::npos);
  EXPECT_NE(refusal(encoded_changed_map([&](map::MapData& m) {
              first_good_point(m)->n_found = -1;
            })).find("found -1 times"),
            std::string::npos);
}

TEST(MapFile, MapTravelThatIsNoDistanceIsRefused) {
  for (const double travel_m : {-1.0, std::numeric_limits<double>::quiet_NaN(), 2e9}) {
    const Bytes bytes = encoded_changed_map([&](map::MapData& m) { m.keyframe(1)->map_travel_m = travel_m; });
    EXPECT_NE(
        refusal(bytes).find("section TRVL: keyframe 1's map travel is negative, not finite or beyond 1e9 m"),
        std::string::npos)
        << travel_m << ": " << refusal(bytes);
  }
}

// Found by fuzzing (corpus/map_file/far_keyframe): a keyframe 1e236 m
// away is finite, but the path length to it is not.
TEST(MapFile, CoordinatesBeyondAnySiteAreRefused) {
  EXPECT_NE(refusal(encoded_changed_map([](map::MapData& m) {
              m.keyframe(3)->T_world_cam = SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, -1e236, 0));
            })).find("keyframe 3: the pose is not finite (or beyond 1e9 m)"),
            std::string::npos);
  EXPECT_NE(refusal(encoded_changed_map([](map::MapData& m) {
              first_good_point(m)->p_world.z() = 2e9;
            })).find("position, normal or scale range is not finite (or beyond 1e9 m)"),
            std::string::npos);
  EXPECT_EQ(refusal(encoded_changed_map([](map::MapData& m) {
              m.keyframe(3)->T_world_cam = SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, -1e9, 0));
            })),
            "accepted");
}

// Found by fuzzing (corpus/map_file/anchor_quaternion_overflow): a
// component near 1e268 overflows the norm, and the normalised rotation
// came out as the zero quaternion.
TEST(MapFile, QuaternionWhoseNormOverflowsIsRefused) {
  ByteWriter out;
  out.pose(SE3());
  for (const double huge : {8.25e268, 1e300, std::numeric_limits<double>::max()}) {
    Bytes bytes = out.bytes();
    for (int i = 0; i < 8; ++i)
      bytes[16 + i] = static_cast<std::uint8_t>(std::bit_cast<std::uint64_t>(huge) >> (8 * i));
    ByteReader in(bytes);
    in.pose();
    EXPECT_FALSE(in.ok()) << huge;
  }
  ByteReader fine(out.bytes());
  EXPECT_TRUE(fine.pose().rotation().isApprox(Eigen::Quaterniond::Identity()));
  EXPECT_TRUE(fine.ok());
}

TEST(MapFile, SaveReplacesAndLoadNamesTheFile) {
  testing::TempDir dir;
  const std::string path = dir / "site.map";
  auto missing = load_map(path);
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().code, ErrorCode::kNotFound);

  map::SharedMap small;
  test::build_map(small, 4);
  ASSERT_TRUE(small.read([&](const map::MapData& m) { return save_map(path, m, {}); }));
  map::SharedMap large;
  test::build_map(large, 9);
  ASSERT_TRUE(large.read([&](const map::MapData& m) { return save_map(path, m, anchored_meta()); }));
  auto loaded = load_map(path);
  ASSERT_TRUE(loaded) << loaded.error().message;
  EXPECT_EQ(loaded->map.keyframe_count(), 8U);
  const MapSummary summary = summarise(*loaded, std::filesystem::file_size(path));
  EXPECT_EQ(summary.keyframes, 8U);
  EXPECT_NEAR(summary.centre_max_m.x() - summary.centre_min_m.x(), 4.0, 1e-9);
  EXPECT_NEAR(summary.path_length_m, 4.0, 1e-9);
  EXPECT_GT(summary.covisibility_edges, 0U);
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path()), {}), 1) << "a temp file is left";

  // A corrupt file is refused with its path in the message, and left as it is.
  Bytes bytes = read_bytes(path);
  bytes[bytes.size() / 2] ^= 0xFF;
  testing::write_file(path, std::string(bytes.begin(), bytes.end()));
  auto corrupt = load_map(path);
  ASSERT_FALSE(corrupt);
  EXPECT_EQ(corrupt.error().code, ErrorCode::kParseError);
  EXPECT_NE(corrupt.error().message.find(path), std::string::npos);
  EXPECT_EQ(read_bytes(path), bytes);
}

TEST(MapFile, FailedSaveLeavesTheOldFile) {
  testing::TempDir dir;
  const std::string path = dir / "site.map";
  map::SharedMap old_map;
  test::build_map(old_map, 3);
  ASSERT_TRUE(old_map.read([&](const map::MapData& m) { return save_map(path, m, {}); }));
  const Bytes old_bytes = read_bytes(path);
  map::SharedMap new_map;
  test::build_map(new_map, 10);
  {
    testing::FileSizeLimit disk_full(old_bytes.size() + 100);
    ASSERT_TRUE(disk_full.ok());
    const Status saved = new_map.read([&](const map::MapData& m) { return save_map(path, m, {}); });
    ASSERT_FALSE(saved);
    EXPECT_EQ(saved.error().code, ErrorCode::kIoError);
    EXPECT_NE(saved.error().message.find("cannot write"), std::string::npos) << saved.error().message;
  }
  EXPECT_EQ(read_bytes(path), old_bytes);
  EXPECT_TRUE(load_map(path));
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path()), {}), 1) << "the temp file is left";
}

TEST(MapFile, StaleTempOfADeadWriterIsRemoved) {
  testing::TempDir dir;
  const std::string path = dir / "site.map";
  // pid 2^22 + 1 is above Linux's pid_max limit: never a live process.
  const std::string stale = dir.write("site.map.tmp-4194305", "half a map");
  const std::string live = dir.write("site.map.tmp-" + std::to_string(::getppid()), "another writer");
  ASSERT_TRUE(write_file_atomically(path, Bytes{1, 2, 3}));
  EXPECT_FALSE(std::filesystem::exists(stale));
  EXPECT_TRUE(std::filesystem::exists(live));
  EXPECT_EQ(read_bytes(path), (Bytes{1, 2, 3}));
}

}  // namespace
}  // namespace sitepose::mapfile
