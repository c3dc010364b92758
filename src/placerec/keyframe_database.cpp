#include "sitepose/placerec/keyframe_database.hpp"

#include <algorithm>
#include <limits>
#include <set>

namespace sitepose::placerec {

KeyFrameDatabase::KeyFrameDatabase(std::shared_ptr<const Vocabulary> vocabulary)
    : vocabulary_(std::move(vocabulary)), inverted_(vocabulary_->word_count()) {}

void KeyFrameDatabase::add(map::KeyFrameId keyframe, const std::vector<map::Descriptor>& descriptors) {
  add(keyframe, vocabulary_->transform(descriptors));  // the tree walk outside the lock
}

void KeyFrameDatabase::add(map::KeyFrameId keyframe, BowVector bow) {
  std::lock_guard lock(mutex_);
  if (auto it = bows_.find(keyframe); it != bows_.end()) {
    for (const BowEntry& e : it->second) std::erase(inverted_[e.word], keyframe);
  }
  for (const BowEntry& e : bow) {
    if (e.word < inverted_.size()) inverted_[e.word].push_back(keyframe);
  }
  bows_[keyframe] = std::move(bow);
}

void KeyFrameDatabase::erase(map::KeyFrameId keyframe) {
  std::lock_guard lock(mutex_);
  const auto it = bows_.find(keyframe);
  if (it == bows_.end()) return;
  for (const BowEntry& e : it->second) std::erase(inverted_[e.word], keyframe);
  bows_.erase(it);
}

void KeyFrameDatabase::clear() {
  std::lock_guard lock(mutex_);
  for (auto& list : inverted_) list.clear();
  bows_.clear();
}

void KeyFrameDatabase::rebuild(const map::MapData& map) {
  clear();
  for (const auto& [id, kf] : map.keyframes()) {
    if (kf.bad) continue;
    std::vector<map::Descriptor> descriptors;
    descriptors.reserve(kf.keypoints.size());
    for (const map::KeyPointData& k : kf.keypoints) descriptors.push_back(k.descriptor);
    add(id, descriptors);
  }
}

std::size_t KeyFrameDatabase::size() const {
  std::lock_guard lock(mutex_);
  return bows_.size();
}

bool KeyFrameDatabase::contains(map::KeyFrameId keyframe) const {
  std::lock_guard lock(mutex_);
  return bows_.count(keyframe) != 0;
}

std::vector<ScoredKeyFrame> KeyFrameDatabase::score(const BowVector& query,
                                                    const CandidateQuery& params) const {
  // Scores are finite (1 - half an L1 distance), so -inf keeps every one.
  return score_excluding(query, {}, -std::numeric_limits<double>::infinity(), params);
}

std::vector<ScoredKeyFrame> KeyFrameDatabase::score_excluding(
    const BowVector& query, const std::unordered_set<map::KeyFrameId>& exclude, double min_score,
    const CandidateQuery& params) const {
  std::lock_guard lock(mutex_);
  std::unordered_map<map::KeyFrameId, int> shared;
  for (const BowEntry& e : query) {
    if (e.word >= inverted_.size()) continue;
    for (map::KeyFrameId kf : inverted_[e.word]) {
      if (exclude.count(kf) == 0) ++shared[kf];
    }
  }
  int most = 0;
  for (const auto& [kf, n] : shared) most = std::max(most, n);
  const double min_shared = params.min_shared_words_of_best * most;
  std::vector<ScoredKeyFrame> out;
  for (const auto& [kf, n] : shared) {
    if (n <= min_shared && n < most) continue;
    const double s = score_l1(query, bows_.at(kf));
    if (s >= min_score) out.push_back({kf, n, s});
  }
  std::sort(out.begin(), out.end(),
            [](const ScoredKeyFrame& a, const ScoredKeyFrame& b) { return a.keyframe < b.keyframe; });
  return out;
}

BowVector KeyFrameDatabase::bow(map::KeyFrameId keyframe) const {
  std::lock_guard lock(mutex_);
  const auto it = bows_.find(keyframe);
  return it == bows_.end() ? BowVector{} : it->second;
}

std::vector<PlaceCandidateGroup> group_candidates(
    const std::vector<ScoredKeyFrame>& scored,
    const std::function<std::vector<map::KeyFrameId>(map::KeyFrameId, int)>& covisible,
    const CandidateQuery& params) {
  std::unordered_map<map::KeyFrameId, double> score_of;
  for (const ScoredKeyFrame& s : scored) score_of[s.keyframe] = s.score;
  std::vector<PlaceCandidateGroup> groups;
  double best_group = 0.0;
  for (const ScoredKeyFrame& s : scored) {
    PlaceCandidateGroup g{s.keyframe, s.score};
    double best = s.score;
    for (map::KeyFrameId n : covisible(s.keyframe, params.covisible_neighbours)) {
      const auto it = score_of.find(n);
      if (it == score_of.end()) continue;
      g.group_score += it->second;
      if (it->second > best) {
        best = it->second;
        g.keyframe = n;
      }
    }
    best_group = std::max(best_group, g.group_score);
    groups.push_back(g);
  }
  std::sort(groups.begin(), groups.end(), [](const PlaceCandidateGroup& a, const PlaceCandidateGroup& b) {
    return a.group_score != b.group_score ? a.group_score > b.group_score : a.keyframe > b.keyframe;
  });
  std::vector<PlaceCandidateGroup> out;
  std::set<map::KeyFrameId> seen;
  for (const PlaceCandidateGroup& g : groups) {
    if (g.group_score <= params.min_group_score_of_best * best_group) break;
    if (seen.insert(g.keyframe).second) out.push_back(g);
  }
  return out;
}

std::vector<map::KeyFrameId> relocalisation_candidates(const KeyFrameDatabase& database,
                                                       const map::SharedMap& map, const cv::Mat& descriptors,
                                                       const std::vector<std::uint8_t>& usable,
                                                       int max_candidates, const CandidateQuery& params,
                                                       map::KeyFrameId only_before) {
  const BowVector query = database.vocabulary().transform(descriptors, usable);
  // Left out before the most shared words are counted: the provisional map
  // sees the same place best and would push the site map's keyframes out.
  std::unordered_set<map::KeyFrameId> exclude;
  if (only_before != map::kNoKeyFrame) {
    map.read([&](const map::MapData& data) {
      for (const auto& [id, kf] : data.keyframes()) {
        if (id >= only_before) exclude.insert(id);
      }
    });
  }
  const std::vector<ScoredKeyFrame> scored =
      database.score_excluding(query, exclude, -std::numeric_limits<double>::infinity(), params);
  if (scored.empty()) return {};
  const std::vector<PlaceCandidateGroup> groups = map.read([&](const map::MapData& data) {
    return group_candidates(
        scored, [&](map::KeyFrameId id, int n) { return data.best_covisible(id, n); }, params);
  });
  std::vector<map::KeyFrameId> out;
  for (const PlaceCandidateGroup& g : groups) {
    if (static_cast<int>(out.size()) >= max_candidates) break;
    out.push_back(g.keyframe);
  }
  return out;
}

}  // namespace sitepose::placerec
