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
// - sitepose_sections(): the table behind both (section.hpp): every key once
//   with its rule; files embedding these sections (the daemon's) read them
//   through it.
// - load_orbslam2_settings(path): an ORB-SLAM2 stereo settings file
//   (OpenCV FileStorage YAML) for users who bring theirs; see
//   orbslam2_settings.hpp.
// All functions are pure (no globals), safe to call from any thread.

#include <string>
#include <string_view>

#include "sitepose/config/orbslam2_settings.hpp"
#include "sitepose/config/section.hpp"
#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/config/yaml_reader.hpp"
#include "sitepose/core/expected.hpp"

namespace sitepose::config {

const Section<SiteposeConfig>& sitepose_sections();

Expected<SiteposeConfig> load_config(const std::string& path);
// Same, from text; source_name is used in messages in place of a path.
Expected<SiteposeConfig> load_config_from_string(std::string_view text,
                                                 const std::string& source_name);

std::string to_yaml(const SiteposeConfig& config);

// Enum names as written in the YAML and on the command line (--mode).
// Errors (kInvalidArgument) list the accepted names.
Expected<MaskingMode> parse_masking_mode(std::string_view name);
Expected<ClassifierMode> parse_classifier_mode(std::string_view name);
// "none|bbox|pixel|hierarchical|full" and "paper|sitepose", for --help texts.
const char* masking_mode_names();
const char* classifier_mode_names();

}  // namespace sitepose::config
