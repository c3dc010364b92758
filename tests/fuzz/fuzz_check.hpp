#pragma once
// What a harness asserts about an accepted input: a parser that says ok
// must hand back what its header promises. A broken promise aborts, so the
// fuzzer keeps the input like a crash.

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "sitepose/core/se3.hpp"

namespace sitepose::fuzz {

inline void require(bool condition, const char* what) {
  if (condition) return;
  std::fprintf(stderr, "fuzz harness: accepted input breaks: %s\n", what);
  std::abort();
}

inline void require_pose(const SE3& pose) {
  require(pose.translation().allFinite(), "finite translation");
  require(std::abs(pose.rotation().norm() - 1.0) < 1e-6, "unit quaternion");
}

}  // namespace sitepose::fuzz
