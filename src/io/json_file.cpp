#include "sitepose/io/json_file.hpp"

#include <fstream>
#include <sstream>

namespace sitepose::io {

std::string to_json_text(const Json& value) {
  // error_handler::replace: a non-UTF-8 byte in a name (a scenario's
  // description) becomes U+FFFD instead of an exception.
  return value.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + "\n";
}

Status write_json_file(const std::string& path, const Json& value) {
  std::ofstream out(path, std::ios::binary);
  if (!out) return make_error(ErrorCode::kIoError, "cannot write " + path);
  out << to_json_text(value);
  out.close();  // the buffered rest is written here: a full disk shows only now
  if (!out) return make_error(ErrorCode::kIoError, "write failed: " + path);
  return ok_status();
}

Expected<Json> read_json_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return make_error(ErrorCode::kNotFound, "cannot open " + path);
  std::stringstream text;
  text << in.rdbuf();
  try {
    return Json::parse(text.str());
  } catch (const nlohmann::json::parse_error& e) {
    return make_error(ErrorCode::kParseError,
                      path + ": not valid JSON (byte " + std::to_string(e.byte) + ")");
  }
}

}  // namespace sitepose::io
