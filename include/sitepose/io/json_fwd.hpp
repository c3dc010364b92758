#pragma once
// io::Json declared without the whole of nlohmann-json, for headers that
// only name it (json_file.hpp has the definitions).

#include <nlohmann/json_fwd.hpp>

namespace sitepose::io {

using Json = nlohmann::ordered_json;

}  // namespace sitepose::io
