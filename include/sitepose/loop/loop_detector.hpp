#pragma once
// Loop detection (ORB-SLAM2 LoopClosing::DetectLoop and KeyFrameDatabase::
// DetectLoopCandidates, written for sitepose).
//
// Candidates of a keyframe K: min_score (min_covisible_score) is the lowest
// L1 score between K's bag of words and those of its covisible keyframes
// (a loop must look at least as much like K as its neighbours do); the
// database is asked for keyframes sharing words with K, its covisible
// keyframes left out, keeping scores >= min_score
// (KeyFrameDatabase::score_excluding); those are grouped by covisibility as
// for relocalisation (placerec::group_candidates). The two steps take the
// database's lock and the map's in turn, never together.
//
// Consistency (LoopConsistency): a candidate's group is the candidate and
// its covisible keyframes. A group that shares a keyframe with a group kept
// for the previous keyframe inherits its count + 1, else starts at 0; a
// candidate whose group reaches `required` (ORB-SLAM2: 3) is consistent,
// i.e. the same place was proposed for `required` keyframes in a row.
//
// Thread-safety: LoopConsistency is owned by one thread (the loop closer's).

#include <functional>
#include <set>
#include <unordered_set>
#include <vector>

#include "sitepose/map/map_types.hpp"
#include "sitepose/placerec/keyframe_database.hpp"

namespace sitepose::loop {

struct CandidateGroup {
  map::KeyFrameId candidate = map::kNoKeyFrame;
  std::set<map::KeyFrameId> group;  // the candidate and its covisible keyframes
};

class LoopConsistency {
 public:
  explicit LoopConsistency(int required = 3) : required_(required) {}

  // The candidates of the next keyframe; returns those now consistent.
  std::vector<map::KeyFrameId> update(const std::vector<CandidateGroup>& candidates);
  // Forgets every group (after a loop is closed, ORB-SLAM2 too).
  void reset() { previous_.clear(); }
  std::size_t groups() const { return previous_.size(); }

 private:
  struct Group {
    std::set<map::KeyFrameId> keyframes;
    int count = 0;
  };
  int required_;
  std::vector<Group> previous_;
};

// The lowest score between `bow` and the bags of words of `covisible`
// (those in the database); 1 when none is there (then nothing qualifies).
double min_covisible_score(const placerec::KeyFrameDatabase& database, const placerec::BowVector& bow,
                           const std::vector<map::KeyFrameId>& covisible);

}  // namespace sitepose::loop
