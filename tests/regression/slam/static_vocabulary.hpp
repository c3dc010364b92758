#pragma once
// A small place-recognition vocabulary trained at test time on the `static`
// scenario (60 frames, seed 5, every 2nd left image), shared by the
// relocalisation and loop-closing regression tests. Needs
// SITEPOSE_SCENARIO_DIR (the test target's compile definition).

#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/experiments/labelled_source.hpp"
#include "sitepose/experiments/vocabulary_training.hpp"
#include "sitepose/placerec/vocabulary.hpp"

namespace sitepose::experiments {

// Null (with a test failure recorded) when rendering or training fails.
inline std::shared_ptr<const placerec::Vocabulary> train_on_static(int width, int height) {
  auto source = open_simulated(std::string(SITEPOSE_SCENARIO_DIR) + "/static.yaml", 60, 5, width, height);
  EXPECT_TRUE(source.has_value());
  if (!source) return nullptr;
  config::SiteposeConfig config;
  auto images = left_image_descriptors(**source, config.orb, 2);
  EXPECT_TRUE(images.has_value());
  if (!images) return nullptr;
  auto vocabulary = placerec::Vocabulary::train(*images);
  EXPECT_TRUE(vocabulary.has_value());
  if (!vocabulary) return nullptr;
  return std::make_shared<const placerec::Vocabulary>(std::move(*vocabulary));
}

}  // namespace sitepose::experiments
