// `sitepose ablate roc`: motion-state classification as a detector of
// "static" (positive) against the simulator's ground-truth moving flags.
// Paper mode: sigma_bkg swept over [0, 0.6] m (threshold 3 sigma_bkg; paper
// AUC 0.737 on chiba1). sitepose mode: its own threshold, the chi2 gate on
// squared Mahalanobis distances, swept over [0.01, 1e5]. One run per mode
// (mode full, default settings); the sweep re-applies the decision rule to
// each object's per-point statistics (dynamic::is_static_at).

#include <cmath>
#include <cstdio>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "ablation_command.hpp"
#include "command_registry.hpp"
#include "sitepose/config/config.hpp"
#include "sitepose/experiments/charts.hpp"
#include "sitepose/experiments/dynamic_run.hpp"
#include "sitepose/experiments/roc.hpp"

namespace sitepose::cli {
namespace {

constexpr const char* kCommand = "ablate roc";

// The smoothed verdicts per class (and all together) with the unknown
// verdicts by reason: one CSV row each, one printed line each.
void add_state_rows(const char* classifier, const std::vector<experiments::ObjectSample>& samples,
                    int min_points, std::ostringstream& csv) {
  std::set<std::string> classes{""};
  for (const auto& s : samples) classes.insert(s.object.verdict.class_name);
  for (const std::string& c : classes) {
    const experiments::StateScores sc = experiments::score_states(samples, min_points, c);
    const auto reason = [&](const char* r) {
      const auto it = sc.unknown_by_reason.find(r);
      return it == sc.unknown_by_reason.end() ? 0 : it->second;
    };
    csv << classifier << ',' << (c.empty() ? "all" : c) << ',' << sc.samples << ',' << sc.testable << ','
        << sc.unknown_share() << ',' << sc.balanced_accuracy() << ',' << sc.auc << ',' << sc.auc_all << ','
        << sc.static_called_static << ',' << sc.static_called_moving << ',' << sc.moving_called_moving << ','
        << sc.moving_called_static << ',' << reason("no_reference") << ',' << reason("too_few_points") << ','
        << reason("ambiguous") << ',' << reason("settling") << '\n';
    std::printf(
        "  %-9s %-10s balanced accuracy %.3f  AUC %.3f (with untestable %.3f)  unknown %.1f %% of %d "
        "testable  "
        "moving called static %d  unknown: no reference %d, too few points %d, ambiguous %d, settling %d\n",
        classifier, c.empty() ? "all" : c.c_str(), sc.balanced_accuracy(), sc.auc, sc.auc_all,
        100.0 * sc.unknown_share(), sc.testable, sc.moving_called_static, reason("no_reference"),
        reason("too_few_points"), reason("ambiguous"), reason("settling"));
  }
}

int run(const AblationArgs& args, config::SiteposeConfig& config, const experiments::LabelledSource& source) {
  config.dynamic.mode = config::MaskingMode::kFull;

  std::ostringstream csv, summary, states;
  states << "classifier,class,samples,testable,unknown_share,balanced_accuracy,auc,auc_with_untestable,"
            "static_called_static,"
            "static_called_moving,moving_called_moving,moving_called_static,unknown_no_reference,"
            "unknown_too_few_points,unknown_ambiguous,unknown_settling\n";
  csv << "classifier,parameter,parameter_value,threshold,tpr,fpr\n";
  summary << "classifier,auc,samples,static_samples,moving_samples,ate_rmse_m\n";
  std::vector<experiments::ChartSeries> curves;
  for (config::ClassifierMode classifier :
       {config::ClassifierMode::kPaper, config::ClassifierMode::kSitepose}) {
    config.dynamic.classifier = classifier;
    auto result = experiments::run_dynamic(source, config);
    if (!result) return fail(kCommand, result.error().message, 1);
    const bool paper = classifier == config::ClassifierMode::kPaper;
    std::vector<double> parameters, thresholds;
    if (paper) {
      for (int i = 0; i <= 120; ++i) parameters.push_back(0.005 * i);  // sigma_bkg, m
      for (double s : parameters) thresholds.push_back(3.0 * s);
    } else {
      for (int i = 0; i <= 140; ++i) parameters.push_back(std::pow(10.0, -2.0 + 0.05 * i));  // chi2 gate
      thresholds = parameters;
    }
    const auto curve = experiments::roc_curve(
        result->samples, thresholds, config.dynamic.static_inlier_fraction, config.dynamic.min_object_points);
    const double auc = experiments::roc_auc(curve);
    int positives = 0, negatives = 0;
    for (const auto& s : result->samples) {
      if (s.moving_gt) (*s.moving_gt ? negatives : positives)++;
    }
    experiments::ChartSeries series{
        std::string(paper ? "paper (sigma_bkg 0..0.6 m)" : "sitepose (chi2 gate)") + ", AUC " +
            std::to_string(auc).substr(0, 5),
        {},
        {},
        paper ? cv::Scalar(30, 30, 200) : cv::Scalar(200, 90, 30)};
    for (std::size_t i = 0; i < curve.size(); ++i) {
      csv << config::to_string(classifier) << ',' << (paper ? "sigma_bkg_m" : "chi2_gate") << ','
          << parameters[i] << ',' << curve[i].threshold << ',' << curve[i].tpr << ',' << curve[i].fpr << '\n';
      series.x.push_back(curve[i].fpr);
      series.y.push_back(curve[i].tpr);
    }
    curves.push_back(series);
    summary << config::to_string(classifier) << ',' << auc << ',' << positives + negatives << ',' << positives
            << ',' << negatives << ',' << result->ate_m() << '\n';
    std::printf("%-9s AUC %.3f over %d object-frames (%d static, %d moving); run ATE %.4f m\n",
                config::to_string(classifier), auc, positives + negatives, positives, negatives,
                result->ate_m());
    add_state_rows(config::to_string(classifier), result->samples, config.dynamic.min_object_points, states);
    std::fflush(stdout);
  }
  const std::string states_path = args.out_dir + "/roc_states.csv";
  if (auto st = experiments::write_text(states_path, states.str()); !st)
    return fail(kCommand, st.error().message, 1);
  const std::string csv_path = args.out_dir + "/roc.csv";
  const std::string summary_path = args.out_dir + "/roc_auc.csv";
  const std::string png_path = args.out_dir + "/roc.png";
  if (auto st = experiments::write_text(csv_path, csv.str()); !st)
    return fail(kCommand, st.error().message, 1);
  if (auto st = experiments::write_text(summary_path, summary.str()); !st)
    return fail(kCommand, st.error().message, 1);
  experiments::ChartOptions chart;
  chart.title = "Motion states on " + source_title(source) + ": ROC, static = positive";
  chart.x_label = "false positive rate (moving called static)";
  chart.y_label = "true positive rate";
  chart.draw_diagonal = true;
  chart.markers = false;
  if (auto st = experiments::write_png(png_path, experiments::render_line_chart(curves, chart)); !st) {
    return fail(kCommand, st.error().message, 1);
  }
  std::printf("wrote %s, %s, %s\n", csv_path.c_str(), summary_path.c_str(), png_path.c_str());
  return 0;
}

const CommandRegistrar kRoc{ablation_command(
    "roc",
    "ROC of the motion-state classifier (static = positive), paper mode (sigma_bkg 0..0.6) and "
    "sitepose mode (chi2 gate), with AUC (CSV + PNG)",
    {"crowded", "Sequence directory with labels (boxes with moving flags, masks)",
     "sitepose YAML config (mode and classifier are set here)",
     "roc.csv, roc_auc.csv, roc_states.csv (per class and unknown reason), roc.png"},
    run)};

}  // namespace
}  // namespace sitepose::cli
