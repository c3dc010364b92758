// sitepose-detector-host: runs one detector plugin in a process of its own
// for siteposed (dynamic.detector_isolation: process), so that the plugin's
// crash or hang cannot end the daemon. Started by detect::IsolatedCalls
// (src/detect/isolated_detector.cpp) with
//   --socket-fd N --shm-fd M --parent-pid P
// and not meant to be run by hand. It speaks detector_host/protocol.hpp:
// Init -> Ready once, then Detect -> Detections and Segment -> Segmented
// until the socket closes (then the plugin is destroyed and it exits 0).
// Exit status: 0 after EOF, 2 bad usage, 3 the plugin did not load
// (reported in Ready first), 4 a protocol error or an exception. It dies
// with its parent (PR_SET_PDEATHSIG): a plugin stuck in a call does not
// outlive siteposed. It writes no core file (RLIMIT_CORE 0).

#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>
#include <vector>

#include "sitepose/detect/plugin_calls.hpp"
#include "sitepose/detector_host/protocol.hpp"

namespace dh = sitepose::detector_host;
using sitepose::detect::CreatedPlugin;

namespace {

void say(const std::string& what) {
  std::fprintf(stderr, "sitepose-detector-host[%d]: %s\n", ::getpid(), what.c_str());
}

// The parent's memfd, mapped as large as the current request needs.
class SharedFrames {
 public:
  explicit SharedFrames(int fd) : fd_(fd) {}
  ~SharedFrames() {
    if (data_ != nullptr) ::munmap(data_, bytes_);
  }
  SharedFrames(const SharedFrames&) = delete;
  SharedFrames& operator=(const SharedFrames&) = delete;

  // nullptr when the memfd is smaller than `need` (the parent's bug).
  std::uint8_t* map(std::uint64_t need) {
    if (need <= bytes_) return data_;
    struct stat st {};
    if (::fstat(fd_, &st) != 0 || static_cast<std::uint64_t>(st.st_size) < need) return nullptr;
    if (data_ != nullptr) ::munmap(data_, bytes_);
    void* p = ::mmap(nullptr, need, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, 0);
    data_ = p == MAP_FAILED ? nullptr : static_cast<std::uint8_t*>(p);
    bytes_ = data_ != nullptr ? need : 0;
    return data_;
  }

