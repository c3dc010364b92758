#include "sitepose/experiments/roc.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "sitepose/dynamic/motion_classifier.hpp"

namespace sitepose::experiments {

std::vector<RocPoint> roc_curve(const std::vector<ObjectSample>& samples,
                                const std::vector<double>& thresholds, double fraction, int min_points) {
  std::vector<RocPoint> out;
  for (double threshold : thresholds) {
    int tp = 0, fn = 0, fp = 0, tn = 0;
    for (const auto& s : samples) {
      if (!s.moving_gt) continue;
      const auto& stats = s.object.statistics;
      const bool predicted_static =
          static_cast<int>(stats.size()) >= min_points && dynamic::is_static_at(stats, threshold, fraction);
      if (!*s.moving_gt) {
        (predicted_static ? tp : fn)++;
      } else {
        (predicted_static ? fp : tn)++;
      }
    }
    RocPoint p;
    p.threshold = threshold;
    p.tpr = tp + fn > 0 ? static_cast<double>(tp) / (tp + fn) : 0.0;
    p.fpr = fp + tn > 0 ? static_cast<double>(fp) / (fp + tn) : 0.0;
    out.push_back(p);
  }
  return out;
}

double roc_auc(std::vector<RocPoint> curve) {
  curve.push_back({0.0, 0.0, 0.0});
  curve.push_back({0.0, 1.0, 1.0});
  std::sort(curve.begin(), curve.end(), [](const RocPoint& a, const RocPoint& b) {
    return a.fpr != b.fpr ? a.fpr < b.fpr : a.tpr < b.tpr;
  });
  double area = 0.0;
  for (std::size_t i = 1; i < curve.size(); ++i) {
    area += (curve[i].fpr - curve[i - 1].fpr) * 0.5 * (curve[i].tpr + curve[i - 1].tpr);
  }
  return area;
}

namespace {

bool selected(const ObjectSample& s, const std::string& class_name) {
  return s.moving_gt.has_value() && (class_name.empty() || s.object.verdict.class_name == class_name);
}

double motion_score(const dynamic::ObjectVerdict& v, int min_points) {
  if (v.matched_points < min_points) return std::numeric_limits<double>::infinity();
  return std::max(v.score, v.part_statistic);
}

}  // namespace

double StateScores::balanced_accuracy() const {
  const int statics = static_called_static + static_called_moving;
  const int movings = moving_called_moving + moving_called_static;
  if (statics == 0 || movings == 0) return std::nan("");
  return 0.5 * (static_cast<double>(static_called_static) / statics +
                static_cast<double>(moving_called_moving) / movings);
}

double StateScores::unknown_share() const {
  return testable > 0 ? static_cast<double>(unknown_testable) / testable : 0.0;
}

StateScores score_states(const std::vector<ObjectSample>& samples, int min_points,
                         const std::string& class_name) {
  StateScores out;
  for (const ObjectSample& s : samples) {
    if (!selected(s, class_name)) continue;
    const dynamic::ObjectVerdict& v = s.object.verdict;
    ++out.samples;
    const bool testable = v.matched_points >= min_points;
    out.testable += testable ? 1 : 0;
    switch (v.state) {
      case dynamic::MotionState::kUnknown:
        out.unknown_testable += testable ? 1 : 0;
        ++out.unknown_by_reason[dynamic::to_string(v.unknown_reason)];
        break;
      case dynamic::MotionState::kStatic:
        (*s.moving_gt ? out.moving_called_static : out.static_called_static)++;
        break;
      case dynamic::MotionState::kMoving:
        (*s.moving_gt ? out.moving_called_moving : out.static_called_moving)++;
        break;
    }
  }
  out.auc = score_auc(samples, min_points, class_name, true);
  out.auc_all = score_auc(samples, min_points, class_name, false);
  return out;
}

double score_auc(const std::vector<ObjectSample>& samples, int min_points, const std::string& class_name,
                 bool testable_only) {
  std::vector<double> statics, movings;
  for (const ObjectSample& s : samples) {
    if (!selected(s, class_name)) continue;
    if (testable_only && s.object.verdict.matched_points < min_points) continue;
    (*s.moving_gt ? movings : statics).push_back(motion_score(s.object.verdict, min_points));
  }
  if (statics.empty() || movings.empty()) return std::nan("");
  std::sort(movings.begin(), movings.end());
  double wins = 0.0;
  for (double st : statics) {
    // Moving samples scoring above this static one, ties half.
    const auto lo = std::lower_bound(movings.begin(), movings.end(), st);
    const auto hi = std::upper_bound(movings.begin(), movings.end(), st);
    wins += static_cast<double>(movings.end() - hi) + 0.5 * static_cast<double>(hi - lo);
  }
  return wins / (static_cast<double>(statics.size()) * static_cast<double>(movings.size()));
}

}  // namespace sitepose::experiments
