#pragma once
// JSON files the project reads and writes (run stats, sim meta.json, eval
// figures), all through nlohmann-json so every one of them is valid JSON:
// keys in insertion order, NaN and infinities written as null.

#include <nlohmann/json.hpp>
#include <string>

#include "sitepose/core/expected.hpp"
#include "sitepose/io/json_fwd.hpp"

namespace sitepose::io {

// `value` indented by 2, one trailing newline.
std::string to_json_text(const Json& value);

// Writes to_json_text(value) to `path`; kIoError naming the path when it
// cannot be opened or the write fails (a full disk shows at close).
Status write_json_file(const std::string& path, const Json& value);

// Parses `path`; kNotFound / kParseError naming the path (and the parser's
// byte offset).
Expected<Json> read_json_file(const std::string& path);

}  // namespace sitepose::io
