#pragma once
// A GenICam feature file (firmware-config/genicam/*.features): the settings
// a camera family needs beyond what siteposed sets from its own keys
// (source.aravis.*), applied to each camera of the pair at every open,
// before those keys, so the keys win where both set a feature.
//
// Format: one step per line, applied in order; "#" starts a comment, blank
// lines are skipped.
//   Name=Value   sets a feature (integer, float, boolean, enumeration or
//                string; the camera converts the text)
//   Name         executes a command feature (e.g. UserSetLoad)
// Names are GenICam names ([A-Za-z_][A-Za-z0-9_]*); a value is one word (no
// spaces or quotes). The same text `arv-tool-0.8 control` takes, so a file
// can be tried by hand first.

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "sitepose/core/expected.hpp"

namespace sitepose::drivers::aravis {

struct FeatureStep {
  int line = 0;  // 1-based, for messages
  std::string name;
  std::optional<std::string> value;  // empty: a command

  // "Name=Value" or "Name", as written in the file.
  std::string text() const { return value ? name + "=" + *value : name; }
};

struct FeatureFile {
  std::string path;  // "" = none
  std::vector<FeatureStep> steps;
};

// Parses the text of a feature file; errors name `path` and the line.
Expected<FeatureFile> parse_feature_file(std::string_view text, const std::string& path);

// Reads and parses a feature file (at most 1 MiB).
Expected<FeatureFile> read_feature_file(const std::string& path);

}  // namespace sitepose::drivers::aravis
