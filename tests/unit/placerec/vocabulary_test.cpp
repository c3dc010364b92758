#include "sitepose/placerec/vocabulary.hpp"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>

#include <unistd.h>

#include "descriptors.hpp"
#include "sitepose/testing/framed_bytes.hpp"

namespace sitepose::placerec {
namespace {

using testing::flip_bits;
using testing::random_descriptors;
using testing::repeat_row;

std::vector<cv::Mat> random_images(int images, int per_image, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<cv::Mat> out;
  out.reserve(static_cast<std::size_t>(images));
  for (int i = 0; i < images; ++i) out.push_back(random_descriptors(per_image, rng));
  return out;
}

Expected<Vocabulary> trained(int branching, int levels, const std::vector<cv::Mat>& images) {
  VocabularyParams params;
  params.branching = branching;
  params.levels = levels;
  return Vocabulary::train(images, params);
}

TEST(Vocabulary, ADescriptorsWordIsStableAcrossCallsTrainingRunsAndTheFile) {
  const std::vector<cv::Mat> images = random_images(20, 200, 7);
  VocabularyParams params;
  params.branching = 6;
  params.levels = 3;
  auto a = Vocabulary::train(images, params);
  auto b = Vocabulary::train(images, params);
  ASSERT_TRUE(a.has_value()) << a.error().message;
  ASSERT_TRUE(b.has_value());
  EXPECT_EQ(a->id(), b->id()) << "the same inputs and seed give the same vocabulary";
  EXPECT_GT(a->word_count(), 100U);
  EXPECT_LE(a->word_count(), 216U);
  auto decoded = Vocabulary::decode(a->encode());
  ASSERT_TRUE(decoded.has_value()) << decoded.error().message;
  EXPECT_EQ(decoded->id(), a->id());
  EXPECT_EQ(decoded->word_count(), a->word_count());
  for (const cv::Mat& image : images) {
    for (int r = 0; r < image.rows; ++r) {
      const WordId w = a->word_of(image.ptr<std::uint8_t>(r));
      ASSERT_EQ(w, a->word_of(image.ptr<std::uint8_t>(r)));
      ASSERT_EQ(w, decoded->word_of(image.ptr<std::uint8_t>(r)));
    }
  }
  params.seed = 2;
  auto other = Vocabulary::train(images, params);
  ASSERT_TRUE(other.has_value());
  EXPECT_NE(other->id(), a->id()) << "another seed, another tree, another id";
}

// Prototype 0 is in every training image, prototype i (1..5) only in image
// i - 1: idf 0 and ln 5. A query of 5 x P0, 1 x P1, 3 x P2 weighs P1 and P2
// 1 : 3 (tf x idf, L1-normalised); P0 tells nothing and is dropped.
TEST(Vocabulary, WeighsWordsByTermFrequencyTimesInverseDocumentFrequency) {
  std::mt19937 rng(3);
  const cv::Mat prototypes = random_descriptors(6, rng);
  std::vector<cv::Mat> images;
  for (int i = 1; i <= 5; ++i) {
    cv::Mat image = repeat_row(prototypes, 0, 4);
    image.push_back(repeat_row(prototypes, i, 4));
    images.push_back(image);
  }
  VocabularyParams params;
  params.branching = 8;
  params.levels = 2;
  auto v = Vocabulary::train(images, params);
  ASSERT_TRUE(v.has_value()) << v.error().message;
  ASSERT_EQ(v->word_count(), 6U) << "identical descriptors end in one leaf";
  std::vector<WordId> word(6);
  for (int i = 0; i < 6; ++i) word[i] = v->word_of(prototypes.ptr<std::uint8_t>(i));
  EXPECT_DOUBLE_EQ(v->idf(word[0]), 0.0);
  for (int i = 1; i < 6; ++i) EXPECT_NEAR(v->idf(word[i]), std::log(5.0), 1e-12);
  cv::Mat query = repeat_row(prototypes, 0, 5);
  query.push_back(repeat_row(prototypes, 1, 1));
  query.push_back(repeat_row(prototypes, 2, 3));
  const BowVector bow = v->transform(query);
  ASSERT_EQ(bow.size(), 2U);
  double total = 0.0;
  for (const BowEntry& e : bow) {
    total += e.weight;
    EXPECT_NEAR(e.weight, e.word == word[1] ? 0.25 : 0.75, 1e-12);
  }
  EXPECT_NEAR(total, 1.0, 1e-12);
  // usable masks rows out: only the P1 row left.
  std::vector<std::uint8_t> usable(9, 0);
  usable[5] = 1;
  const BowVector one = v->transform(query, usable);
  ASSERT_EQ(one.size(), 1U);
  EXPECT_EQ(one[0].word, word[1]);
  EXPECT_DOUBLE_EQ(one[0].weight, 1.0);
}

TEST(Vocabulary, L1ScoreIsOneForEqualVectorsAndZeroWithoutCommonWords) {
  const BowVector a{{1, 0.5}, {4, 0.5}};
  const BowVector b{{2, 0.25}, {3, 0.75}};
  const BowVector c{{1, 0.25}, {3, 0.75}};
  EXPECT_DOUBLE_EQ(score_l1(a, a), 1.0);
  EXPECT_DOUBLE_EQ(score_l1(a, b), 0.0);
  // 1 - (|0.5 - 0.25| + 0.5 + 0.75) / 2 = 0.25
  EXPECT_DOUBLE_EQ(score_l1(a, c), 0.25);
  EXPECT_DOUBLE_EQ(score_l1(a, c), score_l1(c, a));
  EXPECT_DOUBLE_EQ(score_l1({}, a), 0.0);
}

TEST(Vocabulary, RefusesBadTrainingInput) {
  EXPECT_FALSE(Vocabulary::train({}).has_value());
  EXPECT_FALSE(Vocabulary::train({cv::Mat()}).has_value());
  EXPECT_FALSE(Vocabulary::train({cv::Mat(3, 16, CV_8UC1)}).has_value());
  VocabularyParams params;
  params.branching = 1;
  EXPECT_FALSE(Vocabulary::train(random_images(2, 10, 1), params).has_value());
}

TEST(Vocabulary, FileRoundTripsAndRefusesTruncatedFlippedAndOtherVersions) {
  auto v = trained(4, 3, random_images(8, 100, 5));
  ASSERT_TRUE(v.has_value());
  const auto dir = std::filesystem::temp_directory_path() / ("placerec_vocab_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto path = dir / "v.bin";
  ASSERT_TRUE(v->save(path).has_value());
  auto loaded = Vocabulary::load(path);
  ASSERT_TRUE(loaded.has_value()) << loaded.error().message;
  EXPECT_EQ(loaded->id(), v->id());
  EXPECT_EQ(loaded->node_count(), v->node_count());
  EXPECT_EQ(loaded->training_images(), 8U);
  const std::vector<std::uint8_t> bytes = v->encode();
  const auto refused = [](std::vector<std::uint8_t> b) {
    auto r = Vocabulary::decode(b);
    return r.has_value() ? std::string() : r.error().message;
  };
  EXPECT_NE(refused({bytes.begin(), bytes.begin() + 20}).find("truncated"), std::string::npos);
  EXPECT_NE(refused({bytes.begin(), bytes.end() - 7}).find("truncated"), std::string::npos);
  std::vector<std::uint8_t> flipped = bytes;
  flipped[bytes.size() / 2] ^= 0x10;
  EXPECT_NE(refused(flipped).find("payload checksum"), std::string::npos);
  std::vector<std::uint8_t> other_version = bytes;
  other_version[8] = 9;
  sitepose::testing::refit_frame(other_version);
  EXPECT_NE(refused(other_version).find("format version 9"), std::string::npos);
  std::vector<std::uint8_t> magic = bytes;
  magic[0] = 'X';
  EXPECT_NE(refused(magic).find("vocabulary file refused: not a sitepose vocabulary file"),
            std::string::npos);
  EXPECT_FALSE(Vocabulary::load(dir / "missing.bin").has_value());
  std::filesystem::remove_all(dir);
}

// Found by fuzzing (tests/fuzz/corpus/vocabulary/idf_out_of_range): an idf
// of 1.7e166 next to a subnormal one, and the bag of words held a weight of
// 0 (vocabulary.hpp promises > 0).
TEST(Vocabulary, AnIdfNoTrainingCouldGiveIsRefused) {
  auto v = trained(2, 2, random_images(8, 6, 3));
  ASSERT_TRUE(v.has_value());
  const std::vector<std::uint8_t> bytes = v->encode();
  // The last node is a leaf; its idf is the file's last 8 bytes.
  const auto with_last_idf = [&bytes](double idf) {
    std::vector<std::uint8_t> b = bytes;
    for (int i = 0; i < 8; ++i)
      b[b.size() - 8 + i] = static_cast<std::uint8_t>(std::bit_cast<std::uint64_t>(idf) >> (8 * i));
    sitepose::testing::refit_frame(b);
    auto r = Vocabulary::decode(b);
    return r.has_value() ? std::string("accepted") : r.error().message;
  };
  EXPECT_EQ(with_last_idf(0.0), "accepted");
  EXPECT_EQ(with_last_idf(std::log(8.0)), "accepted");
  EXPECT_EQ(with_last_idf(std::log(8.0 / 7.0)), "accepted");
  for (const double idf : {1.6875e166, 3.1e-319, std::log(8.0) * 1.001, std::log(8.0 / 7.0) * 0.999, -1.0,
                           std::numeric_limits<double>::infinity()}) {
    EXPECT_NE(with_last_idf(idf).find("is not part of a valid tree"), std::string::npos) << idf;
  }
}

// Few flipped bits move few descriptors to another word: a noisy view of a
// keyframe keeps most of its bag of words.
TEST(Vocabulary, ANoisyCopyKeepsMostOfItsBagOfWords) {
  const std::vector<cv::Mat> images = random_images(10, 300, 11);
  auto v = Vocabulary::train(images);
  ASSERT_TRUE(v.has_value());
  std::mt19937 rng(4);
  const BowVector clean = v->transform(images[3]);
  const BowVector noisy = v->transform(flip_bits(images[3], 4, rng));
  const BowVector other = v->transform(images[4]);
  EXPECT_GT(score_l1(clean, noisy), 0.5);
  EXPECT_LT(score_l1(clean, other), 0.2);
}

}  // namespace
}  // namespace sitepose::placerec
