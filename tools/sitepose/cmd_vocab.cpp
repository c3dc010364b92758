// `sitepose vocab train`: a place-recognition vocabulary (placerec) from the
// left images of recorded or simulated sequences, written atomically to a
// versioned, checksummed file that `sitepose run --vocabulary` reads.

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "command_config.hpp"
#include "command_registry.hpp"
#include "sitepose/experiments/vocabulary_training.hpp"
#include "sitepose/placerec/vocabulary.hpp"

namespace sitepose::cli {
namespace {

constexpr const char* kCommand = "vocab train";

struct Args {
  std::vector<std::string> sequences;
  std::vector<std::string> scenarios;
  std::string config_path;
  std::string out;
  int every = 3;
  int max_frames = 0;
  placerec::VocabularyParams params;
};

int run(const Args& args) {
  if (args.sequences.empty() && args.scenarios.empty())
    return fail(kCommand, "give at least one --sequence or --scenario", 2);
  auto config = load_command_config(args.config_path);
  if (!config) return fail(kCommand, config.error().message, 2);
  const auto start = std::chrono::steady_clock::now();
  std::vector<cv::Mat> images;
  std::size_t descriptors = 0;
  const auto add = [&](Expected<std::unique_ptr<experiments::LabelledSource>> source) -> int {
    if (!source) return fail(kCommand, source.error().message, 2);
    auto read = experiments::left_image_descriptors(**source, config->orb, args.every, args.max_frames);
    if (!read) return fail(kCommand, (*source)->name() + ": " + read.error().message, 2);
    for (cv::Mat& d : *read) {
      descriptors += static_cast<std::size_t>(d.rows);
      images.push_back(std::move(d));
    }
    return 0;
  };
  for (const std::string& dir : args.sequences) {
    if (const int st = add(experiments::open_labelled_sequence(dir, false)); st != 0) return st;
  }
  for (const std::string& scenario : args.scenarios) {
    if (const int st = add(experiments::open_simulated(scenario)); st != 0) return st;
  }
  const auto extracted = std::chrono::steady_clock::now();
  auto vocabulary = placerec::Vocabulary::train(images, args.params);
  if (!vocabulary) return fail(kCommand, vocabulary.error().message, 2);
  const auto trained = std::chrono::steady_clock::now();
  if (auto st = vocabulary->save(args.out); !st) return fail(kCommand, st.error().message, 1);
  std::error_code ec;
  const auto bytes = std::filesystem::file_size(args.out, ec);
  const auto seconds = [](auto a, auto b) { return std::chrono::duration<double>(b - a).count(); };
  std::printf("vocabulary %s\n", vocabulary->id().c_str());
  std::printf("file       %s, %ju bytes\n", args.out.c_str(), static_cast<std::uintmax_t>(ec ? 0 : bytes));
  std::printf("tree       k %d, L %d: %zu nodes, %zu words\n", vocabulary->branching(), vocabulary->levels(),
              vocabulary->node_count(), vocabulary->word_count());
  std::printf("training   %zu images, %zu descriptors; extraction %.1f s, training %.1f s\n", images.size(),
              descriptors, seconds(start, extracted), seconds(extracted, trained));
  return 0;
}

void add_options(CLI::App& sub, Args& args) {
  sub.add_option("--sequence", args.sequences, "Recorded sequence directory (repeatable)")
      ->check(CLI::ExistingDirectory);
  sub.add_option("--scenario", args.scenarios, "Scenario to simulate in-process (name or YAML; repeatable)");
  sub.add_option("--config", args.config_path, "sitepose YAML config (its orb section is used)");
  sub.add_option("--out", args.out, "Vocabulary file to write")->required();
  add_bounded(sub, "--every", args.every, "Use every N-th frame", 1, 1000);
  sub.add_option("--frames", args.max_frames, "At most N frames per sequence (0 = all)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  add_bounded(sub, "--branching", args.params.branching, "Children per node (k)", 2, 64);
  add_bounded(sub, "--levels", args.params.levels, "Levels (L): up to k^L words", 1, 8);
  add_bounded(sub, "--iterations", args.params.max_iterations, "k-majority rounds per node", 1, 100);
  sub.add_option("--seed", args.params.seed, "Seed of the k-means++ draws")->capture_default_str();
}

const CommandRegistrar kVocabTrain{
    make_command<Args>("vocab", "train", add_options, run,
                       "Train a place-recognition vocabulary (k-majority tree, TF-IDF) on sequences")};

}  // namespace
}  // namespace sitepose::cli
