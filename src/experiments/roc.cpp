#include "sitepose/experiments/roc.hpp"

#include <algorithm>

#include "sitepose/dynamic/motion_classifier.hpp"

namespace sitepose::experiments {

std::vector<RocPoint> roc_curve(const std::vector<ObjectSample>& samples, const std::vector<double>& thresholds,
                                double fraction, int min_points) {
  std::vector<RocPoint> out;
  for (double threshold : thresholds) {
    int tp = 0, fn = 0, fp = 0, tn = 0;
    for (const auto& s : samples) {
      if (!s.moving_gt) continue;
      const auto& stats = s.object.statistics;
      const bool predicted_static = static_cast<int>(stats.size()) >= min_points &&
                                    dynamic::is_static_at(stats, threshold, fraction);
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

}  // namespace sitepose::experiments
