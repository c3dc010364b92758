#pragma once
// Ownership rule of the map (the one hand-over between threads):
//
//   The map is owned by SharedMap. The tracking thread and the local mapping
//   thread reach it only through read() (shared lock) and write() (exclusive
//   lock), each taking a callback that runs under the lock. No pointer or
//   reference into MapData may escape a callback: callers copy what they
//   need (poses, positions, descriptors are value types). Locks are held for
//   copying and bookkeeping only, never during feature extraction or a
//   Ceres solve: the mapper copies its local BA problem out under read(),
//   solves unlocked, and writes results back under write().
//
// Lock order: SharedMap is a leaf lock; no other lock is taken inside.

#include <mutex>
#include <shared_mutex>
#include <utility>

#include "sitepose/map/map_data.hpp"

namespace sitepose::map {

class SharedMap {
 public:
  explicit SharedMap(ScalePyramid pyramid = {}) : data_(pyramid) {}
  SharedMap(const SharedMap&) = delete;
  SharedMap& operator=(const SharedMap&) = delete;

  template <typename Fn>
  auto read(Fn&& fn) const {
    std::shared_lock lock(mutex_);
    return std::forward<Fn>(fn)(static_cast<const MapData&>(data_));
  }
  template <typename Fn>
  auto write(Fn&& fn) {
    std::unique_lock lock(mutex_);
    return std::forward<Fn>(fn)(data_);
  }

 private:
  mutable std::shared_mutex mutex_;
  MapData data_;  // guarded by mutex_
};

}  // namespace sitepose::map
