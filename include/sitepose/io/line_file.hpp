#pragma once
// An output file of text lines that never keeps a half line, for logs a
// service appends to while it runs (the daemon's TUM trajectory, candump
// logs). A write() that fails part-way (a full disk, a file size limit) is
// cut back to where the call began, so the caller can write the same text
// again later; opening for append cuts an incomplete last line that a crash
// left. One writer per file; not thread-safe.

#include <cstdint>
#include <string>
#include <string_view>

#include "sitepose/core/expected.hpp"

namespace sitepose::io {

class LineFile {
 public:
  // Creates `path`, or opens it for appending (append) or truncated. When
  // appending, an incomplete last line shorter than 4 KiB is cut off
  // (cut_at_open() says how much); a longer one means the file is not a log
  // of lines and fails (kInvalidArgument). kIoError names the path and errno.
  static Expected<LineFile> open(const std::string& path, bool append);
  // Writes to `fd` without owning it (stdout); `name` is for messages.
  static LineFile borrow(int fd, std::string name);

  LineFile(LineFile&& other) noexcept;
  LineFile& operator=(LineFile&& other) noexcept;
  LineFile(const LineFile&) = delete;
  LineFile& operator=(const LineFile&) = delete;
  ~LineFile();

  // Writes `text` (whole lines, each ending in '\n'); ok once all of it is
  // with the OS. On failure (kIoError naming the file and errno) a regular
  // file is truncated back to its length before the call.
  Status write(std::string_view text);

  std::uint64_t cut_at_open() const { return cut_at_open_; }
  const std::string& name() const { return name_; }

 private:
  LineFile(int fd, bool owned, std::string name);
  Status fail(std::size_t written, int err);

  int fd_ = -1;
  bool owned_ = false;
  bool regular_ = false;  // a regular file can be cut back; a pipe cannot
  std::uint64_t cut_at_open_ = 0;
  std::string name_;
};

}  // namespace sitepose::io
