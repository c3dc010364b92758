// `sitepose bench placerec`: the cost of a place-recognition query for
// relocalisation with N keyframes in the map, the keyframe database (bag of
// words, placerec) against the exact nearest-point vote
// (tracking/place_recognition.hpp), on the left images of one sequence:
// every --keyframe-every-th frame is a keyframe, the frames between are the
// queries. Larger maps repeat the keyframes under new ids (the inverted
// lists and the exact vote's points grow as in a map of that size; every
// keypoint of a keyframe stands for a point, about 4 times what a map
// keeps, so the exact vote's figures are an upper bound). Also
// the share of queries whose best candidate lies within 2 m of the query
// (ground truth), at the unrepeated size. Timings only, never pass/fail.
// Ctrl-C / SIGTERM: the rows of the map sizes measured completely, marked
// partial, exit 130.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>

#include "command_config.hpp"
#include "command_registry.hpp"
#include "interrupt.hpp"
#include "sitepose/experiments/labelled_source.hpp"
#include "sitepose/experiments/vocabulary_training.hpp"
#include "sitepose/features/orb_extractor.hpp"
#include "sitepose/placerec/keyframe_database.hpp"
#include "sitepose/slam/run_recorder.hpp"
#include "sitepose/tracking/place_recognition.hpp"

namespace sitepose::cli {
namespace {

constexpr const char* kCommand = "bench placerec";

struct Args {
  FrameSourceArgs input{.scenario = "backforth"};
  std::string vocabulary;
  int frames = 240;
  int keyframe_every = 6;
  int queries = 20;
  std::vector<int> sizes{40, 200, 1000};
};

struct Frame {
  cv::Mat descriptors;
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
};

double us_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t).count();
}

struct Measured {
  double transform_us = 0.0;
  double score_us = 0.0;
  double exact_us = 0.0;
  int bow_right = 0;
  int exact_right = 0;
  int queries = 0;
};

// keyframes: indices into frames; each repeated `copies` times (id = copy *
// n + i). Queries: the frames that are not keyframes. Ends early when
// interrupted (the caller drops that size).
Measured measure(const std::vector<Frame>& frames, const std::vector<int>& keyframes, int copies, int queries,
                 const std::shared_ptr<const placerec::Vocabulary>& vocabulary) {
  placerec::KeyFrameDatabase db(vocabulary);
  tracking::PlaceIndex exact;
  const auto n = static_cast<map::KeyFrameId>(keyframes.size());
  for (int copy = 0; copy < copies; ++copy) {
    for (std::size_t i = 0; i < keyframes.size(); ++i) {
      const cv::Mat& d = frames[keyframes[i]].descriptors;
      const map::KeyFrameId id = copy * n + static_cast<map::KeyFrameId>(i);
      db.add(id, vocabulary->transform(d));
      for (int r = 0; r < d.rows; ++r) {
        exact.descriptors.push_back(map::descriptor_from_row(d, r));
        exact.keyframes.push_back(id);
        exact.offset.push_back(exact.keyframes.size());
      }
    }
  }
  Measured m;
  const auto no_covisibility = [](map::KeyFrameId, int) { return std::vector<map::KeyFrameId>{}; };
  const auto near = [&](std::size_t query, map::KeyFrameId id) {
    const int kf = keyframes[static_cast<std::size_t>(id % n)];
    return (frames[kf].position_m - frames[query].position_m).norm() < 2.0;
  };
  std::vector<std::size_t> between;
  for (std::size_t q = 0; q < frames.size(); ++q) {
    if (std::find(keyframes.begin(), keyframes.end(), static_cast<int>(q)) == keyframes.end())
      between.push_back(q);
  }
  const std::size_t n_queries = std::min<std::size_t>(between.size(), static_cast<std::size_t>(queries));
  for (std::size_t i = 0; i < n_queries && !interrupted(); ++i) {
    const std::size_t q = between[i * between.size() / n_queries];
    const cv::Mat& d = frames[q].descriptors;
    const std::vector<std::uint8_t> usable(static_cast<std::size_t>(d.rows), 1);
    auto t = std::chrono::steady_clock::now();
    const placerec::BowVector bow = vocabulary->transform(d, usable);
    m.transform_us += us_since(t);
    t = std::chrono::steady_clock::now();
    const auto groups = placerec::group_candidates(db.score(bow), no_covisibility);
    m.score_us += us_since(t);
    t = std::chrono::steady_clock::now();
    const auto ranked = tracking::rank_places(exact, d, usable);
    m.exact_us += us_since(t);
    m.bow_right += !groups.empty() && near(q, groups.front().keyframe) ? 1 : 0;
    m.exact_right += !ranked.empty() && near(q, ranked.front().keyframe) ? 1 : 0;
    ++m.queries;
  }
  return m;
}

