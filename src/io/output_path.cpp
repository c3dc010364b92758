#include "sitepose/io/output_path.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace sitepose::io {

Status check_output_path(const std::string& path) {
  const auto bad = [&](const std::string& why) {
    return make_error(ErrorCode::kInvalidArgument, path + ": cannot write: " + why);
  };
  if (path.empty()) return bad("empty path");
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0) {
    if (S_ISDIR(st.st_mode)) return bad("is a directory");
    // Opened as it is (a FIFO would block, a file must not be truncated).
    if (::access(path.c_str(), W_OK) != 0) return bad(std::strerror(errno));
    return ok_status();
  }
  if (errno != ENOENT) return bad(std::strerror(errno));
  // A new file: create it to see that the folder takes it, then remove it.
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0 && errno == EEXIST) return ok_status();  // a dangling link: writing creates its target
  if (fd < 0) return bad(std::strerror(errno));
  ::close(fd);
  ::unlink(path.c_str());
  return ok_status();
}

}  // namespace sitepose::io
