#include "sitepose/detect/isolated_detector.hpp"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <optional>
#include <thread>
#include <utility>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "sitepose/detect/plugin_calls.hpp"
#include "sitepose/detector_host/protocol.hpp"

extern char** environ;  // NOLINT(readability-redundant-declaration): posix_spawn's environment

namespace sitepose::detect {
namespace {

namespace dh = detector_host;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

// The fds the host finds its socket and memfd on (tools/sitepose-detector-host).
constexpr int kHostSocketFd = 3;
constexpr int kHostShmFd = 4;

class Fd {
 public:
  Fd() = default;
  explicit Fd(int fd) : fd_(fd) {}
  ~Fd() { reset(); }
  Fd(Fd&& o) noexcept : fd_(std::exchange(o.fd_, -1)) {}
  Fd& operator=(Fd&& o) noexcept {
    if (this != &o) {
      reset();
      fd_ = std::exchange(o.fd_, -1);
    }
    return *this;
  }
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  int get() const { return fd_; }
  void reset() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

 private:
  int fd_ = -1;
};

Error errno_error(const std::string& what) {
  return Error{ErrorCode::kRuntime, "detector host: " + what + ": " + std::strerror(errno)};
}

// Above the fds the child's dup2()s write to, so that none overwrites the other.
Expected<Fd> high_fd(int fd) {
  Fd owned(fd);
  const int moved = ::fcntl(fd, F_DUPFD_CLOEXEC, 10);
  if (moved < 0) return Unexpected{errno_error("fcntl(F_DUPFD_CLOEXEC)")};
  return Fd(moved);
}

std::string describe_exit(int status) {
  if (WIFSIGNALED(status)) {
    const char* name = sigdescr_np(WTERMSIG(status));
    return fmt::format("killed by signal {} ({})", WTERMSIG(status), name != nullptr ? name : "?");
  }
  if (WIFEXITED(status)) return fmt::format("exited with status {}", WEXITSTATUS(status));
  return "ended";
}

enum class Failure { kNone, kCrash, kHang };

struct CallResult {
  dh::Message reply;
  Failure failure = Failure::kNone;
  std::string why;  // when failure != kNone
};

// One running sitepose-detector-host.
class HostProcess {
 public:
  HostProcess(pid_t pid, Fd socket) : pid_(pid), socket_(std::move(socket)) {}
  ~HostProcess() {
    if (pid_ > 0) {
      socket_.reset();  // EOF: the host destroys the plugin and exits
      reap(false);
    }
  }
  HostProcess(const HostProcess&) = delete;
  HostProcess& operator=(const HostProcess&) = delete;

  pid_t pid() const { return pid_; }

  // The reply to `request` of type `expected`, or how the host failed; a
  // failed host is reaped (this object is then done with).
  CallResult call(const dh::Message& request, dh::MessageType expected, milliseconds timeout) {
    const std::uint32_t id = ++call_id_;
    if (!dh::send_message(socket_.get(), {id, request})) return died(false, "did not take the request");
    const auto until = Clock::now() + timeout;
    for (;;) {
      const auto left = std::chrono::ceil<milliseconds>(until - Clock::now());
      auto received =
          dh::receive_message(socket_.get(), static_cast<int>(std::max<std::int64_t>(0, left.count())));
      if (!received) return died(true, "sent garbage (" + received.error().message + ")");
      if (received->outcome == dh::ReceiveOutcome::kClosed) return died(false, "died");
      if (received->outcome == dh::ReceiveOutcome::kTimeout) {
        CallResult r = died(true, fmt::format("did not answer within {} ms", timeout.count()));
        r.failure = Failure::kHang;
        return r;
      }
      if (received->envelope.call_id != id) continue;  // an answer to an abandoned call
      if (dh::type_of(received->envelope.message) != expected) {
        return died(true,
                    std::string("answered with a ") + dh::to_string(dh::type_of(received->envelope.message)));
      }
      return CallResult{std::move(received->envelope.message), Failure::kNone, {}};
    }
  }

 private:
  CallResult died(bool kill_first, const std::string& what) {
    const pid_t pid = pid_;
    const std::string status = reap(kill_first);
    return CallResult{dh::Ready{}, Failure::kCrash,
                      fmt::format("detector host (pid {}) {}: {}", pid, what, status)};
  }

