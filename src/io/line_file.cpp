#include "sitepose/io/line_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <utility>

namespace sitepose::io {
namespace {

// A crash mid-write leaves at most one partial line; lines are far shorter.
constexpr off_t kMaxPartialLine = 4096;

std::string errno_text(int err) { return std::strerror(err); }

bool is_regular(int fd) {
  struct stat st {};
  return ::fstat(fd, &st) == 0 && S_ISREG(st.st_mode);
}

// Length of the file up to and including its last '\n' when the bytes after
// it are fewer than kMaxPartialLine; -1 when they are more.
off_t whole_lines_length(int fd, off_t size) {
  char buf[kMaxPartialLine];
  const off_t start = std::max<off_t>(0, size - kMaxPartialLine);
  const ssize_t n = ::pread(fd, buf, static_cast<std::size_t>(size - start), start);
  if (n != size - start) return -1;
  for (ssize_t i = n; i > 0; --i) {
    if (buf[i - 1] == '\n') return start + i;
  }
  return start == 0 ? 0 : -1;
}

}  // namespace

LineFile::LineFile(int fd, bool owned, std::string name)
    : fd_(fd), owned_(owned), regular_(is_regular(fd)), name_(std::move(name)) {}

Expected<LineFile> LineFile::open(const std::string& path, bool append) {
  // O_APPEND always, so writes go to the end even after a cut. O_RDWR when
  // appending: the tail is read back to find the last line end (a file we
  // may only write is appended to unchecked).
  const int flags = O_APPEND | O_CREAT | O_CLOEXEC | (append ? O_RDWR : O_WRONLY | O_TRUNC);
  int fd = ::open(path.c_str(), flags, 0644);
  bool readable = append;
  if (fd < 0 && append && errno == EACCES) {
    fd = ::open(path.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC, 0644);
    readable = false;
  }
  if (fd < 0) {
    return make_error(ErrorCode::kIoError, path + ": cannot open for writing: " + errno_text(errno));
  }
  LineFile file(fd, true, path);
  struct stat st {};
  if (readable && file.regular_ && ::fstat(fd, &st) == 0 && st.st_size > 0) {
    const off_t keep = whole_lines_length(fd, st.st_size);
    if (keep < 0) {
      return make_error(ErrorCode::kInvalidArgument,
                        path + ": does not end with a line end within its last " +
                            std::to_string(kMaxPartialLine) + " bytes; not a log of lines to append to");
    }
    if (keep < st.st_size) {
      if (::ftruncate(fd, keep) != 0) {
        return make_error(ErrorCode::kIoError,
                          path + ": cannot cut the incomplete last line: " + errno_text(errno));
      }
      file.cut_at_open_ = static_cast<std::uint64_t>(st.st_size - keep);
    }
  }
  return file;
}

LineFile LineFile::borrow(int fd, std::string name) { return LineFile(fd, false, std::move(name)); }

LineFile::LineFile(LineFile&& other) noexcept
    : fd_(std::exchange(other.fd_, -1)),
      owned_(other.owned_),
      regular_(other.regular_),
      cut_at_open_(other.cut_at_open_),
      name_(std::move(other.name_)) {}

LineFile& LineFile::operator=(LineFile&& other) noexcept {
  if (this != &other) {
    if (owned_ && fd_ >= 0) ::close(fd_);
    fd_ = std::exchange(other.fd_, -1);
    owned_ = other.owned_;
    regular_ = other.regular_;
    cut_at_open_ = other.cut_at_open_;
    name_ = std::move(other.name_);
  }
  return *this;
}

LineFile::~LineFile() {
  if (owned_ && fd_ >= 0) ::close(fd_);
}

Status LineFile::write(std::string_view text) {
  std::size_t written = 0;
  while (written < text.size()) {
    const ssize_t n = ::write(fd_, text.data() + written, text.size() - written);
    if (n > 0) {
      written += static_cast<std::size_t>(n);
    } else if (n < 0 && errno == EINTR) {
      continue;
    } else {
      return fail(written, n < 0 ? errno : EIO);
    }
  }
  return ok_status();
}

Status LineFile::fail(std::size_t written, int err) {
  std::string message = name_ + ": write failed: " + errno_text(err);
  if (written > 0) {
    // One writer: the `written` bytes are the file's last ones. The seek
    // matters only for a borrowed descriptor without O_APPEND.
    struct stat st {};
    const off_t cut = static_cast<off_t>(written);
    if (regular_ && ::fstat(fd_, &st) == 0 && st.st_size >= cut &&
        ::ftruncate(fd_, st.st_size - cut) == 0 && ::lseek(fd_, st.st_size - cut, SEEK_SET) >= 0) {
      message += " (the partly written line was cut off)";
    } else {
      message += "; " + std::to_string(written) + " bytes of a line were written and could not be cut off";
    }
  }
  return make_error(ErrorCode::kIoError, message);
}

}  // namespace sitepose::io
