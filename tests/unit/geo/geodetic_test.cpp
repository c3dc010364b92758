#include "sitepose/geo/geodetic.hpp"

#include <GeographicLib/LocalCartesian.hpp>
#include <GeographicLib/UTMUPS.hpp>
#include <gtest/gtest.h>

namespace sitepose::geo {
namespace {

const Geodetic kTokyo{35.681236, 139.767125, 40.0};

TEST(Geodetic, ValidateNamesTheBadValue) {
  EXPECT_TRUE(validate_geodetic(kTokyo, "origin").has_value());
  const Status bad_lat = validate_geodetic({91.0, 0.0, 0.0}, "geo.origin");
  ASSERT_FALSE(bad_lat.has_value());
  EXPECT_NE(bad_lat.error().message.find("geo.origin: latitude_deg = 91"), std::string::npos);
  const Status bad_lon = validate_geodetic({0.0, -181.0, 0.0}, "o");
  ASSERT_FALSE(bad_lon.has_value());
  EXPECT_NE(bad_lon.error().message.find("longitude_deg = -181"), std::string::npos);
  EXPECT_FALSE(validate_geodetic({0.0, 0.0, std::nan("")}, "o").has_value());
  EXPECT_FALSE(LocalEnu::create({95.0, 0.0, 0.0}).has_value());
}

TEST(Geodetic, EnuMatchesGeographicLibAndRoundTrips) {
  auto enu = LocalEnu::create(kTokyo);
  ASSERT_TRUE(enu.has_value());
  const GeographicLib::LocalCartesian reference(kTokyo.latitude_deg, kTokyo.longitude_deg,
                                                kTokyo.height_m);
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(123.4, -56.7, 8.9),
                                  Eigen::Vector3d(-2500.0, 3100.0, -30.0)}) {
    const Geodetic g = enu->to_geodetic(p);
    double lat = 0, lon = 0, h = 0;
    reference.Reverse(p.x(), p.y(), p.z(), lat, lon, h);
    EXPECT_NEAR(g.latitude_deg, lat, 1e-12);
    EXPECT_NEAR(g.longitude_deg, lon, 1e-12);
    EXPECT_NEAR(g.height_m, h, 1e-9);
    EXPECT_LT((enu->to_enu(g) - p).norm(), 1e-6);  // far below cm level
  }
}

TEST(Geodetic, EnuAxesPointEastNorthUp) {
  auto enu = LocalEnu::create(kTokyo);
  ASSERT_TRUE(enu.has_value());
  const Geodetic east = enu->to_geodetic({100.0, 0.0, 0.0});
  const Geodetic north = enu->to_geodetic({0.0, 100.0, 0.0});
  const Geodetic up = enu->to_geodetic({0.0, 0.0, 100.0});
  EXPECT_GT(east.longitude_deg, kTokyo.longitude_deg);
  EXPECT_NEAR(east.latitude_deg, kTokyo.latitude_deg, 1e-5);
  EXPECT_GT(north.latitude_deg, kTokyo.latitude_deg);
  EXPECT_NEAR(north.longitude_deg, kTokyo.longitude_deg, 1e-9);
  EXPECT_NEAR(up.height_m, kTokyo.height_m + 100.0, 1e-3);
  // 100 m north is 100 / 111 km of latitude, roughly.
  EXPECT_NEAR(north.latitude_deg - kTokyo.latitude_deg, 100.0 / 110'950.0, 2e-6);
}

TEST(Geodetic, UtmMatchesGeographicLibAndRoundTrips) {
  for (const Geodetic& g : {kTokyo, Geodetic{-33.8688, 151.2093, 5.0}, Geodetic{52.52, 13.405, 0.0},
                           Geodetic{-89.5, 10.0, 0.0} /* UPS south */}) {
    auto utm = to_utm(g);
    ASSERT_TRUE(utm.has_value());
    int zone = -1;
    bool north = false;
    double x = 0, y = 0;
    GeographicLib::UTMUPS::Forward(g.latitude_deg, g.longitude_deg, zone, north, x, y);
    EXPECT_EQ(utm->zone, zone);
    EXPECT_EQ(utm->north, north);
    EXPECT_NEAR(utm->easting_m, x, 1e-6);
    EXPECT_NEAR(utm->northing_m, y, 1e-6);
    auto back = from_utm(*utm, g.height_m);
    ASSERT_TRUE(back.has_value());
    EXPECT_NEAR(back->latitude_deg, g.latitude_deg, 1e-9);
    EXPECT_NEAR(back->longitude_deg, g.longitude_deg, 1e-9);
  }
  auto tokyo = to_utm(kTokyo);
  ASSERT_TRUE(tokyo.has_value());
  EXPECT_EQ(tokyo->zone, 54);
  EXPECT_TRUE(tokyo->north);
  auto sydney = to_utm({-33.8688, 151.2093, 0.0});
  ASSERT_TRUE(sydney.has_value());
  EXPECT_EQ(sydney->zone, 56);
  EXPECT_FALSE(sydney->north);
  EXPECT_FALSE(to_utm({100.0, 0.0, 0.0}).has_value());
  EXPECT_FALSE(from_utm({500000.0, 1e9, 54, true}, 0.0).has_value());
}

}  // namespace
}  // namespace sitepose::geo
