// A GenICam feature file for siteposed's Aravis source (source.aravis.
// feature_file): an accepted file's steps have GenICam names, one-word
// values, and lines in the file's order.
#include "fuzz_check.hpp"
#include "fuzz_input.hpp"
#include "sitepose/drivers/aravis/feature_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace sitepose;
  auto file = drivers::aravis::parse_feature_file(fuzz::as_text(data, size), "fuzz.features");
  if (!file) return 0;
  int previous_line = 0;
  for (const drivers::aravis::FeatureStep& step : file->steps) {
    fuzz::require(step.line > previous_line, "lines in the file's order");
    previous_line = step.line;
    fuzz::require(!step.name.empty() && step.name.find_first_of(" \t\r\n=#") == std::string::npos,
                  "a name without blanks, '=' or '#'");
    if (step.value) {
      fuzz::require(!step.value->empty() && step.value->find_first_of(" \t\r\n'\"#") == std::string::npos,
                    "a one-word value");
    }
  }
  return 0;
}