int run(const Args& args) {
  install_interrupt_handlers();
  auto config = load_command_config(args.input.config_path);
  if (!config) return fail(kCommand, config.error().message, 2);
  auto source = open_frame_source(args.input, args.frames);
  if (!source) return fail(kCommand, source.error().message, 2);
  auto extractor = features::OrbExtractor::create(config->orb);
  if (!extractor) return fail(kCommand, extractor.error().message, 2);
  std::vector<Frame> frames;
  const int n_frames = args.frames > 0 ? std::min(args.frames, (*source)->size()) : (*source)->size();
  for (int i = 0; i < n_frames; ++i) {
    if (interrupted()) {
      std::printf("bench placerec: %d of %d frames extracted (interrupted: partial), no map size measured\n",
                  i, n_frames);
      return report_interrupted(kCommand, "measured nothing: it stopped while extracting the features");
    }
    auto frame = (*source)->read(i);
    if (!frame) return fail(kCommand, frame.error().message, 2);
    auto features = extractor->extract(frame->frame.left);
    if (!features) return fail(kCommand, features.error().message, 1);
    frames.push_back({features->descriptors, frame->T_world_cam_gt ? frame->T_world_cam_gt->translation()
                                                                   : Eigen::Vector3d::Zero()});
  }
  std::vector<int> keyframes;
  for (int i = 0; i < n_frames; i += args.keyframe_every) keyframes.push_back(i);
  auto loaded = load_or_train_vocabulary(args.vocabulary, [&]() -> Expected<std::vector<cv::Mat>> {
    std::vector<cv::Mat> training;
    training.reserve(keyframes.size());
    for (int i : keyframes) training.push_back(frames[i].descriptors);
    return training;
  });
  // A file given: bad input (2); else the training failed (1).
  if (!loaded) return fail(kCommand, loaded.error().message, args.vocabulary.empty() ? 1 : 2);
  const std::shared_ptr<const placerec::Vocabulary>& vocabulary = *loaded;
  std::printf("bench placerec: %s, %d frames, %zu keyframes (every %d), vocabulary %s (%zu words%s)\n",
              (*source)->name().c_str(), n_frames, keyframes.size(), args.keyframe_every,
              vocabulary->id().c_str(), vocabulary->word_count(),
              args.vocabulary.empty() ? ", trained on these keyframes" : "");
  std::printf("%10s %10s %14s %14s %14s %12s %12s\n", "keyframes", "queries", "bow words us", "bow db us",
              "bow total us", "exact us", "exact/bow");
  std::size_t sizes_done = 0;
  for (int size : args.sizes) {
    const int copies = std::max(1, size / std::max<int>(1, static_cast<int>(keyframes.size())));
    const Measured m = measure(frames, keyframes, copies, args.queries, vocabulary);
    if (interrupted()) break;  // this size's queries were cut short: no row
    const double q = std::max(1, m.queries);
    const double bow = (m.transform_us + m.score_us) / q;
    std::printf("%10zu %10d %14.1f %14.1f %14.1f %12.1f %12.1f\n", keyframes.size() * copies, m.queries,
                m.transform_us / q, m.score_us / q, bow, m.exact_us / q,
                bow > 0.0 ? m.exact_us / q / bow : 0.0);
    if (copies == 1) {
      std::printf("%10s best candidate within 2 m of the query: bow %.1f %%, exact %.1f %%\n", "",
                  100.0 * m.bow_right / q, 100.0 * m.exact_right / q);
    }
    ++sizes_done;
  }
  if (interrupted()) return report_rows_interrupted(kCommand, sizes_done, args.sizes.size(), "map sizes");
  return 0;
}

void add_options(CLI::App& sub, Args& args) {
  add_frame_source_options(sub, args.input, "sitepose YAML config (its orb section is used)");
  add_bench_vocabulary_option(sub, args.vocabulary, "one trained on the keyframes");
  sub.add_option("--frames", args.frames, "Frames (0 = all)")->capture_default_str();
  add_bounded(sub, "--keyframe-every", args.keyframe_every, "Every N-th frame is a keyframe", 2, 1000);
  add_bounded(sub, "--queries", args.queries, "Query frames (spread over the frames between keyframes)", 1,
              100000);
  sub.add_option("--keyframes", args.sizes, "Map sizes to measure (keyframes)")->capture_default_str();
}

const CommandRegistrar kBenchPlacerec{make_command<Args>(
    "bench", "placerec", add_options, run,
    "Place-recognition query cost with N keyframes: keyframe database (bag of words) vs the exact vote")};

}  // namespace
}  // namespace sitepose::cli
