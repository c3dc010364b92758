// `sitepose view`: an annotated video (or PNG frames) of a run recorded with
// `sitepose run --debug-out`, with the top view of the trajectory beside it.

#include <unistd.h>

#include <cstdio>
#include <filesystem>

#include "command_registry.hpp"
#include "sitepose/io/sequence.hpp"
#include "sitepose/views/view_writer.hpp"

namespace sitepose::cli {
namespace {

constexpr const char* kCommand = "view";

struct ViewArgs {
  std::string sequence;
  std::string run;
  std::string out;
  std::string frames;
  double fps = 0.0;
  double scale = 1.0;
  bool quiet = false;
};

void print_progress(std::size_t done, std::size_t total, bool tty) {
  if (tty) {
    const int width = 30;
    const int filled = static_cast<int>(width * done / std::max<std::size_t>(total, 1));
    std::fprintf(stderr, "\rview [%s%s] %zu/%zu frames", std::string(filled, '#').c_str(),
                 std::string(width - filled, '.').c_str(), done, total);
    if (done == total) std::fprintf(stderr, "\n");
  } else if (done % 50 == 0 || done == total) {
    std::fprintf(stderr, "view: %zu/%zu frames\n", done, total);
  }
}

int run(const ViewArgs& args) {
  views::ViewRequest request;
  request.out = args.out.empty() ? (std::filesystem::path(args.run) / "view.avi").string() : args.out;
  request.fps = args.fps;
  request.scale = args.scale;
  if (!args.frames.empty()) {
    auto range = views::parse_frame_range(args.frames);
    if (!range) return fail(kCommand, range.error().message, 2);
    request.range = *range;
  }
  auto record = views::read_debug_record(args.run);
  if (!record) return fail(kCommand, "--run: " + record.error().message, 2);
  auto sequence = io::open_sequence(args.sequence);
  if (!sequence) return fail(kCommand, sequence.error().message, 2);
  const bool tty = isatty(STDERR_FILENO) != 0;
  if (!args.quiet)
    request.on_frame = [tty](std::size_t done, std::size_t total) { print_progress(done, total, tty); };
  auto written = views::write_view(*record, **sequence, request);
  if (!written) return fail(kCommand, written.error().message, written.error().exit_status());
  std::printf("wrote %s: %zu frames, %dx%d\n", request.out.c_str(), written->frames, written->width,
              written->height);
  return 0;
}

void add_options(CLI::App& sub, ViewArgs& args) {
  sub.add_option("--sequence", args.sequence, "The sequence the run tracked")->required();
  sub.add_option("--run", args.run, "The run's --debug-out folder")->required();
  sub.add_option("--out", args.out,
                 "FILE.avi (Motion-JPEG), FILE.mp4 (MPEG-4, needs OpenCV's FFmpeg backend) or a folder for "
                 "NNNNNN.png (default: RUN/view.avi)");
  sub.add_option("--frames", args.frames, "A:B, frames A to B-1 of the run (default: all)");
  sub.add_option("--fps", args.fps, "Video frame rate (default: the sequence's)");
  add_bounded(sub, "--scale", args.scale, "Output size relative to the drawn frame", 0.1, 4.0);
  sub.add_flag("--quiet", args.quiet, "No progress bar");
}

const CommandRegistrar kView{make_command<ViewArgs>(
    "", "view", add_options, run, "Annotated video or PNG frames of a run recorded with run --debug-out")};

}  // namespace
}  // namespace sitepose::cli