 private:
  int fd_;
  std::uint8_t* data_ = nullptr;
  std::uint64_t bytes_ = 0;
};

struct Images {
  sp_image left{};
  sp_image right{};
};

Images images_in(std::uint8_t* base, const dh::FrameRef& f) {
  Images im;
  for (sp_image* image : {&im.left, &im.right}) {
    image->width = f.width;
    image->height = f.height;
    image->stride_bytes = f.width;
  }
  im.left.data = base + dh::shm_left_offset(f);
  im.right.data = base + dh::shm_right_offset(f);
  return im;
}

std::string text_of(const std::vector<char>& err) { return {err.data(), ::strnlen(err.data(), err.size())}; }

dh::DetectReply detect(const CreatedPlugin& plugin, std::uint8_t* base, const dh::DetectRequest& request) {
  const Images im = images_in(base, request.frame);
  std::vector<sp_detection> out(static_cast<std::size_t>(request.capacity));
  std::vector<char> err(512, '\0');
  dh::DetectReply reply;
  reply.rc = plugin.api().detect(plugin.handle(), &im.left, &im.right, request.frame.t_ns, request.frame.seq,
                                 out.data(), request.capacity, &reply.count, err.data(), err.size());
  const std::int32_t n = std::max(0, std::min(reply.count, request.capacity));
  reply.detections.assign(out.begin(), out.begin() + n);
  if (reply.rc != 0) reply.error = text_of(err);
  return reply;
}

dh::SegmentReply segment(const CreatedPlugin& plugin, std::uint8_t* base, const dh::SegmentRequest& request) {
  const Images im = images_in(base, request.frame);
  auto* mask = reinterpret_cast<std::uint16_t*>(base + dh::shm_mask_offset(request.frame));
  std::memset(mask, 0, dh::shm_bytes(request.frame) - dh::shm_mask_offset(request.frame));
  std::vector<char> err(512, '\0');
  dh::SegmentReply reply;
  reply.rc =
      plugin.api().segment(plugin.handle(), &im.left, &im.right, request.frame.t_ns, request.frame.seq,
                           request.detections.data(), static_cast<std::int32_t>(request.detections.size()),
                           mask, request.frame.width, err.data(), err.size());
  if (reply.rc != 0) reply.error = text_of(err);
  return reply;
}

// Answers requests until EOF. Returns the exit status.
int serve(int socket, SharedFrames& frames, const CreatedPlugin& plugin) {
  for (;;) {
    auto received = dh::receive_message(socket, -1);
    if (!received) {
      say(received.error().message);
      return 4;
    }
    if (received->outcome != dh::ReceiveOutcome::kMessage) return 0;  // siteposed closed: done
    const std::uint32_t id = received->envelope.call_id;
    const dh::Message& m = received->envelope.message;
    const dh::FrameRef* frame = nullptr;
    if (const auto* d = std::get_if<dh::DetectRequest>(&m)) frame = &d->frame;
    if (const auto* s = std::get_if<dh::SegmentRequest>(&m)) frame = &s->frame;
    if (frame == nullptr) {
      say(std::string("unexpected ") + dh::to_string(dh::type_of(m)) + " message");
      return 4;
    }
    std::uint8_t* base = frames.map(dh::shm_bytes(*frame));
    if (base == nullptr) {
      say("the shared frame memory is smaller than the frame");
      return 4;
    }
    const dh::Message reply = std::holds_alternative<dh::DetectRequest>(m)
                                  ? dh::Message(detect(plugin, base, std::get<dh::DetectRequest>(m)))
                                  : dh::Message(segment(plugin, base, std::get<dh::SegmentRequest>(m)));
    if (auto st = dh::send_message(socket, {id, reply}); !st) return 0;  // the parent went away
  }
}

int parse_fd(const char* text) {
  char* end = nullptr;
  const long v = std::strtol(text, &end, 10);
  return (end != text && *end == '\0' && v >= 0 && v < 1024) ? static_cast<int>(v) : -1;
}

int run(int argc, char** argv) {
  int socket = -1;
  int shm = -1;
  long parent = -1;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string key = argv[i];
    if (key == "--socket-fd") socket = parse_fd(argv[i + 1]);
    if (key == "--shm-fd") shm = parse_fd(argv[i + 1]);
    if (key == "--parent-pid") parent = std::strtol(argv[i + 1], nullptr, 10);
  }
  if (socket < 0 || shm < 0 || parent <= 0 || argc != 7) {
    say("usage: sitepose-detector-host --socket-fd N --shm-fd M --parent-pid P (started by siteposed)");
    return 2;
  }
  ::prctl(PR_SET_PDEATHSIG, SIGKILL);
  // No core file per crash: a plugin that crashes on every restart would
  // fill the disk; the crash is reported by siteposed (signal, frame).
  const rlimit no_core{0, 0};
  ::setrlimit(RLIMIT_CORE, &no_core);
  if (::getppid() != parent) return 0;                                      // the parent is already gone
  ::close_range(static_cast<unsigned>(std::max(socket, shm)) + 1, ~0u, 0);  // nothing else of siteposed's

  auto init = dh::receive_message(socket, -1);
  if (!init || init->outcome != dh::ReceiveOutcome::kMessage ||
      !std::holds_alternative<dh::Init>(init->envelope.message)) {
    say(init ? "expected an init message first" : init.error().message);
    return 4;
  }
  const auto& request = std::get<dh::Init>(init->envelope.message);
  auto plugin = sitepose::detect::create_plugin(request.plugin_path, request.config_yaml);
  dh::Ready ready;
  if (plugin) {
    ready.capabilities = (*plugin)->api().capabilities((*plugin)->handle());
  } else {
    ready.status = dh::ready_status(plugin.error().code);
    ready.error = plugin.error().message.substr(0, dh::kMaxTextBytes);
  }
  if (auto st = dh::send_message(socket, {init->envelope.call_id, ready}); !st || !plugin)
    return plugin ? 0 : 3;
  SharedFrames frames(shm);
  return serve(socket, frames, **plugin);
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {  // out of memory, mostly: siteposed sees the exit status
    say(std::string("stopped: ") + e.what());
    return 4;
  }
}
