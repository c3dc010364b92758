#pragma once
// ROC figures of the motion-state classifier from a run's object samples
// (`sitepose ablate roc`, the regression tests).

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
std::vector<RocPoint> roc_curve(const std::vector<ObjectSample>& samples, const std::vector<double>& thresholds,
                                double fraction, int min_points);
// Area under the curve by the trapezoid rule, (0,0) and (1,1) added.
double roc_auc(std::vector<RocPoint> curve);

}  // namespace sitepose::experiments
