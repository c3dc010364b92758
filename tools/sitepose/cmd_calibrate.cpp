// `sitepose calibrate`: stereo calibration from chessboard or ChArUco views
// (DIR/left/NAME.png, DIR/right/NAME.png) into the OpenCV YAML file the
// camera sources read (calib/calibration_file.hpp). Exit status 0 ok,
// 1 failure while running or writing, 2 bad usage or too few usable views.

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "command_registry.hpp"
#include "sitepose/calib/calibration_file.hpp"
#include "sitepose/calib/stereo_calibrate.hpp"

namespace sitepose::cli {
namespace {

struct CalibrateArgs {
  std::string images;
  std::string board;
  std::string board_type = "chessboard";
  double square_m = 0.0;
  double marker_m = 0.0;
  std::string dictionary = calib::CharucoMarkers{}.dictionary;
  std::string out;
  int min_views = 5;
  bool free_k3 = false;
};

void print_views(const calib::CalibrationReport& report) {
  std::printf("%-24s %10s %10s\n", "view", "rms_left", "rms_right");
  for (const auto& v : report.views) {
    if (v.used) {
      std::printf("%-24s %10.3f %10.3f\n", v.name.c_str(), v.rms_left_px, v.rms_right_px);
    } else {
      std::printf("%-24s %21s\n", v.name.c_str(), ("skipped: " + v.why_skipped).c_str());
    }
  }
}

void print_result(const calib::CalibrationReport& report, const StereoCamera& rectified) {
  const auto& c = report.calibration;
  std::printf("views used    %d of %zu\n", report.views_used, report.views.size());
  std::printf("rms           %.3f px stereo (left alone %.3f, right alone %.3f)\n", c.rms_px,
              report.rms_left_px, report.rms_right_px);
  std::printf("left          fx %.2f fy %.2f cx %.2f cy %.2f\n", c.K1.at<double>(0, 0), c.K1.at<double>(1, 1),
              c.K1.at<double>(0, 2), c.K1.at<double>(1, 2));
  std::printf("right         fx %.2f fy %.2f cx %.2f cy %.2f\n", c.K2.at<double>(0, 0), c.K2.at<double>(1, 1),
              c.K2.at<double>(0, 2), c.K2.at<double>(1, 2));
  std::printf("baseline      %.4f m (T = %.4f %.4f %.4f)\n", cv::norm(c.T), c.T.at<double>(0),
              c.T.at<double>(1), c.T.at<double>(2));
  std::printf("rectified     f %.2f px, cx %.2f cy %.2f, %dx%d\n", rectified.fx, rectified.cx, rectified.cy,
              rectified.width, rectified.height);
}

// The board of --board, --square-m and, for --board-type charuco, --marker-m
// and --dictionary; the error names the options.
Expected<calib::BoardSpec> board_from_args(const CalibrateArgs& a) {
  std::optional<calib::CharucoMarkers> markers;
  if (a.board_type == "charuco") {
    markers = calib::CharucoMarkers{a.marker_m, a.dictionary};
  } else if (a.marker_m != 0.0 || a.dictionary != calib::CharucoMarkers{}.dictionary) {
    return make_error(ErrorCode::kInvalidArgument,
                      "--marker-m and --dictionary describe a ChArUco board; add --board-type charuco");
  }
  auto board = calib::parse_board(a.board, a.square_m, markers);
  if (!board) {
    return make_error(
        ErrorCode::kInvalidArgument,
        std::string(markers ? "--board/--square-m/--marker-m/--dictionary: " : "--board/--square-m: ") +
            board.error().message);
  }
  return board;
}

int run_calibrate(const CalibrateArgs& a) {
  const std::string cmd = "calibrate";
  auto board = board_from_args(a);
  if (!board) return fail(cmd, board.error().message, 2);
  const bool charuco = board->kind == calib::BoardKind::kCharuco;
  auto names = calib::list_calibration_views(a.images);
  if (!names) return fail(cmd, names.error().message, 2);
  calib::CalibrateOptions options;
  options.min_views = a.min_views;
  options.fix_k3 = !a.free_k3;
  const bool tty = isatty(STDERR_FILENO) != 0;
  options.progress = [tty](int done, int total, const calib::ViewResult& v) {
    if (!v.used) {
      std::fprintf(stderr, "%ssitepose calibrate: %s: %s, skipped\n", tty ? "\r" : "", v.name.c_str(),
                   v.why_skipped.c_str());
    }
    if (tty) {
      std::fprintf(stderr, "\rsitepose calibrate: corners %d/%d views%s", done, total,
                   done == total ? "\n" : "");
    } else if (done == total || done % std::max(1, total / 4) == 0) {
      std::fprintf(stderr, "sitepose calibrate: corners %d/%d views\n", done, total);
    }
  };
  char marker_text[96] = "";
  if (charuco) {
    std::snprintf(marker_text, sizeof(marker_text), ", %g m markers of %s", board->markers.marker_m,
                  board->markers.dictionary.c_str());
  }
  std::fprintf(stderr, "sitepose calibrate: %zu views in %s, %s %dx%d inner corners, %g m squares%s\n",
               names->size(), a.images.c_str(), a.board_type.c_str(), board->cols, board->rows,
               board->square_m, marker_text);
  auto report = calib::calibrate_stereo(
      names->size(), [&](std::size_t i) { return calib::load_calibration_view(a.images, (*names)[i]); },
      *board, options);
  if (!report) return fail(cmd, report.error().message, report.error().exit_status());
  auto rectified = calib::rectified_camera(report->calibration);
  if (!rectified) return fail(cmd, rectified.error().message, 1);
  print_views(*report);
  print_result(*report, *rectified);
  if (auto st = calib::write_stereo_calibration(a.out, report->calibration); !st) {
    return fail(cmd, st.error().message, 1);
  }
  std::printf("wrote         %s\n", a.out.c_str());
  return 0;
}

const CommandRegistrar kCalibrate{
    {"", "calibrate",
     "Stereo calibration from chessboard or ChArUco views: K1 D1 K2 D2 R T and the rectification, "
     "written as the OpenCV YAML file the camera sources read",
     [](CLI::App& sub) -> CommandAction {
       auto args = std::make_shared<CalibrateArgs>();
       sub.add_option("--images", args->images,
                      "Folder with left/NNNNNN.png and right/NNNNNN.png (same names, taken together)")
           ->type_name("DIR")
           ->required();
       sub.add_option("--board", args->board,
                      "Board inner corners, COLSxROWS (e.g. 9x6: 10 x 7 squares), for both board types")
           ->type_name("COLSxROWS")
           ->required();
       sub.add_option("--square-m", args->square_m, "Side of one board square (m)")
           ->type_name("S")
           ->required();
       sub.add_option("--board-type", args->board_type,
                      "chessboard: seen whole in both images; charuco: ArUco markers in the white squares, "
                      "usable when partly hidden or cut off (views use the corners both cameras see)")
           ->check(CLI::IsMember({"chessboard", "charuco"}))
           ->capture_default_str();
       sub.add_option("--marker-m", args->marker_m,
                      "ChArUco: side of one marker (m), smaller than --square-m")
           ->type_name("M");
       sub.add_option("--dictionary", args->dictionary, "ChArUco: the predefined OpenCV ArUco dictionary")
           ->check(CLI::IsMember(calib::charuco_dictionary_names()))
           ->capture_default_str();
       sub.add_option("--out", args->out, "Calibration file to write (OpenCV FileStorage YAML)")
           ->type_name("FILE.yaml")
           ->required();
       sub.add_option("--min-views", args->min_views, "Fewest views with the board found in both images")
           ->check(CLI::Range(3, 10000))
           ->capture_default_str();
       sub.add_flag("--free-k3", args->free_k3,
                    "Also fit the radial coefficient k3 (wide-angle lenses; needs many views)");
       return [args] { return run_calibrate(*args); };
     }}};

}  // namespace
}  // namespace sitepose::cli
