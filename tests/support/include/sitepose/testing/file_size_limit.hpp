#pragma once
// A full disk for tests: RLIMIT_FSIZE makes the kernel write a file only up
// to `bytes` (a short write), then fail with EFBIG, as ENOSPC would. SIGXFSZ
// is ignored while the limit holds. Process-wide: use in single-threaded
// tests; the destructor lifts the limit ("space returns").

#include <signal.h>
#include <sys/resource.h>

#include <cstddef>

namespace sitepose::testing {

class FileSizeLimit {
 public:
  explicit FileSizeLimit(std::size_t bytes) {
    ::getrlimit(RLIMIT_FSIZE, &saved_);
    old_handler_ = ::signal(SIGXFSZ, SIG_IGN);
    rlimit limit = saved_;
    limit.rlim_cur = bytes;
    ok_ = ::setrlimit(RLIMIT_FSIZE, &limit) == 0;
  }
  ~FileSizeLimit() { lift(); }
  FileSizeLimit(const FileSizeLimit&) = delete;
  FileSizeLimit& operator=(const FileSizeLimit&) = delete;

  bool ok() const { return ok_; }
  void lift() {
    if (!ok_) return;
    ::setrlimit(RLIMIT_FSIZE, &saved_);
    ::signal(SIGXFSZ, old_handler_);
    ok_ = false;
  }

 private:
  rlimit saved_{};
  sighandler_t old_handler_ = SIG_DFL;
  bool ok_ = false;
};

}  // namespace sitepose::testing
