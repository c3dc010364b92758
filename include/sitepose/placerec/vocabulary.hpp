#pragma once
// A visual vocabulary over 256-bit ORB descriptors, written for sitepose
// (DBoW2 is not available): a hierarchical k-majority tree (binary k-means:
// Hamming distance, centres by per-bit majority, k-means++ seeding) of
// `branching` children per node and `levels` levels; its leaves are the
// words. Each word carries an inverse document frequency from the training
// images, idf = ln(N / n_word). An image becomes a bag-of-words vector of
// TF-IDF weights, L1-normalised; two vectors score
// 1 - |a - b|_1 / 2 in [0, 1] (DBoW2's L1 score).
//
// File (little-endian; this comment is its specification):
//   header  32 bytes: magic "SPVOCAB\x1a", u32 version, u32 flags (0),
//           u64 payload bytes, u32 CRC-32 of the payload, u32 CRC-32 of the
//           header's first 28 bytes
//   payload u32 branching, u32 levels, u64 training images, u64 nodes, then
//           per node in breadth-first order (root first): 32-byte centre,
//           u8 children, f64 idf (0 for inner nodes). A node's children
//           follow each other, after those of the nodes before it.
// An idf is 0 or ln(N / n) for 1 <= n <= N training images; a file with
// another is refused. A truncated, corrupted or other-version file is
// refused naming why; saving
// is atomic (mapfile/atomic_file.hpp). id() names the vocabulary in map
// files: "orb-kmajority-<k>x<L>-<payload CRC-32 in hex>".
//
// Thread: const members are safe to call from any thread.

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "sitepose/core/expected.hpp"
#include "sitepose/map/map_types.hpp"

namespace sitepose::placerec {

using WordId = std::uint32_t;

struct BowEntry {
  WordId word = 0;
  double weight = 0.0;
  bool operator==(const BowEntry&) const = default;
};
// Sorted by word, weights > 0 summing to 1 (empty for an image without words).
using BowVector = std::vector<BowEntry>;

// DBoW2's L1 score of two L1-normalised vectors: 1 for equal vectors, 0 for
// vectors without a common word.
double score_l1(const BowVector& a, const BowVector& b);

struct VocabularyParams {
  int branching = 10;       // k
  int levels = 4;           // L: up to k^L words
  int max_iterations = 10;  // k-majority rounds per node (fewer when stable)
  std::uint64_t seed = 1;   // k-means++ seeding; the same inputs and seed give the same file
};

inline constexpr std::uint32_t kVocabularyFormatVersion = 1;

class Vocabulary {
 public:
  // images: per training image its descriptors (N x 32 CV_8UC1; N may be
  // 0). kInvalidArgument for bad parameters (branching 2..64, levels 1..8),
  // a descriptor matrix of another type, or no descriptor at all.
  static Expected<Vocabulary> train(const std::vector<cv::Mat>& images, const VocabularyParams& params = {});

  // The word a descriptor falls in: the nearest centre on each level.
  WordId word_of(const std::uint8_t* descriptor) const;
  // The bag of words of the rows of `descriptors` where usable is nonzero
  // (all rows when usable is empty).
  BowVector transform(const cv::Mat& descriptors, const std::vector<std::uint8_t>& usable = {}) const;
  BowVector transform(const std::vector<map::Descriptor>& descriptors) const;

  std::size_t word_count() const { return word_node_.size(); }
  double idf(WordId word) const;
  int branching() const { return branching_; }
  int levels() const { return levels_; }
  std::size_t node_count() const { return nodes_.size(); }
  std::uint64_t training_images() const { return training_images_; }
  const std::string& id() const { return id_; }

  std::vector<std::uint8_t> encode() const;
  static Expected<Vocabulary> decode(std::span<const std::uint8_t> bytes);
  Status save(const std::filesystem::path& path) const;
  static Expected<Vocabulary> load(const std::filesystem::path& path);

 private:
  struct Node {
    map::Descriptor centre{};
    std::uint32_t first_child = 0;
    std::uint8_t children = 0;
    double idf = 0.0;
    WordId word = 0;  // leaves only
  };
  // Word ids (leaves in node order) and the id, once nodes_ is complete.
  void finish();
  std::string make_id() const;
  std::vector<std::uint8_t> encode_payload() const;

  int branching_ = 0;
  int levels_ = 0;
  std::uint64_t training_images_ = 0;
  std::vector<Node> nodes_;
  std::vector<std::uint32_t> word_node_;  // word -> node index
  std::string id_;
};

}  // namespace sitepose::placerec