  // Waits for the host to end (up to 1 s after EOF, then SIGKILL).
  std::string reap(bool kill_first) {
    if (kill_first) ::kill(pid_, SIGKILL);
    int status = 0;
    for (int i = 0; i < 100; ++i) {
      const pid_t r = ::waitpid(pid_, &status, WNOHANG);
      if (r == pid_ || (r < 0 && errno != EINTR)) return finish(r == pid_, status);
      std::this_thread::sleep_for(milliseconds(10));
    }
    ::kill(pid_, SIGKILL);
    pid_t r = -1;
    do {
      r = ::waitpid(pid_, &status, 0);
    } while (r < 0 && errno == EINTR);
    return finish(r == pid_, status);
  }
  std::string finish(bool reaped, int status) {
    pid_ = -1;
    return reaped ? describe_exit(status) : "not reaped";
  }

  pid_t pid_;
  Fd socket_;
  std::uint32_t call_id_ = 0;
};

// Starts the host with the socket on fd 3 and the memfd on fd 4.
Expected<std::unique_ptr<HostProcess>> spawn_host(const std::string& host_path, int shm_fd) {
  int pair[2] = {-1, -1};
  if (::socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, pair) != 0) {
    return Unexpected{errno_error("socketpair")};
  }
  Fd ours(pair[0]);
  SITEPOSE_TRY(Fd theirs, high_fd(pair[1]));
  SITEPOSE_TRY(Fd shm, high_fd(::fcntl(shm_fd, F_DUPFD_CLOEXEC, 0)));
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, theirs.get(), kHostSocketFd);
  posix_spawn_file_actions_adddup2(&actions, shm.get(), kHostShmFd);
  posix_spawn_file_actions_adddup2(&actions, STDERR_FILENO, STDOUT_FILENO);
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  sigset_t none;
  sigset_t all;
  sigemptyset(&none);
  sigfillset(&all);
  posix_spawnattr_setsigmask(&attr, &none);
  posix_spawnattr_setsigdefault(&attr, &all);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
  const std::string parent = std::to_string(::getpid());
  std::string socket_arg = std::to_string(kHostSocketFd);
  std::string shm_arg = std::to_string(kHostShmFd);
  std::vector<char*> argv = {const_cast<char*>(host_path.c_str()),
                             const_cast<char*>("--socket-fd"),
                             socket_arg.data(),
                             const_cast<char*>("--shm-fd"),
                             shm_arg.data(),
                             const_cast<char*>("--parent-pid"),
                             const_cast<char*>(parent.c_str()),
                             nullptr};
  pid_t pid = -1;
  const int rc = ::posix_spawn(&pid, host_path.c_str(), &actions, &attr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attr);
  if (rc != 0) {
    return make_error(ErrorCode::kRuntime,
                      "detector host " + host_path + ": cannot start: " + std::strerror(rc));
  }
  return std::make_unique<HostProcess>(pid, std::move(ours));
}

// The plugin's calls, made in a sitepose-detector-host; restarts it after a
// crash or hang (see isolated_detector.hpp).
class IsolatedCalls final : public PluginCalls {
 public:
  IsolatedCalls(std::string host_path, dh::Init init, IsolationOptions options, Fd shm)
      : host_path_(std::move(host_path)),
        init_(std::move(init)),
        options_(std::move(options)),
        shm_(std::move(shm)),
        backoff_(options_.backoff_min) {
    if (!options_.counters) options_.counters = std::make_shared<HostCounters>();
  }
  ~IsolatedCalls() override {
    host_.reset();
    if (map_ != nullptr) ::munmap(map_, map_bytes_);
  }
  IsolatedCalls(const IsolatedCalls&) = delete;
  IsolatedCalls& operator=(const IsolatedCalls&) = delete;

  // The first start: its failure is the load's error.
  Status start() {
    SITEPOSE_TRY(host_, spawn_host(host_path_, shm_.get()));
    CallResult r = host_->call(init_, dh::MessageType::kReady, options_.start_timeout);
    if (r.failure != Failure::kNone) {
      host_.reset();
      return make_error(ErrorCode::kRuntime, "detector plugin " + init_.plugin_path + ": " + r.why);
    }
    const auto& ready = std::get<dh::Ready>(r.reply);
    if (ready.status != 0) {
      host_.reset();
      // The loader's own error, already naming the plugin.
      return make_error(dh::ready_error_code(ready.status), ready.error);
    }
    capabilities_ = ready.capabilities;
    return ok_status();
  }

