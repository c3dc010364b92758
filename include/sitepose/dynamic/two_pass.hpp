#pragma once
// The dynamic layer's steps of two-pass tracking (METHOD.md "Two-pass
// coarse-to-fine tracking"), used by slam::TwoPassTracker: which keypoints a
// pass may use, the instance bookkeeping between classification and pass 2,
// and the gate that decides whether pass 2 may replace pass 1.
// Pure functions and value types; thread-safe.

#include <cstdint>
#include <vector>

#include "sitepose/dynamic/motion_classifier.hpp"
#include "sitepose/dynamic/object_types.hpp"
#include "sitepose/tracking/tracker.hpp"

namespace sitepose::dynamic {

// Object instances by id, in the order they were added (a repeated id stays
// repeated, as the boxes gave it). Tells keypoints of these objects apart.
class InstanceSet {
 public:
  InstanceSet() = default;
  explicit InstanceSet(std::vector<std::uint16_t> ids) : ids_(std::move(ids)) {}

  void add(std::uint16_t id) { ids_.push_back(id); }
  void remove(std::uint16_t id);  // every occurrence
  bool contains(std::uint16_t id) const;
  bool empty() const { return ids_.empty(); }
  int size() const { return static_cast<int>(ids_.size()); }
  const std::vector<std::uint16_t>& ids() const { return ids_; }

 private:
  std::vector<std::uint16_t> ids_;
};

// Per keypoint of a prepared frame, 1 = a pass may use it (Tracker::estimate).
using KeypointMask = std::vector<std::uint8_t>;

// The background keypoints (instance 0): pass 1.
KeypointMask background_keypoints(const tracking::PreparedFrame& frame);

// The keypoints of `instances` only.
KeypointMask keypoints_of(const tracking::PreparedFrame& frame, const InstanceSet& instances);

// `mask` plus the keypoints of `instances`: pass 1's fallback, pass 2.
KeypointMask with_keypoints_of(KeypointMask mask, const tracking::PreparedFrame& frame,
                               const InstanceSet& instances);

// The objects whose state (after hysteresis) is static, in object order.
InstanceSet static_objects(const std::vector<ClassifiedObject>& objects);

// Records the map checks in `objects` (statistic; moving where it failed)
// and takes the objects that failed out of `static_objects`. Returns how
// many failed.
int apply_map_checks(const std::vector<MapCheck>& checks, std::vector<ClassifiedObject>& objects,
                     InstanceSet& static_objects);

// Pass 2 may refine pass 1 but not contradict it: true when the pose
// difference is within pass 1's calibrated covariance (squared Mahalanobis
// distance, chi2 6 dof 99 %), or pass 1 has no covariance to test against.
bool pass2_agrees_with_pass1(const tracking::PassResult& pass1, const tracking::PassResult& pass2);

}  // namespace sitepose::dynamic
