// `sitepose ablate unmask`: the paper's Table 3 — every a-priori dynamic
// object masked (hierarchical, one pass) vs static objects unmasked (full:
// motion states + two passes); bbox beside them for reference.

#include <cstdio>
#include <numeric>
#include <sstream>

#include "ablation_command.hpp"
#include "command_registry.hpp"
#include "sitepose/config/config.hpp"
#include "sitepose/experiments/charts.hpp"
#include "sitepose/experiments/dynamic_run.hpp"

namespace sitepose::cli {
namespace {

constexpr const char* kCommand = "ablate unmask";

int run(const AblationArgs& args, config::SiteposeConfig& config, const experiments::LabelledSource& source) {
  std::ostringstream csv;
  csv << "variant,mode,ate_rmse_m,ate_max_m,coverage,mean_static_objects_unmasked,mean_features_pass1,"
         "mean_features_final\n";
  std::vector<std::string> labels;
  std::vector<double> ates;
  const std::pair<const char*, config::MaskingMode> variants[] = {
      {"bbox", config::MaskingMode::kBbox},
      {"all masked", config::MaskingMode::kHierarchical},
      {"static unmasked", config::MaskingMode::kFull}};
  for (const auto& [name, mode] : variants) {
    config.dynamic.mode = mode;
    auto result = experiments::run_dynamic(source, config);
    if (!result) return fail(kCommand, result.error().message, 1);
    double unmasked = 0, f1 = 0, f2 = 0;
    for (const PoseEstimate& p : result->recorder.poses()) {
      unmasked += p.counters.static_objects_unmasked;
      f1 += p.counters.features_used_pass1;
      f2 += p.counters.features_used;
    }
    const double n = std::max(1, result->frames);
    const double max_m = result->ate_max_m();
    csv << name << ',' << config::to_string(mode) << ',' << result->ate_m() << ',' << max_m << ','
        << result->coverage_ok() << ',' << unmasked / n << ',' << f1 / n << ',' << f2 / n << '\n';
    std::printf(
        "%-16s ATE %.4f m (max %.4f)  coverage %.1f %%  static objects unmasked %.2f/frame  "
        "features pass 1 %.0f, final %.0f\n",
        name, result->ate_m(), max_m, 100.0 * result->coverage_ok(), unmasked / n, f1 / n, f2 / n);
    std::fflush(stdout);
    labels.push_back(name);
    ates.push_back(result->ate_m());
  }
  experiments::ChartOptions chart;
  chart.title = "Unmasking static objects on " + source_title(source) + ": ATE RMSE (m)";
  return write_csv_and_png(kCommand, args.out_dir, "unmask", csv.str(),
                           experiments::render_bar_chart(labels, ates, chart));
}

const CommandRegistrar kUnmask{ablation_command(
    "unmask", "All dynamic-class objects masked vs static ones unmasked (two passes): ATE (CSV + PNG)",
    {"parked", "Sequence directory with labels (boxes and masks)",
     "sitepose YAML config (the mode is set here)", "unmask.csv, unmask.png"},
    run)};

}  // namespace
}  // namespace sitepose::cli
