#pragma once
// One object's verdict from one frame's evidence: the object-level tests
// of Algorithm 2 (paper mode) and of sitepose mode on the displacements of
// its matched points, with the rules for machines whose parts move on their
// own. MotionClassifier (motion_classifier.cpp) pairs the frames, finds the
// displacements and turns these verdicts into states over time.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "point_displacement.hpp"
#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/dynamic/object_types.hpp"

namespace sitepose::dynamic::detail {

// The kind of object judge_sitepose() tests.
struct ObjectKind {
  // An articulated machine seen moving lately (is_working): a few points that
  // show motion on their own make it moving, as many that disagree are doubt.
  bool working = false;
  // A machine whose upper structure turns on its undercarriage
  // (turns_on_undercarriage): points in the image rows from this one down
  // lie on the undercarriage and cannot prove it static alone.
  std::optional<double> undercarriage_from_v_px;
};

// The kind of object an instance of `class_name` is: `working` as
// MotionClassifier tracks it, and for a machine whose upper structure turns
// on its undercarriage (an excavator) where its box (in `boxes`) shows it.
ObjectKind object_kind(const std::string& class_name, bool working, const std::vector<ObjectBox>& boxes,
                       std::uint16_t instance);

// Paper mode (Algorithm 2) on one object's point errors (m); see the .cpp.
std::vector<double> judge_paper(std::vector<double> errors_m, const config::DynamicConfig& config,
                                ObjectVerdict& v);

// Sitepose mode on one object's matched points; see the .cpp.
UnknownReason judge_sitepose(const std::vector<PointDisplacement>& points,
                             const config::DynamicConfig& config, int min_points, ObjectKind kind,
                             ObjectVerdict& v, std::vector<double>& statistics);

// The points' displacement lengths (m), for paper mode.
std::vector<double> errors_m_of(const std::vector<PointDisplacement>& points);

}  // namespace sitepose::dynamic::detail
