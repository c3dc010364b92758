// The place-recognition vocabulary (mapping.vocabulary; loaded at start
// with the map). An accepted vocabulary has parameters in range and at
// least one word, a finite idf >= 0 per word, sends every descriptor to a
// word it has, turns descriptors into a bag of words as vocabulary.hpp
// promises (sorted words, weights > 0 summing to 1), and encodes back to
// the payload it was read from.
#include <algorithm>
#include <cmath>

#include "fuzz_check.hpp"
#include "fuzz_frame.hpp"
#include "fuzz_input.hpp"
#include "sitepose/placerec/vocabulary.hpp"

namespace {

using namespace sitepose;

void check_bow(const placerec::BowVector& bow, const placerec::Vocabulary& v) {
  double total = 0.0;
  for (std::size_t i = 0; i < bow.size(); ++i) {
    fuzz::require(bow[i].word < v.word_count(), "bag-of-words word in range");
    fuzz::require(i == 0 || bow[i - 1].word < bow[i].word, "bag of words sorted by word, once each");
    fuzz::require(std::isfinite(bow[i].weight) && bow[i].weight > 0.0, "bag-of-words weight finite, > 0");
    total += bow[i].weight;
  }
  fuzz::require(bow.empty() || std::abs(total - 1.0) < 1e-9, "bag-of-words weights sum to 1");
  const double self = placerec::score_l1(bow, bow);
  fuzz::require(bow.empty() || std::abs(self - 1.0) < 1e-9, "a bag of words scores 1 against itself");
}

void check(const std::vector<std::uint8_t>& bytes) {
  auto decoded = placerec::Vocabulary::decode(bytes);
  if (!decoded) return;
  const placerec::Vocabulary& v = *decoded;
  fuzz::require(v.branching() >= 2 && v.branching() <= 64 && v.levels() >= 1 && v.levels() <= 8,
                "branching 2..64, levels 1..8");
  fuzz::require(v.word_count() >= 1 && v.word_count() <= v.node_count(), "1..nodes words");
  fuzz::require(!v.id().empty(), "an id");
  for (placerec::WordId w = 0; w < v.word_count(); ++w) {
    fuzz::require(std::isfinite(v.idf(w)) && v.idf(w) >= 0.0, "finite idf >= 0");
  }
  fuzz::require(v.idf(static_cast<placerec::WordId>(v.word_count())) == 0.0, "no idf past the words");

  // Descriptors: all zeros, all ones, and 32-byte windows of the input.
  std::vector<map::Descriptor> descriptors(2);
  descriptors[1].fill(0xFF);
  for (std::size_t at = 0; at + 32 <= bytes.size() && descriptors.size() < 6; at += 37) {
    map::Descriptor d;
    std::copy_n(bytes.begin() + static_cast<std::ptrdiff_t>(at), 32, d.begin());
    descriptors.push_back(d);
  }
  for (const map::Descriptor& d : descriptors) {
    fuzz::require(v.word_of(d.data()) < v.word_count(), "a descriptor's word exists");
  }
  check_bow(v.transform(descriptors), v);
  cv::Mat rows(static_cast<int>(descriptors.size()), 32, CV_8UC1);
  for (int r = 0; r < rows.rows; ++r) std::copy_n(descriptors[r].data(), 32, rows.ptr<std::uint8_t>(r));
  const placerec::BowVector from_rows = v.transform(rows);
  fuzz::require(from_rows == v.transform(descriptors), "matrix and vector transforms agree");
  check_bow(v.transform(rows, {1, 0, 1}), v);

  const std::vector<std::uint8_t> again = v.encode();
  fuzz::require(
      again.size() == bytes.size() && std::equal(again.begin() + mapfile::kFrameHeaderBytes, again.end(),
                                                 bytes.begin() + mapfile::kFrameHeaderBytes),
      "encodes back to the payload it was read from");
  auto reloaded = placerec::Vocabulary::decode(again);
  fuzz::require(reloaded.has_value() && reloaded->id() == v.id(), "re-encoded vocabulary loads with its id");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  check(std::vector<std::uint8_t>(data, data + size));
  check(sitepose::fuzz::reframed(data, size));
  return 0;
}
