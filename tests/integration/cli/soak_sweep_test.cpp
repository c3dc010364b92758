// The soak regression of soak_cli_test over 2000 frames (issues 20, 19),
// the first two passes of backforth as the warm-up: minutes, so label
// sweep, outside the default set (ctest -L sweep).

#include "soak_check.hpp"

namespace sitepose {
namespace {

TEST(BenchSoakSweep, RssStaysFlatOverTwoThousandFrames) { testing::expect_flat_rss_soak(2000, 100, 432); }

}  // namespace
}  // namespace sitepose
