// The soak regression of soak_cli_test over 2000 frames (issue 20), the
// first two loops of the backforth pass as the warm-up: minutes, so label
// sweep, outside the default set (ctest -L sweep).

#include "soak_check.hpp"

namespace sitepose {
namespace {

TEST(BenchSoakSweep, RssStaysFlatOverTwoThousandFrames) { testing::expect_flat_rss_soak(2000, 100, 432); }

}  // namespace
}  // namespace sitepose
