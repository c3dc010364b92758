// `sitepose top`: a live terminal view of a running siteposed, from its LCM
// health and pose channels (views/top_view.hpp). Plain ANSI: works over SSH.
// q or Ctrl-C quits and gives the terminal back as it was.

#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <csignal>
#include <cstdio>

#include "command_registry.hpp"
#include "sitepose/output/lcm_bus.hpp"
#include "sitepose/views/top_view.hpp"

namespace sitepose::cli {
namespace {

constexpr const char* kCommand = "top";

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

struct TopArgs {
  std::string url;
  output::LcmOptions channels;
  bool once = false;
  double timeout_s = 5.0;
  double interval_s = 0.5;
  bool no_colour = false;
};

// Raw keyboard input while the view runs; the old settings come back on
// destruction (also after Ctrl-C, which only sets g_stop).
class RawTerminal {
 public:
  RawTerminal() {
    if (isatty(STDIN_FILENO) == 0 || tcgetattr(STDIN_FILENO, &old_) != 0) return;
    termios raw = old_;
    raw.c_lflag &= ~static_cast<tcflag_t>(ICANON | ECHO);
    raw.c_cc[VMIN] = 0;
    raw.c_cc[VTIME] = 0;
    active_ = tcsetattr(STDIN_FILENO, TCSANOW, &raw) == 0;
  }
  ~RawTerminal() {
    if (active_) tcsetattr(STDIN_FILENO, TCSANOW, &old_);
  }
  RawTerminal(const RawTerminal&) = delete;
  RawTerminal& operator=(const RawTerminal&) = delete;

  bool quit_pressed() const {
    pollfd fd{STDIN_FILENO, POLLIN, 0};
    char c = 0;
    return poll(&fd, 1, 0) > 0 && read(STDIN_FILENO, &c, 1) == 1 && (c == 'q' || c == 'Q');
  }

 private:
  termios old_{};
  bool active_ = false;
};

int snapshot(views::TopMonitor& monitor, const TopArgs& args) {
  const auto deadline = views::TopClock::now() + std::chrono::duration<double>(args.timeout_s);
  while (views::TopClock::now() < deadline && g_stop == 0) {
    const auto& s = monitor.state();
    if (s.health && s.pose) break;
    if (!monitor.handle(50)) break;  // an LCM failure or the end of a log
  }
  const auto& s = monitor.state();
  std::fputs(views::render_top(s, views::TopClock::now(), !args.no_colour && isatty(STDOUT_FILENO)).c_str(),
             stdout);
  if (!s.health && !s.pose) {
    return fail(kCommand,
                "nothing received on " + args.channels.pose_channel + " or " + args.channels.health_channel +
                    " within " + std::to_string(args.timeout_s) + " s",
                1);
  }
  return 0;
}

int live(views::TopMonitor& monitor, const TopArgs& args) {
  RawTerminal terminal;
  const bool colour = !args.no_colour;
  std::fputs("\x1b[?25l", stdout);  // cursor hidden while drawing
  auto next_draw = views::TopClock::now();
  while (g_stop == 0 && !terminal.quit_pressed()) {
    if (!monitor.handle(50)) break;
    if (views::TopClock::now() < next_draw) continue;
    next_draw +=
        std::chrono::duration_cast<views::TopClock::duration>(std::chrono::duration<double>(args.interval_s));
    std::string screen = views::render_top(monitor.state(), views::TopClock::now(), colour);
    std::string framed = "\x1b[H";
    for (const char c : screen) framed += c == '\n' ? std::string("\x1b[K\n") : std::string(1, c);
    framed += "\x1b[J";
    std::fputs(framed.c_str(), stdout);
    std::fflush(stdout);
  }
  std::fputs("\x1b[?25h\n", stdout);
  return 0;
}

int run(const TopArgs& args) {
  if (auto st = args.channels.validate("top"); !st) return fail(kCommand, st.error().message, 2);
  auto lcm = output::open_lcm(args.url);
  if (!lcm) return fail(kCommand, lcm.error().message, 1);
  auto monitor = views::TopMonitor::create(*lcm, args.channels.pose_channel, args.channels.health_channel);
  if (!monitor) return fail(kCommand, monitor.error().message, 1);
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  if (!args.once) std::fputs("\x1b[2J", stdout);
  return args.once ? snapshot(**monitor, args) : live(**monitor, args);
}

void add_options(CLI::App& sub, TopArgs& args) {
  sub.add_option("--lcm-url", args.url,
                 "LCM provider URL (default: LCM_DEFAULT_URL or udpm://239.255.76.67:7667; a log: "
                 "file:///path.lcmlog?speed=0)");
  sub.add_option("--pose-channel", args.channels.pose_channel, "pose_t channel")->capture_default_str();
  sub.add_option("--health-channel", args.channels.health_channel, "health_t channel")->capture_default_str();
  sub.add_flag("--once", args.once,
               "Print one snapshot once a health and a pose arrived (or --timeout-s passed) and exit; "
               "exit 1 when "
               "nothing arrived");
  sub.add_option("--timeout-s", args.timeout_s, "How long --once waits")->capture_default_str();
  add_bounded(sub, "--interval-s", args.interval_s, "Refresh interval", 0.05, 60.0);
  sub.add_flag("--no-colour", args.no_colour, "No ANSI colours");
}

const CommandRegistrar kTop{make_command<TopArgs>(
    "", "top", add_options, run, "Live terminal view of a running siteposed (LCM health and pose channels)")};

}  // namespace
}  // namespace sitepose::cli
