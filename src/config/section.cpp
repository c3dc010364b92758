#include "sitepose/config/section.hpp"

#include <algorithm>
#include <iterator>
#include <unordered_map>

namespace sitepose::config {

// ---- value text -----------------------------------------------------------

std::string yaml_text(bool value) { return value ? "true" : "false"; }
std::string yaml_text(int value) { return std::to_string(value); }
std::string yaml_text(std::int64_t value) { return std::to_string(value); }
std::string yaml_text(double value) { return detail::number_text(value); }

std::string yaml_text(const std::string& value) {
  std::string out = "\"";
  for (const char c : value) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\t': out += "\\t"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          static const char kHex[] = "0123456789abcdef";
          out += "\\x";
          out += kHex[(c >> 4) & 0xf];
          out += kHex[c & 0xf];
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

// ---- YamlWriter -----------------------------------------------------------

std::string YamlWriter::path_of(std::string_view key) const {
  std::string path;
  for (const std::string& part : path_) path += part + ".";
  return path + std::string(key);
}

void YamlWriter::value(std::string_view key, std::string text) {
  YamlEntry entry;
  entry.path = path_of(key);
  entry.key = std::string(key);
  entry.depth = static_cast<int>(path_.size());
  entry.value = std::move(text);
  entry.absent = absent_depth_ > 0;
  entries_.push_back(std::move(entry));
}

void YamlWriter::begin_section(std::string_view key) {
  YamlEntry entry;
  entry.path = path_of(key);
  entry.key = std::string(key);
  entry.depth = static_cast<int>(path_.size());
  entry.section = true;
  entry.absent = absent_depth_ > 0;
  entries_.push_back(std::move(entry));
  path_.emplace_back(key);
}

namespace {

// The section whose header is entries[begin] (its entries follow to the
// end) into an earlier one of the same path, if there is one: its entries
// go after the earlier one's, its header goes.
void merge_repeated_section(std::vector<YamlEntry>& entries, std::size_t begin) {
  const YamlEntry& header = entries[begin];
  if (header.absent) return;
  for (std::size_t i = 0; i < begin; ++i) {
    if (!entries[i].section || entries[i].absent || entries[i].path != header.path) continue;
    std::size_t end = i + 1;
    while (end < begin && entries[end].depth > entries[i].depth) ++end;
    const auto first = entries.begin() + static_cast<std::ptrdiff_t>(begin);
    std::vector<YamlEntry> moved(std::make_move_iterator(first + 1), std::make_move_iterator(entries.end()));
    entries.erase(first, entries.end());
    entries.insert(entries.begin() + static_cast<std::ptrdiff_t>(end), std::make_move_iterator(moved.begin()),
                   std::make_move_iterator(moved.end()));
    return;
  }
}

}  // namespace

void YamlWriter::end_section() {
  if (absent_depth_ == static_cast<int>(path_.size())) absent_depth_ = 0;
  std::string path;
  for (const std::string& part : path_) path += (path.empty() ? "" : ".") + part;
  const int depth = static_cast<int>(path_.size()) - 1;
  path_.pop_back();
  for (std::size_t i = entries_.size(); i-- > 0;) {
    if (entries_[i].section && entries_[i].depth == depth && entries_[i].path == path) {
      merge_repeated_section(entries_, i);
      break;
    }
  }
}

bool YamlWriter::absent_section(std::string_view key, std::string note) {
  YamlEntry entry;
  entry.path = path_of(key);
  entry.key = std::string(key);
  entry.depth = static_cast<int>(path_.size());
  entry.section = true;
  entry.absent = true;
  entry.note = std::move(note);
  entries_.push_back(std::move(entry));
  if (!expand_absent_) return false;
  path_.emplace_back(key);
  absent_depth_ = static_cast<int>(path_.size());
  return true;
}

std::string YamlWriter::text() const {
  std::string out;
  for (std::size_t i = 0; i < entries_.size(); ++i) {
    const YamlEntry& entry = entries_[i];
    if (entry.absent) continue;
    out += std::string(2 * static_cast<std::size_t>(entry.depth), ' ') + entry.key + ":";
    if (!entry.section) {
      out += " " + entry.value + "\n";
      continue;
    }
    std::string notes;
    bool has_keys = false;
    for (std::size_t j = i + 1; j < entries_.size() && entries_[j].depth > entry.depth; ++j) {
      if (!entries_[j].absent) {
        has_keys = true;
        break;
      }
      if (entries_[j].depth == entry.depth + 1 && !entries_[j].note.empty()) {
        notes += "  # " + entries_[j].note;
      }
    }
    out += has_keys ? "\n" : " {}" + notes + "\n";
  }
  return out;
}

// ---- ReadKeys -------------------------------------------------------------

bool ReadKeys::valid(std::string_view key) const {
  return std::find(valid_.begin(), valid_.end(), key) != valid_.end();
}

// ---- documented files -----------------------------------------------------

namespace detail {
namespace {

bool present(const YamlMap& root, std::string_view path) {
  YamlMap map = root;
  for (std::size_t dot = path.find('.'); dot != std::string_view::npos; dot = path.find('.')) {
    const std::string_view part = path.substr(0, dot);
    if (!map.has(part)) return false;
    map = map.map(part);
    path.remove_prefix(dot + 1);
  }
  return map.has(path);
}

// A comment line "#   key: ..." (an optional section's documented keys).
bool commented(const std::string& text, const std::string& key) {
  std::size_t begin = 0;
  while (begin < text.size()) {
    std::size_t end = text.find('\n', begin);
    if (end == std::string::npos) end = text.size();
    std::string_view line(text.data() + begin, end - begin);
    const std::size_t hash = line.find_first_not_of(" \t");
    if (hash != std::string_view::npos && line[hash] == '#') {
      line.remove_prefix(hash);
      line.remove_prefix(std::min(line.find_first_not_of("# \t"), line.size()));
      if (line.substr(0, key.size() + 1) == key + ":") return true;
    }
    begin = end + 1;
  }
  return false;
}

bool contains(const std::vector<std::string>& list, std::string_view item) {
  return std::find(list.begin(), list.end(), item) != list.end();
}

}  // namespace

Status compare_documented(const DocumentedFile& file, const std::string& text, const YamlReader& reader,
                          const std::vector<YamlEntry>& defaults, const std::vector<YamlEntry>& documented) {
  std::unordered_map<std::string, const YamlEntry*> documented_by_path;
  for (const YamlEntry& entry : documented) documented_by_path[entry.path] = &entry;
  const YamlMap root = reader.root();
  std::vector<std::string> problems;
  for (const YamlEntry& entry : defaults) {
    const std::string where = file.path + ": " + entry.path;
    const bool in_file = present(root, entry.path);
    const bool elsewhere = contains(file.documented_elsewhere, entry.path.substr(0, entry.path.find('.')));
    if (entry.absent) {
      if (in_file) {
        problems.push_back(where + ": set, but absent by default (document it in a comment)");
      } else if (!elsewhere && !commented(text, entry.key)) {
        problems.push_back(where + ": not documented (expected a comment line \"# " + entry.key + ": ...\")");
      }
      continue;
    }
    if (!in_file) {
      if (!elsewhere) {
        problems.push_back(where + ": not documented" +
                           (entry.section ? std::string() : " (default " + entry.value + ")"));
      }
      continue;
    }
    if (entry.section) continue;
    const auto found = documented_by_path.find(entry.path);
    const std::string value = found != documented_by_path.end() ? found->second->value : "";
    const bool shipped = contains(file.shipped_values, entry.path);
    std::string problem = where;
    problem.append(" = ").append(value);
    if (shipped && value == entry.value) {
      problems.push_back(problem.append(": listed as a deployment value, but equals the default"));
    } else if (!shipped && value != entry.value) {
      problems.push_back(problem.append(": the default is ").append(entry.value));
    }
  }
  for (const std::string& path : file.shipped_values) {
    const bool known = std::any_of(defaults.begin(), defaults.end(),
                                   [&](const YamlEntry& e) { return e.path == path && !e.section; });
    if (!known)
      problems.push_back(file.path + ": " + path + ": listed as a deployment value, but no such key");
  }
  if (problems.empty()) return ok_status();
  std::string message;
  for (const std::string& problem : problems) message += (message.empty() ? "" : "\n") + problem;
  return make_error(ErrorCode::kInvalidArgument, message);
}

}  // namespace detail
}  // namespace sitepose::config
