// `sitepose ablate occlusion-sweep`: the paper's toy experiment behind
// tau_mar = 0.5 (METHOD.md "Hierarchical masking"): a fake centred
// occlusion of growing area ratio is masked on a static sequence; ATE and
// lost frames against the ratio. Paper: flat to 0.6, exponential above 0.7.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "ablation_command.hpp"
#include "command_registry.hpp"
#include "sitepose/config/config.hpp"
#include "sitepose/experiments/charts.hpp"
#include "sitepose/experiments/dynamic_run.hpp"

namespace sitepose::cli {
namespace {

constexpr const char* kCommand = "ablate occlusion-sweep";
// Instance id of the fake occluder (above any simulated object's).
constexpr std::uint16_t kOccluderInstance = 65000;

struct Args {
  AblationArgs common;
  std::vector<double> ratios{0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8};
};

int run(const Args& args) {
  for (double r : args.ratios) {
    if (!(r >= 0.0 && r < 1.0))
      return fail(kCommand, "--ratios: " + std::to_string(r) + " is not in [0, 1)", 2);
  }
  auto inputs = open_ablation_inputs(args.common);
  if (!inputs) return fail(kCommand, inputs.error().message, 2);
  config::SiteposeConfig& config = inputs->config;
  const auto& source = inputs->source;
  // Box masking of the occluder only: the sequence's own machines stay
  // unmasked, so the curve isolates the effect of masked area.
  config.dynamic.mode = config::MaskingMode::kBbox;
  config.dynamic.dynamic_classes = {"occluder"};
  const cv::Size size(source->camera().width, source->camera().height);

  std::ostringstream csv;
  csv << "occlusion_ratio,ate_rmse_m,ate_max_m,frames,frames_ok,frames_lost,coverage\n";
  experiments::ChartSeries ate{"ATE RMSE (m)", {}, {}, {200, 80, 30}};
  experiments::ChartSeries lost{"lost frames (share)", {}, {}, {30, 30, 200}};
  for (double ratio : args.ratios) {
    const int w = static_cast<int>(std::lround(size.width * std::sqrt(ratio)));
    const int h = static_cast<int>(std::lround(size.height * std::sqrt(ratio)));
    const cv::Rect box((size.width - w) / 2, (size.height - h) / 2, w, h);
    experiments::DynamicRunOptions options;
    options.alter = [&](experiments::LabelledFrame& f) {
      f.objects.boxes.clear();
      if (box.area() > 0) f.objects.boxes.push_back({kOccluderInstance, "occluder", 1.0, box});
    };
    auto result = experiments::run_dynamic(*source, config, options);
    if (!result) return fail(kCommand, result.error().message, 1);
    const int ok = result->recorder.frames_ok();
    const int lost_frames = static_cast<int>(
        std::count_if(result->recorder.poses().begin(), result->recorder.poses().end(),
                      [](const PoseEstimate& p) { return p.state == TrackingState::kLost; }));
    const double max_m = result->ate_max_m();
    csv << ratio << ',' << result->ate_m() << ',' << max_m << ',' << result->frames << ',' << ok << ','
        << lost_frames << ',' << result->coverage_ok() << '\n';
    std::printf("occlusion %.2f (mask %.3f of the image): ATE %.4f m (max %.4f), OK %d/%d, lost %d\n", ratio,
                result->max_masked_ratio, result->ate_m(), max_m, ok, result->frames, lost_frames);
    std::fflush(stdout);
    ate.x.push_back(ratio);
    ate.y.push_back(result->ate_m());
    lost.x.push_back(ratio);
    lost.y.push_back(result->frames > 0 ? static_cast<double>(lost_frames) / result->frames : NAN);
  }
  const std::string csv_path = args.common.out_dir + "/occlusion_sweep.csv";
  const std::string png_ate = args.common.out_dir + "/occlusion_sweep_ate.png";
  const std::string png_lost = args.common.out_dir + "/occlusion_sweep_lost.png";
  if (auto st = experiments::write_text(csv_path, csv.str()); !st)
    return fail(kCommand, st.error().message, 1);
  experiments::ChartOptions chart;
  chart.title = "Occlusion sweep on " + source_title(*source) + ": ATE vs centred masked ratio";
  chart.x_label = "occlusion ratio";
  chart.y_label = "ATE RMSE (m)";
  if (auto st = experiments::write_png(png_ate, experiments::render_line_chart({ate}, chart)); !st) {
    return fail(kCommand, st.error().message, 1);
  }
  chart.title = "Occlusion sweep on " + source_title(*source) + ": lost frames vs centred masked ratio";
  chart.y_label = "share of frames LOST";
  if (auto st = experiments::write_png(png_lost, experiments::render_line_chart({lost}, chart)); !st) {
    return fail(kCommand, st.error().message, 1);
  }
  std::printf("wrote %s, %s, %s\n", csv_path.c_str(), png_ate.c_str(), png_lost.c_str());
  return 0;
}

void add_options(CLI::App& sub, Args& args) {
  add_ablation_options(
      sub, args.common,
      {"static", "Sequence directory with labels", "sitepose YAML config (mode and classes are set here)",
       "occlusion_sweep.csv and two PNGs"});
  sub.add_option("--ratios", args.ratios, "Occlusion area ratios (default 0 0.1 ... 0.8)");
}

const CommandRegistrar kOcclusion{make_command<Args>(
    "ablate", "occlusion-sweep", add_options, run,
    "Fake centred occlusion 0..0.8 masked on a static sequence: ATE and lost frames (CSV + PNG)")};

}  // namespace
}  // namespace sitepose::cli
