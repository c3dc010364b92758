#pragma once
// Place recognition for relocalisation: which keyframes of the whole map
// look like the current frame.
//
// The default when no vocabulary is given (placerec's keyframe database
// replaces it with one: SlamOptions::vocabulary, `run --vocabulary`;
// docs/placerec/README.md compares the two). Each query descriptor votes for every
// keyframe that observes its nearest good map point, when that point is
// within kDescriptorDistanceLow bits and clearly nearer than the second
// nearest: an exact nearest-neighbour vote over all map points, with no
// quantisation error, no training and no database for the mapper to keep in
// step. Size: the snapshot holds 32 bytes plus the observing keyframe ids
// per good point (a 20 000-point map: ~0.8 MB, copied under the read lock).
// Query cost: max_query_descriptors x points Hamming distances (300 x
// 20 000 = 6 M, ~30 ms on one core), paid only while tracking is LOST; it
// grows with the map, so the vocabulary is the step when site maps reach
// ~10^5 points. Pure functions; the caller takes the map lock.

#include <vector>

#include <opencv2/core.hpp>

#include "sitepose/map/map_data.hpp"

namespace sitepose::tracking {

// The good points of a map with their descriptors and observing keyframes
// (keyframes_of_point[offset[i] .. offset[i + 1]) for point i).
struct PlaceIndex {
  std::vector<map::Descriptor> descriptors;
  std::vector<std::size_t> offset{0};
  std::vector<map::KeyFrameId> keyframes;
};

struct PlaceQuery {
  int max_query_descriptors = 300;  // spread evenly over the usable keypoints
  int max_distance = 50;            // bits, ORB-SLAM2 TH_LOW
  double ratio = 0.9;               // nearest < ratio * second nearest
  int min_votes = 15;               // fewer cannot give a PnP solution
  double min_votes_of_best = 0.5;   // keep candidates with >= this share of the best's votes
  int max_candidates = 5;
};

struct PlaceCandidate {
  map::KeyFrameId keyframe = map::kNoKeyFrame;
  int votes = 0;
};

// Copies what a query needs; call under SharedMap::read(). only_before:
// the keyframes with smaller ids and their points only; kNoKeyFrame = all.
PlaceIndex make_place_index(const map::MapData& map, map::KeyFrameId only_before = map::kNoKeyFrame);

// Keyframes ranked by votes, best first (ties: the newer keyframe first),
// at most query.max_candidates of them. descriptors: N x 32 CV_8UC1;
// usable: per row, nonzero = may vote.
std::vector<PlaceCandidate> rank_places(const PlaceIndex& index, const cv::Mat& descriptors,
                                        const std::vector<std::uint8_t>& usable,
                                        const PlaceQuery& query = {});

}  // namespace sitepose::tracking