  std::uint32_t capabilities() const override { return capabilities_; }
  pid_t host_pid() const { return host_ ? host_->pid() : -1; }

  int detect(const sp_image& left, const sp_image& right, std::int64_t t_ns, std::int64_t seq,
             sp_detection* out, std::int32_t capacity, std::int32_t* count, std::string& error) override {
    const dh::FrameRef frame{seq, t_ns, left.width, left.height};
    if (!ready_for(frame, left, right, error)) return -1;
    CallResult r =
        host_->call(dh::DetectRequest{frame, capacity}, dh::MessageType::kDetections, options_.call_timeout);
    if (r.failure != Failure::kNone) return lost(r, seq, error);
    auto& reply = std::get<dh::DetectReply>(r.reply);
    const auto n = std::min<std::size_t>(reply.detections.size(), static_cast<std::size_t>(capacity));
    std::copy_n(reply.detections.begin(), n, out);
    *count = reply.count;
    error = std::move(reply.error);
    backoff_ = options_.backoff_min;
    return reply.rc;
  }

  int segment(const sp_image& left, const sp_image& right, std::int64_t t_ns, std::int64_t seq,
              const sp_detection* detections, std::int32_t n_detections, std::uint16_t* mask,
              std::int32_t mask_stride_px, std::string& error) override {
    const dh::FrameRef frame{seq, t_ns, left.width, left.height};
    if (!ready_for(frame, left, right, error)) return -1;
    dh::SegmentRequest request{frame, {detections, detections + n_detections}};
    CallResult r = host_->call(request, dh::MessageType::kSegmented, options_.call_timeout);
    if (r.failure != Failure::kNone) return lost(r, seq, error);
    auto& reply = std::get<dh::SegmentReply>(r.reply);
    if (reply.rc == 0) {
      const auto* shared = reinterpret_cast<const std::uint16_t*>(map_ + dh::shm_mask_offset(frame));
      for (int v = 0; v < frame.height; ++v) {
        std::memcpy(mask + static_cast<std::ptrdiff_t>(v) * mask_stride_px,
                    shared + static_cast<std::ptrdiff_t>(v) * frame.width,
                    sizeof(std::uint16_t) * frame.width);
      }
    }
    error = std::move(reply.error);
    backoff_ = options_.backoff_min;
    return reply.rc;
  }

 private:
  // A host to call (started again after the back-off) with the frame in
  // the memfd; false with `error` set when there is none.
  bool ready_for(const dh::FrameRef& frame, const sp_image& left, const sp_image& right, std::string& error) {
    if (!host_ && !restart(error)) return false;
    if (auto st = map_at_least(dh::shm_bytes(frame)); !st) {
      error = st.error().message;
      return false;
    }
    for (int v = 0; v < frame.height; ++v) {
      const auto row = static_cast<std::ptrdiff_t>(v);
      std::memcpy(map_ + dh::shm_left_offset(frame) + row * frame.width, left.data + row * left.stride_bytes,
                  static_cast<std::size_t>(frame.width));
      std::memcpy(map_ + dh::shm_right_offset(frame) + row * frame.width,
                  right.data + row * right.stride_bytes, static_cast<std::size_t>(frame.width));
    }
    return true;
  }

  bool restart(std::string& error) {
    const auto now = Clock::now();
    if (now < next_start_) {
      error = fmt::format("detector host restarting in {} ms (after: {})",
                          std::chrono::duration_cast<milliseconds>(next_start_ - now).count(), last_failure_);
      return false;
    }
    if (auto st = start(); !st) {
      ++options_.counters->failed_starts;
      last_failure_ = st.error().message;
      schedule_restart();
      error = "detector host did not start again: " + last_failure_;
      spdlog::warn("{}; next try in {} ms", error, backoff_.count());
      return false;
    }
    ++options_.counters->restarts;
    spdlog::info("detector host restarted (pid {}) for {}", host_->pid(), init_.plugin_path);
    return true;
  }

  int lost(const CallResult& r, std::int64_t seq, std::string& error) {
    host_.reset();  // already reaped
    ++(r.failure == Failure::kHang ? options_.counters->hangs : options_.counters->crashes);
    last_failure_ = r.why;
    error = fmt::format("{} on frame {}; restarting in {} ms", r.why, seq, backoff_.count());
    spdlog::warn("detector: {}", error);
    schedule_restart();
    return -1;
  }

