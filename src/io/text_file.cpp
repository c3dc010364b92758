#include "sitepose/io/text_file.hpp"

#include <fstream>

namespace sitepose::io {

Status write_text_file(const std::filesystem::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  out.close();
  if (!out) return make_error(ErrorCode::kIoError, "cannot write " + path.string());
  return ok_status();
}

}  // namespace sitepose::io
