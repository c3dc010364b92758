#include "sitepose/placerec/vocabulary.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <random>

#include "sitepose/features/hamming.hpp"

namespace sitepose::placerec {
namespace {

using map::Descriptor;

// Per-bit majority of the members (ties give 0).
Descriptor majority(const std::vector<const std::uint8_t*>& descriptors,
                    const std::vector<std::uint32_t>& members) {
  std::array<std::uint32_t, 256> ones{};
  for (std::uint32_t m : members) {
    const std::uint8_t* d = descriptors[m];
    for (int byte = 0; byte < 32; ++byte) {
      for (int bit = 0; bit < 8; ++bit) ones[8 * byte + bit] += (d[byte] >> bit) & 1U;
    }
  }
  Descriptor centre{};
  for (int i = 0; i < 256; ++i) {
    if (2 * ones[i] > members.size()) centre[i / 8] |= static_cast<std::uint8_t>(1U << (i % 8));
  }
  return centre;
}

Descriptor copy_of(const std::uint8_t* d) {
  Descriptor out{};
  std::copy(d, d + 32, out.begin());
  return out;
}

// k-means++ seeding with Hamming distances (DBoW2's choice): each next
// centre drawn with probability proportional to its squared distance from
// the nearest centre so far. std::mt19937_64's raw output keeps the draw the
// same on every standard library.
std::vector<Descriptor> seed_centres(const std::vector<const std::uint8_t*>& descriptors,
                                     const std::vector<std::uint32_t>& members, int k, std::mt19937_64& rng) {
  std::vector<Descriptor> centres{copy_of(descriptors[members[rng() % members.size()]])};
  std::vector<double> nearest_sq(members.size(), 0.0);
  for (std::size_t i = 0; i < members.size(); ++i) {
    const double d = features::hamming_distance(centres[0].data(), descriptors[members[i]]);
    nearest_sq[i] = d * d;
  }
  while (static_cast<int>(centres.size()) < k) {
    double total = 0.0;
    for (double d : nearest_sq) total += d;
    if (total <= 0.0) break;  // every member equals a centre
    const double r = total * (static_cast<double>(rng() >> 11) * 0x1.0p-53);
    std::size_t pick = 0;
    double cumulative = nearest_sq[0];
    while (cumulative <= r && pick + 1 < members.size()) cumulative += nearest_sq[++pick];
    centres.push_back(copy_of(descriptors[members[pick]]));
    for (std::size_t i = 0; i < members.size(); ++i) {
      const double d = features::hamming_distance(centres.back().data(), descriptors[members[i]]);
      nearest_sq[i] = std::min(nearest_sq[i], d * d);
    }
  }
  return centres;
}

struct Clusters {
  std::vector<Descriptor> centres;
  std::vector<std::vector<std::uint32_t>> members;
};

// k-majority clustering of `members` (indices into descriptors); empty
// clusters are dropped. At most k members: one cluster per distinct descriptor.
Clusters cluster(const std::vector<const std::uint8_t*>& descriptors,
                 const std::vector<std::uint32_t>& members, int k, int max_iterations, std::mt19937_64& rng) {
  Clusters out;
  if (static_cast<int>(members.size()) <= k) {
    for (std::uint32_t m : members) {
      const auto same = std::find_if(out.centres.begin(), out.centres.end(), [&](const Descriptor& c) {
        return features::hamming_distance(c.data(), descriptors[m]) == 0;
      });
      if (same != out.centres.end()) {
        out.members[same - out.centres.begin()].push_back(m);
        continue;
      }
      out.centres.push_back(copy_of(descriptors[m]));
      out.members.push_back({m});
    }
    return out;
  }
  out.centres = seed_centres(descriptors, members, k, rng);
  std::vector<int> assignment(members.size(), -1);
  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    bool changed = false;
    for (std::size_t i = 0; i < members.size(); ++i) {
      int best = 0;
      int best_distance = features::kDescriptorBits + 1;
      for (int c = 0; c < static_cast<int>(out.centres.size()); ++c) {
        const int d = features::hamming_distance(out.centres[c].data(), descriptors[members[i]]);
        if (d < best_distance) {
          best_distance = d;
          best = c;
        }
      }
      changed = changed || assignment[i] != best;
      assignment[i] = best;
    }
    out.members.assign(out.centres.size(), {});
    for (std::size_t i = 0; i < members.size(); ++i) out.members[assignment[i]].push_back(members[i]);
    if (!changed) break;
    for (std::size_t c = 0; c < out.centres.size(); ++c) {
      if (!out.members[c].empty()) out.centres[c] = majority(descriptors, out.members[c]);
    }
  }
  Clusters kept;
  for (std::size_t c = 0; c < out.centres.size(); ++c) {
    if (out.members[c].empty()) continue;
    kept.centres.push_back(out.centres[c]);
    kept.members.push_back(std::move(out.members[c]));
  }
  return kept;
}

Status check_training_input(const std::vector<cv::Mat>& images, const VocabularyParams& params) {
  if (params.branching < 2 || params.branching > 64 || params.levels < 1 || params.levels > 8 ||
      params.max_iterations < 1) {
    return make_error(ErrorCode::kInvalidArgument,
                      "vocabulary: branching must be 2..64, levels 1..8 and iterations >= 1 (got " +
                          std::to_string(params.branching) + ", " + std::to_string(params.levels) + ", " +
                          std::to_string(params.max_iterations) + ")");
  }
  bool any = false;
  for (const cv::Mat& d : images) {
    if (d.empty()) continue;
    if (d.type() != CV_8UC1 || d.cols != features::kDescriptorBytes) {
      return make_error(ErrorCode::kInvalidArgument, "vocabulary: descriptors must be N x 32 CV_8UC1");
    }
    any = true;
  }
  if (!any) return make_error(ErrorCode::kInvalidArgument, "vocabulary: no training descriptors");
  return ok_status();
}

}  // namespace