  void schedule_restart() {
    next_start_ = Clock::now() + backoff_;
    backoff_ = std::min(backoff_ * 2, options_.backoff_max);
  }

  Status map_at_least(std::uint64_t bytes) {
    if (bytes <= map_bytes_) return ok_status();
    if (map_ != nullptr) ::munmap(map_, map_bytes_);
    map_ = nullptr;
    map_bytes_ = 0;
    if (::ftruncate(shm_.get(), static_cast<off_t>(bytes)) != 0) return Unexpected{errno_error("memfd size")};
    void* p = ::mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_SHARED, shm_.get(), 0);
    if (p == MAP_FAILED) return Unexpected{errno_error("mmap")};
    map_ = static_cast<std::uint8_t*>(p);
    map_bytes_ = bytes;
    return ok_status();
  }

  std::string host_path_;
  dh::Init init_;
  IsolationOptions options_;
  Fd shm_;
  std::uint8_t* map_ = nullptr;
  std::uint64_t map_bytes_ = 0;
  std::unique_ptr<HostProcess> host_;
  std::uint32_t capabilities_ = 0;
  Clock::time_point next_start_{};
  milliseconds backoff_;
  std::string last_failure_;
};

// The frames' memfd: the host may grow it but never shrink it under our
// mapping (a SIGBUS here), and may add no seal of its own.
Expected<Fd> frames_memfd() {
  Fd fd(::memfd_create("sitepose-detector-frames", MFD_CLOEXEC | MFD_ALLOW_SEALING));
  if (fd.get() < 0) return Unexpected{errno_error("memfd_create")};
  if (::fcntl(fd.get(), F_ADD_SEALS, F_SEAL_SHRINK | F_SEAL_SEAL) != 0) {
    return Unexpected{errno_error("memfd seals")};
  }
  return fd;
}

}  // namespace

Expected<std::string> detector_host_path() {
  constexpr const char* kName = "sitepose-detector-host";
  std::vector<fs::path> candidates;
  if (const char* env = std::getenv("SITEPOSE_DETECTOR_HOST"); env != nullptr && *env) {
    candidates.emplace_back(env);
  }
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) candidates.push_back(exe.parent_path() / ".." / "lib" / "sitepose" / kName);
  candidates.emplace_back(SITEPOSE_DETECTOR_HOST_BUILD_PATH);
  std::string searched;
  for (const fs::path& candidate : candidates) {
    if (fs::is_regular_file(candidate, ec) && ::access(candidate.c_str(), X_OK) == 0) {
      return fs::weakly_canonical(candidate, ec).string();
    }
    searched += (searched.empty() ? "" : ", ") + candidate.string();
  }
  return make_error(ErrorCode::kNotFound, std::string(kName) + " not found (looked at: " + searched +
                                              "; set SITEPOSE_DETECTOR_HOST)");
}

Expected<std::unique_ptr<Detector>> load_isolated_plugin(const std::string& path,
                                                         const std::string& config_yaml,
                                                         const PluginLoadOptions& options,
                                                         const IsolationOptions& isolation) {
  if (options.capacity < 1 || options.capacity > dh::kMaxDetections) {
    return make_error(ErrorCode::kInvalidArgument,
                      "detector plugin " + path + ": capacity = " + std::to_string(options.capacity) +
                          ": must be in [1, " + std::to_string(dh::kMaxDetections) + "]");
  }
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) {
    return make_error(ErrorCode::kNotFound, "detector plugin " + path + ": no such file");
  }
  std::string host = isolation.host_path;
  if (host.empty()) {
    SITEPOSE_TRY(host, detector_host_path());
  }
  SITEPOSE_TRY(Fd shm, frames_memfd());
  // The host resolves a relative plugin path from its own working
  // directory, which is ours; an absolute one is the same file either way.
  const std::string absolute = fs::absolute(path, ec).string();
  auto calls = std::make_unique<IsolatedCalls>(std::move(host), dh::Init{absolute, config_yaml}, isolation,
                                               std::move(shm));
  SITEPOSE_TRY_STATUS(calls->start());
  spdlog::info("detector plugin {} runs in sitepose-detector-host (pid {})", path, calls->host_pid());
  PluginLoadOptions named = options;
  if (named.name.empty()) named.name = path;
  return make_plugin_detector(std::move(calls), std::move(named));
}

}  // namespace sitepose::detect
