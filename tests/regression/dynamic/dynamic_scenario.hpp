#pragma once
// A scenario rendered once and cached in memory, run through the dynamic
// layer in any mode on the same frames: the figures the dynamic regression
// tests and sweeps compare. SITEPOSE_DYN_FRAMES overrides a test's frame
// count; SITEPOSE_DYN_DUMP prints every frame and classified object.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <optional>
#include <string>

#include "sitepose/detect/create_detector.hpp"
#include "sitepose/experiments/dynamic_run.hpp"
#include "sitepose/experiments/roc.hpp"

namespace sitepose::experiments {

// Objects with fewer matched points are not tested (unknown); flicker and
// "testable" counts use the same bound.
inline const int kMinObjectPoints = config::DynamicConfig{}.min_object_points;

inline int frames_from_env(int fallback) {
  if (const char* env = std::getenv("SITEPOSE_DYN_FRAMES"); env && *env) return std::atoi(env);
  return fallback;
}

struct ModeFigures {
  double ate_m = NAN;
  double coverage = 0.0;
  double max_masked = 0.0;
  DynamicRunResult run;
};

class Scenario {
 public:
  // seed: the rendering's (textures, layout, exposure, noise); default the scenario's.
  Scenario(const std::string& name, int frames, std::optional<int> seed = std::nullopt) {
    auto source = open_simulated(name, frames, seed);
    if (!source) {
      error_ = source.error().message;
      return;
    }
    source_ = cache_frames(std::move(*source));
  }
  const std::string& error() const { return error_; }
  double fps() const { return source_ ? source_->fps() : 0.0; }

  // detector: empty = the scenario's labels, else a detector by name.
  ModeFigures run(config::MaskingMode mode,
                  config::ClassifierMode classifier = config::ClassifierMode::kSitepose,
                  const std::string& detector = "") {
    return run_with(config::SiteposeConfig{}, mode, classifier, detector);
  }
  // run() from `config` instead of the defaults (mode, classifier and
  // detector still set here).
  ModeFigures run_with(config::SiteposeConfig config, config::MaskingMode mode,
                       config::ClassifierMode classifier = config::ClassifierMode::kSitepose,
                       const std::string& detector = "") {
    config.dynamic.mode = mode;
    config.dynamic.classifier = classifier;
    DynamicRunOptions options;
    std::unique_ptr<detect::Detector> made;
    if (!detector.empty()) {
      config.detector.name = detector;
      detect::add_inherent_dynamic_classes(config.detector, config.dynamic);
      auto created = detect::create_detector(config.detector, {"", source_->camera()});
      EXPECT_TRUE(created.has_value()) << (created ? "" : created.error().message);
      if (!created) return {};
      made = std::move(*created);
      options.detector = made.get();
    }
    if (std::getenv("SITEPOSE_DYN_DUMP") != nullptr) {
      // Diagnostics on demand: one line per frame and per classified object.
      options.on_frame = [](int i, int, const slam::FrameReport& r) {
        std::printf("frame %d %s p1 %d p2 %d mar %.2f t %.3f %.3f %.3f\n", i, to_string(r.pose.state),
                    r.pose.counters.features_used_pass1, r.pose.counters.features_used, r.mar,
                    r.pose.T_world_cam.translation().x(), r.pose.T_world_cam.translation().y(),
                    r.pose.T_world_cam.translation().z());
        for (const auto& o : r.objects) {
          std::printf("   obj %u %s raw %s state %s score %.2f pooled %.1f points %d ref %lld map %.1f\n",
                      o.verdict.instance, o.verdict.class_name.c_str(), dynamic::to_string(o.verdict.raw),
                      dynamic::to_string(o.verdict.state), o.verdict.score, o.verdict.pooled_statistic,
                      o.verdict.points, static_cast<long long>(o.verdict.reference_seq),
                      o.verdict.map_statistic.value_or(-1.0));
        }
      };
    }
    auto result = run_dynamic(*source_, config, options);
    EXPECT_TRUE(result.has_value()) << (result ? "" : result.error().message);
    ModeFigures f;
    if (!result) return f;
    f.ate_m = result->ate_m();
    f.coverage = result->coverage_ok();
    f.max_masked = result->max_masked_ratio;
    std::printf(
        "[figures] %-9s %-12s %-8s %s ATE %.4f m  max %.4f m  coverage %.1f %%  max masked %.2f  "
        "pixel-mask calls %d  pass 2 rejected %d  re-masked by the map check %d\n",
        source_->name().c_str(), config::to_string(mode), config::to_string(classifier),
        detector.empty() ? "labels" : detector.c_str(), f.ate_m, result->ate_max_m(), 100.0 * f.coverage,
        f.max_masked, result->recorder.pixel_mask_calls(), result->recorder.pass2_rejections(),
        result->recorder.map_check_remasks());
    f.run = std::move(*result);
    return f;
  }

 private:
  std::unique_ptr<LabelledSource> source_;
  std::string error_;
};

}  // namespace sitepose::experiments