double score_l1(const BowVector& a, const BowVector& b) {
  // For L1-normalised non-negative vectors 1 - |a - b|_1 / 2 is the sum of
  // the common words' smaller weights.
  double score = 0.0;
  auto i = a.begin();
  auto j = b.begin();
  while (i != a.end() && j != b.end()) {
    if (i->word < j->word) {
      ++i;
    } else if (j->word < i->word) {
      ++j;
    } else {
      score += std::min(i->weight, j->weight);
      ++i;
      ++j;
    }
  }
  return score;
}

Expected<Vocabulary> Vocabulary::train(const std::vector<cv::Mat>& images, const VocabularyParams& params) {
  SITEPOSE_TRY_STATUS(check_training_input(images, params));
  std::vector<const std::uint8_t*> descriptors;
  for (const cv::Mat& d : images) {
    for (int r = 0; r < d.rows; ++r) descriptors.push_back(d.ptr<std::uint8_t>(r));
  }
  Vocabulary v;
  v.branching_ = params.branching;
  v.levels_ = params.levels;
  v.training_images_ = images.size();
  std::mt19937_64 rng(params.seed);
  struct Pending {
    std::uint32_t node;
    int level;
    std::vector<std::uint32_t> members;
  };
  std::vector<std::uint32_t> all(descriptors.size());
  for (std::uint32_t i = 0; i < all.size(); ++i) all[i] = i;
  v.nodes_.push_back(Node{});
  v.nodes_[0].centre = majority(descriptors, all);
  // Breadth first, so that each node's children are appended together
  // after those of the nodes before it (the file's order).
  std::deque<Pending> pending;
  pending.push_back({0, 0, std::move(all)});
  while (!pending.empty()) {
    Pending p = std::move(pending.front());
    pending.pop_front();
    if (p.level == params.levels) continue;
    Clusters c = cluster(descriptors, p.members, params.branching, params.max_iterations, rng);
    if (c.centres.size() < 2) continue;  // identical descriptors: a leaf
    v.nodes_[p.node].first_child = static_cast<std::uint32_t>(v.nodes_.size());
    v.nodes_[p.node].children = static_cast<std::uint8_t>(c.centres.size());
    for (std::size_t i = 0; i < c.centres.size(); ++i) {
      Node child;
      child.centre = c.centres[i];
      pending.push_back({static_cast<std::uint32_t>(v.nodes_.size()), p.level + 1, std::move(c.members[i])});
      v.nodes_.push_back(child);
    }
  }
  v.finish();
  // idf from the training images as the tree routes them (a descriptor may
  // land in another leaf than the cluster it was trained in).
  std::vector<std::uint32_t> images_with_word(v.word_count(), 0);
  std::vector<std::uint32_t> last_image(v.word_count(), 0);
  for (std::uint32_t image = 0; image < images.size(); ++image) {
    const cv::Mat& d = images[image];
    for (int r = 0; r < d.rows; ++r) {
      const WordId w = v.word_of(d.ptr<std::uint8_t>(r));
      if (last_image[w] == image + 1) continue;
      last_image[w] = image + 1;
      ++images_with_word[w];
    }
  }
  const auto n_images = static_cast<double>(images.size());
  for (WordId w = 0; w < v.word_count(); ++w) {
    if (images_with_word[w] > 0) v.nodes_[v.word_node_[w]].idf = std::log(n_images / images_with_word[w]);
  }
  v.finish();
  return v;
}

