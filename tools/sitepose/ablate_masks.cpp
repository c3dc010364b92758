// `sitepose ablate masks`: the paper's Table 2 — box, hierarchical and pixel
// masking compared by ATE, the largest masked ratio and time per frame.

#include <cstdio>
#include <sstream>

#include <opencv2/core.hpp>

#include "ablation_command.hpp"
#include "command_registry.hpp"
#include "sitepose/config/config.hpp"
#include "sitepose/experiments/charts.hpp"
#include "sitepose/experiments/dynamic_run.hpp"

namespace sitepose::cli {
namespace {

constexpr const char* kCommand = "ablate masks";

int run(const AblationArgs& args, config::SiteposeConfig& config, const experiments::LabelledSource& source) {
  std::ostringstream csv;
  csv << "mode,ate_rmse_m,ate_max_m,coverage,max_masked_ratio,max_mar,pixel_mask_calls,frames,"
         "mask_ms_mean,frame_ms_mean\n";
  std::vector<std::string> labels;
  std::vector<double> ates, masked, frame_ms;
  for (config::MaskingMode mode :
       {config::MaskingMode::kBbox, config::MaskingMode::kHierarchical, config::MaskingMode::kPixel}) {
    config.dynamic.mode = mode;
    auto result = experiments::run_dynamic(source, config);
    if (!result) return fail(kCommand, result.error().message, 1);
    const auto stages = result->recorder.stage_summaries();
    const double mask_ms = stages.count("mask") ? stages.at("mask").mean_ms : 0.0;
    const double whole_ms = stages.count("whole_frame") ? stages.at("whole_frame").mean_ms : 0.0;
    const double max_m = result->ate_max_m();
    csv << config::to_string(mode) << ',' << result->ate_m() << ',' << max_m << ',' << result->coverage_ok()
        << ',' << result->max_masked_ratio << ',' << result->max_mar << ','
        << result->recorder.pixel_mask_calls() << ',' << result->frames << ',' << mask_ms << ',' << whole_ms
        << '\n';
    std::printf(
        "%-12s ATE %.4f m (max %.4f)  coverage %.1f %%  max masked ratio %.3f  pixel masks %d/%d  "
        "mask %.2f ms  frame %.1f ms\n",
        config::to_string(mode), result->ate_m(), max_m, 100.0 * result->coverage_ok(),
        result->max_masked_ratio, result->recorder.pixel_mask_calls(), result->frames, mask_ms, whole_ms);
    std::fflush(stdout);
    labels.push_back(config::to_string(mode));
    ates.push_back(result->ate_m());
    masked.push_back(result->max_masked_ratio);
    frame_ms.push_back(whole_ms);
  }
  experiments::ChartOptions chart;
  chart.height_px = 400;
  chart.title = "Masking on " + source_title(source) + ": ATE RMSE (m)";
  cv::Mat a = experiments::render_bar_chart(labels, ates, chart);
  chart.title = "Largest masked ratio of a frame";
  cv::Mat b = experiments::render_bar_chart(labels, masked, chart);
  chart.title = "Mean frame time (ms; masks from labels, no segmentation network)";
  cv::Mat c = experiments::render_bar_chart(labels, frame_ms, chart);
  cv::Mat all;
  cv::vconcat(std::vector<cv::Mat>{a, b, c}, all);
  return write_csv_and_png(kCommand, args.out_dir, "masks", csv.str(), all);
}

const CommandRegistrar kMasks{ablation_command(
    "masks", "bbox vs hierarchical vs pixel masks: ATE, largest masked ratio, time (CSV + PNG)",
    {"crowded", "Sequence directory with labels (boxes and masks)",
     "sitepose YAML config (the mode is set here)", "masks.csv, masks.png"},
    run)};

}  // namespace
}  // namespace sitepose::cli
