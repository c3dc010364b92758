#include "detail/file_head.hpp"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace sitepose::config::detail {

Expected<std::string> read_file_head(const std::string& path, std::size_t limit, std::string_view noun,
                                     std::string_view directory_hint) {
  const std::string named = std::string(noun) + " " + path;
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    return make_error(ErrorCode::kInvalidArgument,
                      "cannot read " + named + ": is a directory" + std::string(directory_hint));
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) return make_error(ErrorCode::kNotFound, "cannot open " + named + ": " + std::strerror(errno));
  std::string text(limit + 1, '\0');
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  if (in.bad()) return make_error(ErrorCode::kIoError, "cannot read " + named);
  text.resize(static_cast<std::size_t>(in.gcount()));
  return text;
}

}  // namespace sitepose::config::detail
