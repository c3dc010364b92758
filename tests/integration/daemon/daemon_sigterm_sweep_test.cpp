// The SIGTERM loop of daemon_e2e_test over 50 runs (issue 20): minutes, so
// label sweep, outside the default set (ctest -L sweep).

#include "daemon_test_util.hpp"

namespace sitepose::daemon::testing {
namespace {

TEST(DaemonEndToEndSweep, SigtermAtFiftyRandomPointsLosesNoLine) {
  expect_sigterm_at_random_points_loses_no_line(50);
}

}  // namespace
}  // namespace sitepose::daemon::testing
