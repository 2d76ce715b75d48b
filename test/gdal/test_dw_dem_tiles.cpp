/// \file test_dw_dem_tiles.cpp
/// \brief dw_dem on several tiles of one survey is dw_dem on the whole: the bundled crop split into
/// two LAS files (same header, VLRs and scale; records divided) gives the same GeoTIFF byte for byte,
/// and tiles on different integer grids are refused with a clear error.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>

#include "gdal_test_util.h"

namespace {

const std::string kDem = std::string(DW_BINARY_DIR) + "/apps/dw_dem";

/// The records [first, last) of a LAS 1.2 file, after its header and VLRs unchanged but the count.
std::string part(const std::string& las, std::uint32_t first, std::uint32_t last) {
  std::uint32_t offset, count;
  std::uint16_t length;
  std::memcpy(&offset, las.data() + 96, 4);
  std::memcpy(&length, las.data() + 105, 2);
  std::memcpy(&count, las.data() + 107, 4);
  EXPECT_LE(last, count);
  std::string out = las.substr(0, offset) +
                    las.substr(offset + std::size_t(first) * length, std::size_t(last - first) * length);
  const std::uint32_t n = last - first;
  std::memcpy(&out[107], &n, 4);
  return out;
}

int run(const std::string& args) {
  return std::system((kDem + " " + args + " --quiet > /dev/null 2>&1").c_str());
}

TEST(DwDemTiles, TwoTilesGiveTheSameRasterAsTheWholeFile) {
  if (!dw_test::exists(kDem)) GTEST_SKIP() << kDem << " is not built";
  const std::string dir = dw_test::scratch("tiles");
  const std::string whole = dw_test::readBytes(std::string(DW_TEST_DATA_DIR) + "/autzen_crop.las");
  dw_test::writeBytes(dir + "/a.las", part(whole, 0, 2000));
  dw_test::writeBytes(dir + "/b.las", part(whole, 2000, 5779));
  ASSERT_EQ(run(std::string(DW_TEST_DATA_DIR) + "/autzen_crop.las -o " + dir + "/whole.tif --resolution 2"),
            0);
  ASSERT_EQ(run(dir + "/a.las " + dir + "/b.las -o " + dir + "/tiles.tif --resolution 2"), 0);
  EXPECT_EQ(dw_test::readBytes(dir + "/tiles.tif"), dw_test::readBytes(dir + "/whole.tif"));
  EXPECT_GT(dw_test::readBytes(dir + "/whole.tif").size(), 1000u);
}

TEST(DwDemTiles, TilesOnAnotherIntegerGridAreRefused) {
  if (!dw_test::exists(kDem)) GTEST_SKIP() << kDem << " is not built";
  const std::string dir = dw_test::scratch("grids");
  const std::string whole = dw_test::readBytes(std::string(DW_TEST_DATA_DIR) + "/autzen_crop.las");
  std::string b = part(whole, 2000, 5779);
  const double x_offset = 0.005;  // half a unit of the 0.01 scale
  std::memcpy(&b[155], &x_offset, 8);
  dw_test::writeBytes(dir + "/a.las", part(whole, 0, 2000));
  dw_test::writeBytes(dir + "/b.las", b);
  const std::string log = dir + "/log.txt";
  EXPECT_NE(std::system(
                (kDem + " " + dir + "/a.las " + dir + "/b.las -o " + dir + "/x.tif --resolution 2 2> " + log)
                    .c_str()),
            0);
  EXPECT_NE(dw_test::readBytes(log).find(
                "b.las: its LAS scale and offset do not share the first input's integer grid"),
            std::string::npos)
      << dw_test::readBytes(log);
  EXPECT_FALSE(dw_test::exists(dir + "/x.tif"));
}

}  // namespace
