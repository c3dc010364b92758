#pragma once
// ROC figures of the motion-state classifier from a run's object samples
// (`sitepose ablate roc`, the regression tests).

#include <map>
#include <string>
#include <vector>

#include "sitepose/experiments/dynamic_run.hpp"

namespace sitepose::experiments {

// ROC of "static" as positive over thresholds applied to the per-point
// statistics (is_static_at), for samples with ground truth; points with
// too few statistics count as predicted not static.
struct RocPoint {
  double threshold = 0.0;
  double tpr = 0.0;  // static predicted static
  double fpr = 0.0;  // moving predicted static
};
std::vector<RocPoint> roc_curve(const std::vector<ObjectSample>& samples,
                                const std::vector<double>& thresholds, double fraction, int min_points);
// Area under the curve by the trapezoid rule, (0,0) and (1,1) added.
double roc_auc(std::vector<RocPoint> curve);

// The smoothed verdicts (ObjectVerdict::state, what masking uses) against
// the ground truth, over the samples with a ground-truth flag of one class
// (empty: every class). "Testable": at least min_points matched points.
struct StateScores {
  int samples = 0;
  int testable = 0;
  int unknown_testable = 0;  // testable samples left unknown
  int static_called_static = 0, static_called_moving = 0;
  int moving_called_moving = 0, moving_called_static = 0;  // the last: the unsafe error
  std::map<std::string, int> unknown_by_reason;            // every unknown sample, by reason
  double auc = 0.5;      // score_auc over the same samples, testable ones only
  double auc_all = 0.5;  // ... and with the untestable ones (scored +inf)

  // Mean of the static and the moving recall over decided verdicts; NaN
  // when a class of truth has no decided verdict.
  double balanced_accuracy() const;
  double unknown_share() const;  // unknown_testable / testable (0 when none)
};
StateScores score_states(const std::vector<ObjectSample>& samples, int min_points,
                         const std::string& class_name = "");
// ROC AUC of one scalar motion score per sample (the larger, the more
// moving): the 70 % quantile of the tested points' statistics, or the moving
// part's statistic when larger. Samples with fewer than min_points matched
// points have no score: left out when testable_only, else scored +inf
// (never static). Ties count half (Mann-Whitney).
double score_auc(const std::vector<ObjectSample>& samples, int min_points, const std::string& class_name = "",
                 bool testable_only = true);

}  // namespace sitepose::experiments