void Vocabulary::finish() {
  word_node_.clear();
  for (std::uint32_t i = 0; i < nodes_.size(); ++i) {
    if (nodes_[i].children != 0) continue;
    nodes_[i].word = static_cast<WordId>(word_node_.size());
    word_node_.push_back(i);
  }
  id_ = make_id();
}

WordId Vocabulary::word_of(const std::uint8_t* descriptor) const {
  std::uint32_t node = 0;
  while (nodes_[node].children != 0) {
    const Node& n = nodes_[node];
    std::uint32_t best = n.first_child;
    int best_distance = features::kDescriptorBits + 1;
    for (std::uint32_t c = n.first_child; c < n.first_child + n.children; ++c) {
      const int d = features::hamming_distance(nodes_[c].centre.data(), descriptor);
      if (d < best_distance) {
        best_distance = d;
        best = c;
      }
    }
    node = best;
  }
  return nodes_[node].word;
}

double Vocabulary::idf(WordId word) const {
  return word < word_node_.size() ? nodes_[word_node_[word]].idf : 0.0;
}

namespace {

// Sums the idf of each descriptor's word per word, drops zero weights (words
// in every training image tell nothing) and normalises to L1 = 1.
BowVector bow_from_words(std::vector<WordId>& words, const Vocabulary& vocabulary) {
  std::sort(words.begin(), words.end());
  BowVector bow;
  double total = 0.0;
  for (std::size_t i = 0; i < words.size();) {
    std::size_t j = i;
    while (j < words.size() && words[j] == words[i]) ++j;
    const double weight = static_cast<double>(j - i) * vocabulary.idf(words[i]);
    if (weight > 0.0) {
      bow.push_back({words[i], weight});
      total += weight;
    }
    i = j;
  }
  for (BowEntry& e : bow) e.weight /= total;
  return bow;
}

}  // namespace

BowVector Vocabulary::transform(const cv::Mat& descriptors, const std::vector<std::uint8_t>& usable) const {
  std::vector<WordId> words;
  if (nodes_.empty() || descriptors.cols != features::kDescriptorBytes || descriptors.type() != CV_8UC1)
    return {};
  words.reserve(descriptors.rows);
  for (int r = 0; r < descriptors.rows; ++r) {
    if (!usable.empty() && (r >= static_cast<int>(usable.size()) || usable[r] == 0)) continue;
    words.push_back(word_of(descriptors.ptr<std::uint8_t>(r)));
  }
  return bow_from_words(words, *this);
}

BowVector Vocabulary::transform(const std::vector<map::Descriptor>& descriptors) const {
  if (nodes_.empty()) return {};
  std::vector<WordId> words;
  words.reserve(descriptors.size());
  for (const map::Descriptor& d : descriptors) words.push_back(word_of(d.data()));
  return bow_from_words(words, *this);
}

}  // namespace sitepose::placerec
