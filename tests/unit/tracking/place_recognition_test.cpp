#include "sitepose/tracking/place_recognition.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <random>

namespace sitepose::tracking {
namespace {

// A map of `n_keyframes` keyframes, each with its own 100 points of random
// descriptors (seen by that keyframe only).
map::MapData map_of_places(int n_keyframes, std::mt19937& rng) {
  map::MapData map;
  std::uniform_int_distribution<int> byte(0, 255);
  for (int k = 0; k < n_keyframes; ++k) {
    map::KeyFrame kf;
    kf.keypoints.resize(100);
    kf.point_of_keypoint.assign(100, map::kNoPoint);
    for (auto& kp : kf.keypoints) {
      for (auto& b : kp.descriptor) b = static_cast<std::uint8_t>(byte(rng));
    }
    const map::KeyFrameId id = map.add_keyframe(std::move(kf));
    for (int i = 0; i < 100; ++i) map.add_point(Eigen::Vector3d(k, i, 10.0), id, i);
  }
  return map;
}

// Rows: the descriptors of keyframe `id`'s first n keypoints, each with
// `flipped_bits` bits changed (another view of the same place).
cv::Mat view_of(const map::MapData& map, map::KeyFrameId id, int n, int flipped_bits, std::mt19937& rng) {
  cv::Mat rows(n, 32, CV_8UC1);
  std::uniform_int_distribution<int> bit(0, 255);
  const map::KeyFrame* kf = map.keyframe(id);
  for (int i = 0; i < n; ++i) {
    map::Descriptor d = kf->keypoints[i].descriptor;
    for (int f = 0; f < flipped_bits; ++f) {
      const int b = bit(rng);
      d[b / 8] ^= static_cast<std::uint8_t>(1u << (b % 8));
    }
    std::copy(d.begin(), d.end(), rows.ptr<std::uint8_t>(i));
  }
  return rows;
}

TEST(PlaceRecognition, RanksTheKeyframeOfTheSamePlaceFirst) {
  std::mt19937 rng(7);
  const map::MapData map = map_of_places(12, rng);
  const PlaceIndex index = make_place_index(map);
  EXPECT_EQ(index.descriptors.size(), 12u * 100u);
  for (map::KeyFrameId id : {map::KeyFrameId{0}, map::KeyFrameId{5}, map::KeyFrameId{11}}) {
    const cv::Mat query = view_of(map, id, 80, 20, rng);
    const std::vector<PlaceCandidate> ranked = rank_places(index, query, std::vector<std::uint8_t>(80, 1));
    ASSERT_FALSE(ranked.empty()) << "keyframe " << id;
    EXPECT_EQ(ranked.front().keyframe, id);
    EXPECT_GE(ranked.front().votes, 70);  // 20 flipped bits stay within 50 of the original
    EXPECT_EQ(ranked.size(), 1u) << "no other keyframe shares descriptors with it";
  }
}

TEST(PlaceRecognition, UnknownPlacesAndUnusableKeypointsGiveNoCandidate) {
  std::mt19937 rng(8);
  const map::MapData map = map_of_places(6, rng);
  const PlaceIndex index = make_place_index(map);
  cv::Mat unknown(80, 32, CV_8UC1);
  cv::randu(unknown, 0, 256);
  EXPECT_TRUE(rank_places(index, unknown, std::vector<std::uint8_t>(80, 1)).empty());
  const cv::Mat known = view_of(map, 3, 80, 10, rng);
  EXPECT_TRUE(rank_places(index, known, std::vector<std::uint8_t>(80, 0)).empty());
  EXPECT_TRUE(rank_places(PlaceIndex{}, known, std::vector<std::uint8_t>(80, 1)).empty());
}

// The size and query cost the header states, on a 20 000-point map.
TEST(PlaceRecognition, FindsThePlaceInATwentyThousandPointMap) {
  std::mt19937 rng(10);
  const map::MapData map = map_of_places(200, rng);
  const PlaceIndex index = make_place_index(map);
  const cv::Mat query = view_of(map, 123, 100, 25, rng);
  const auto start = std::chrono::steady_clock::now();
  const std::vector<PlaceCandidate> ranked = rank_places(index, query, std::vector<std::uint8_t>(100, 1));
  const double query_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  std::printf("place index: %zu points, %.2f MB; query of 100 descriptors: %.1f ms\n",
              index.descriptors.size(),
              (index.descriptors.size() * sizeof(map::Descriptor) +
               index.keyframes.size() * sizeof(map::KeyFrameId) + index.offset.size() * sizeof(std::size_t)) /
                  1e6,
              query_ms);
  ASSERT_FALSE(ranked.empty());
  EXPECT_EQ(ranked.front().keyframe, 123);
}

TEST(PlaceRecognition, QueryBudgetCapsTheVotes) {
  std::mt19937 rng(9);
  const map::MapData map = map_of_places(4, rng);
  const cv::Mat query = view_of(map, 2, 100, 5, rng);
  PlaceQuery capped;
  capped.max_query_descriptors = 30;
  const std::vector<PlaceCandidate> ranked =
      rank_places(make_place_index(map), query, std::vector<std::uint8_t>(100, 1), capped);
  ASSERT_EQ(ranked.size(), 1u);
  EXPECT_EQ(ranked.front().keyframe, 2);
  EXPECT_EQ(ranked.front().votes, 30);
}

}  // namespace
}  // namespace sitepose::tracking
