#pragma once
// The keyframe database (ORB-SLAM2 KeyFrameDatabase, written for sitepose):
// the bag of words of each keyframe and an inverted index word -> keyframes.
// The local mapper adds a keyframe when it has processed it and erases it
// when it culls it; relocalisation (and later loop detection) queries it.
//
// Query (ORB-SLAM2 DetectRelocalizationCandidates):
//   1. the keyframes sharing a word with the query, and how many words;
//   2. of those sharing more than 0.8 of the most shared words, the L1 score;
//   3. per scored keyframe, the scores of its best 10 covisible keyframes
//      (those scored) added up; the best-scoring keyframe of each group
//      whose sum exceeds 0.75 of the best sum is a candidate.
// Steps 1-2 run under the database's mutex (score()); step 3 needs the
// covisibility and runs on what score() returned, under the map's read lock
// (group_candidates()), so the two locks are never held together.
//
// Thread: every member may be called from any thread; the mutex is a leaf
// lock (nothing else is locked while it is held).

#include <functional>
#include <memory>
#include <mutex>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "sitepose/map/shared_map.hpp"
#include "sitepose/placerec/vocabulary.hpp"

namespace sitepose::placerec {

struct ScoredKeyFrame {
  map::KeyFrameId keyframe = map::kNoKeyFrame;
  int shared_words = 0;
  double score = 0.0;  // L1 score with the query
};

struct CandidateQuery {
  double min_shared_words_of_best = 0.8;  // ORB-SLAM2: 0.8 x the most shared words
  int covisible_neighbours = 10;          // ORB-SLAM2 GetBestCovisibilityKeyFrames(10)
  double min_group_score_of_best = 0.75;  // ORB-SLAM2: 0.75 x the best accumulated score
};

struct PlaceCandidateGroup {
  map::KeyFrameId keyframe = map::kNoKeyFrame;  // the best-scoring keyframe of the group
  double group_score = 0.0;                     // the group's accumulated score
};

class KeyFrameDatabase {
 public:
  explicit KeyFrameDatabase(std::shared_ptr<const Vocabulary> vocabulary);

  const Vocabulary& vocabulary() const { return *vocabulary_; }

  // Adds (or replaces) a keyframe with the bag of words of its descriptors.
  void add(map::KeyFrameId keyframe, const std::vector<map::Descriptor>& descriptors);
  void add(map::KeyFrameId keyframe, BowVector bow);
  void erase(map::KeyFrameId keyframe);
  void clear();
  // Every good keyframe of `map`, replacing what was there (a loaded map;
  // not one under SharedMap's lock, which is a leaf lock).
  void rebuild(const map::MapData& map);

  std::size_t size() const;
  bool contains(map::KeyFrameId keyframe) const;
  // Steps 1-2 of the query, sorted by keyframe id.
  std::vector<ScoredKeyFrame> score(const BowVector& query, const CandidateQuery& params = {}) const;
  // Steps 1-2 for loop detection (ORB-SLAM2 DetectLoopCandidates): the
  // keyframes in `exclude` (the query keyframe and its covisible ones) are
  // left out before the most shared words are counted, and only scores
  // >= min_score are kept. Sorted by keyframe id.
  std::vector<ScoredKeyFrame> score_excluding(const BowVector& query,
                                              const std::unordered_set<map::KeyFrameId>& exclude,
                                              double min_score, const CandidateQuery& params = {}) const;
  // The stored bag of words of a keyframe; empty when it is not in the database.
  BowVector bow(map::KeyFrameId keyframe) const;

 private:
  std::shared_ptr<const Vocabulary> vocabulary_;
  mutable std::mutex mutex_;
  std::vector<std::vector<map::KeyFrameId>> inverted_;   // guarded by mutex_: word -> keyframes
  std::unordered_map<map::KeyFrameId, BowVector> bows_;  // guarded by mutex_
};

// Step 3 of the query; best group score first. covisible(id, n): the n best
// covisible keyframes of id.
std::vector<PlaceCandidateGroup> group_candidates(
    const std::vector<ScoredKeyFrame>& scored,
    const std::function<std::vector<map::KeyFrameId>(map::KeyFrameId, int)>& covisible,
    const CandidateQuery& params = {});

// The whole query for relocalisation: the usable rows of `descriptors`
// (N x 32 CV_8UC1) as a bag of words, scored in `database`, grouped by the
// covisibility of `map` (taken under its read lock), best first, at most
// max_candidates. only_before: only keyframes with smaller ids (the site map
// while a provisional map is tracked); kNoKeyFrame = all.
std::vector<map::KeyFrameId> relocalisation_candidates(const KeyFrameDatabase& database,
                                                       const map::SharedMap& map, const cv::Mat& descriptors,
                                                       const std::vector<std::uint8_t>& usable,
                                                       int max_candidates, const CandidateQuery& params = {},
                                                       map::KeyFrameId only_before = map::kNoKeyFrame);

}  // namespace sitepose::placerec
