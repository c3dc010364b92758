#include "sitepose/tracking/place_recognition.hpp"

#include <algorithm>
#include <map>

#include "sitepose/features/hamming.hpp"

namespace sitepose::tracking {

PlaceIndex make_place_index(const map::MapData& map, map::KeyFrameId only_before) {
  const auto included = [&](map::KeyFrameId id) {
    return only_before == map::kNoKeyFrame || id < only_before;
  };
  PlaceIndex index;
  index.descriptors.reserve(map.point_count());
  index.offset.reserve(map.point_count() + 1);
  for (const auto& [id, point] : map.points()) {
    if (point.bad || point.observations.empty() || !included(point.first_keyframe)) continue;
    index.descriptors.push_back(point.descriptor);
    for (const auto& [keyframe, keypoint] : point.observations) {
      if (included(keyframe)) index.keyframes.push_back(keyframe);
    }
    index.offset.push_back(index.keyframes.size());
  }
  return index;
}

std::vector<PlaceCandidate> rank_places(const PlaceIndex& index, const cv::Mat& descriptors,
                                        const std::vector<std::uint8_t>& usable, const PlaceQuery& query) {
  std::vector<int> rows;
  for (int r = 0; r < descriptors.rows && r < static_cast<int>(usable.size()); ++r) {
    if (usable[r]) rows.push_back(r);
  }
  // An even spread keeps every image region voting when the budget caps.
  const std::size_t n_query = std::min<std::size_t>(rows.size(), std::max(0, query.max_query_descriptors));
  const auto descriptor_of = [&](int i) { return index.descriptors[i].data(); };
  std::map<map::KeyFrameId, int> votes;
  for (std::size_t q = 0; q < n_query; ++q) {
    const int row = rows[q * rows.size() / n_query];
    const features::NearestTwo nearest = features::nearest_two(
        descriptors.ptr<std::uint8_t>(row), static_cast<int>(index.descriptors.size()), descriptor_of);
    if (nearest.index < 0 || nearest.distance > query.max_distance ||
        nearest.distance >= query.ratio * nearest.second_distance) {
      continue;
    }
    const auto i = static_cast<std::size_t>(nearest.index);
    for (std::size_t j = index.offset[i]; j < index.offset[i + 1]; ++j) ++votes[index.keyframes[j]];
  }
  std::vector<PlaceCandidate> ranked;
  ranked.reserve(votes.size());
  for (const auto& [keyframe, n] : votes) ranked.push_back({keyframe, n});
  std::sort(ranked.begin(), ranked.end(), [](const PlaceCandidate& a, const PlaceCandidate& b) {
    return a.votes != b.votes ? a.votes > b.votes : a.keyframe > b.keyframe;
  });
  if (ranked.empty()) return ranked;
  const double floor = std::max<double>(query.min_votes, query.min_votes_of_best * ranked.front().votes);
  std::erase_if(ranked, [&](const PlaceCandidate& c) { return c.votes < floor; });
  if (static_cast<int>(ranked.size()) > query.max_candidates)
    ranked.resize(std::max(0, query.max_candidates));
  return ranked;
}

}  // namespace sitepose::tracking
