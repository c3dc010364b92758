#pragma once
// Loading, validating and printing the sitepose configuration.
//
// - load_config(path): the YAML file documented by config/sitepose.yaml.
//   Every key is optional (absent = the struct default from
//   sitepose_config.hpp; an empty file gives SiteposeConfig{}); unknown keys,
//   wrong types, out-of-range values and bad enum names are errors naming the
//   file, line, key path, value and the rule, all problems in one message
//   (kInvalidArgument; kNotFound for a missing file, kParseError for
//   malformed YAML).
// - to_yaml(config): the resolved configuration as YAML that load_config
//   reads back to an equal struct (numbers printed round-trip exact); logged
//   once at startup.
// - load_orbslam2_settings(path): an ORB-SLAM2 stereo settings file
//   (OpenCV FileStorage YAML) for users who bring theirs; see
//   orbslam2_settings.hpp.
// All functions are pure (no globals), safe to call from any thread.

#include <string>
#include <string_view>

#include "sitepose/config/orbslam2_settings.hpp"
#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/config/yaml_reader.hpp"
#include "sitepose/core/expected.hpp"

namespace sitepose::config {

Expected<SiteposeConfig> load_config(const std::string& path);
// Same, from text; source_name is used in messages in place of a path.
Expected<SiteposeConfig> load_config_from_string(std::string_view text,
                                                 const std::string& source_name);

// Reads every section of `config` from a document's root mapping, keeping
// the values already in `config` for absent keys. For files that embed the
// sitepose configuration next to keys of their own (the daemon's settings);
// the caller owns `reader` and calls finish() on it.
void read_config(const YamlMap& root, SiteposeConfig& config);

std::string to_yaml(const SiteposeConfig& config);

// Enum names as written in the YAML and on the command line (--mode).
// Errors (kInvalidArgument) list the accepted names.
Expected<MaskingMode> parse_masking_mode(std::string_view name);
Expected<ClassifierMode> parse_classifier_mode(std::string_view name);
// "none|bbox|pixel|hierarchical|full" and "paper|sitepose", for --help texts.
const char* masking_mode_names();
const char* classifier_mode_names();

}  // namespace sitepose::config
