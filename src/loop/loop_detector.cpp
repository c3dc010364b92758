#include "sitepose/loop/loop_detector.hpp"

#include <algorithm>

namespace sitepose::loop {
namespace {

bool intersects(const std::set<map::KeyFrameId>& a, const std::set<map::KeyFrameId>& b) {
  auto i = a.begin();
  auto j = b.begin();
  while (i != a.end() && j != b.end()) {
    if (*i == *j) return true;
    if (*i < *j) {
      ++i;
    } else {
      ++j;
    }
  }
  return false;
}

}  // namespace

std::vector<map::KeyFrameId> LoopConsistency::update(const std::vector<CandidateGroup>& candidates) {
  std::vector<Group> current;
  std::vector<map::KeyFrameId> consistent;
  std::vector<bool> taken(previous_.size(), false);
  for (const CandidateGroup& c : candidates) {
    bool enough = false;
    bool continues_some = false;
    for (std::size_t g = 0; g < previous_.size(); ++g) {
      if (!intersects(c.group, previous_[g].keyframes)) continue;
      continues_some = true;
      const int count = previous_[g].count + 1;
      // A previous group passes its count on once.
      if (!taken[g]) {
        current.push_back({c.group, count});
        taken[g] = true;
      }
      if (count >= required_ && !enough) {
        consistent.push_back(c.candidate);
        enough = true;
      }
    }
    if (!continues_some) current.push_back({c.group, 0});
  }
  previous_ = std::move(current);
  return consistent;
}

double min_covisible_score(const placerec::KeyFrameDatabase& database, const placerec::BowVector& bow,
                           const std::vector<map::KeyFrameId>& covisible) {
  double min_score = 1.0;
  for (map::KeyFrameId id : covisible) {
    const placerec::BowVector other = database.bow(id);
    if (other.empty()) continue;
    min_score = std::min(min_score, placerec::score_l1(bow, other));
  }
  return min_score;
}

}  // namespace sitepose::loop
