/// \file test_envi_writer.cpp
/// \brief The GDAL-free raster output: the raw band holds the rows in order as Float32 (or Float64)
/// bit for bit, the header describes the grid exactly (corner, cell size, size, nodata, CRS), rows out
/// of order and an incomplete raster are errors that leave an existing file as it was.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <unistd.h>

#include "pcl_delaunay_walk/core/dem/envi_writer.h"
#include "pcl_delaunay_walk/core/graph/types.h"

namespace {

std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

std::string tempPath(const std::string& name) {
  return std::string(::testing::TempDir()) + "dw_envi_" + std::to_string(::getpid()) + "_" + name;
}

dw::dem::RasterGrid grid3x4() {
  dw::dem::RasterGrid g;
  g.west = 636000.25, g.north = 849001.5, g.cell = 0.5, g.cols = 3, g.rows = 4;
  return g;
}

}  // namespace

TEST(EnviWriter, HeaderPathReplacesTheExtension) {
  EXPECT_EQ(dw::dem::enviHeaderPath("dir/dem.raw"), "dir/dem.hdr");
  EXPECT_EQ(dw::dem::enviHeaderPath("dir.v2/dem"), "dir.v2/dem.hdr");
  EXPECT_EQ(dw::dem::enviHeaderPath("a.b.bin"), "a.b.hdr");
}

TEST(EnviWriter, RowsInBatchesGiveTheCellsAsFloat32AndAnExactHeader) {
  const dw::dem::RasterGrid g = grid3x4();
  std::vector<double> v(g.size());
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = 120.0 + 0.1 * double(i) + 1e-9;
  v[4] = -9999;
  const std::string path = tempPath("f32.raw");
  dw::dem::EnviOptions o;
  o.srs_wkt = "PROJCS[\"x\"]";
  dw::dem::EnviWriter w(path, g, o);
  w.writeRows(0, 1, v.data());
  w.writeRows(1, 3, v.data() + 3);
  w.commit();
  const std::string raw = slurp(path);
  ASSERT_EQ(raw.size(), g.size() * sizeof(float));
  for (std::size_t i = 0; i < v.size(); ++i) {
    float f;
    std::memcpy(&f, raw.data() + 4 * i, 4);
    EXPECT_EQ(f, float(v[i])) << i;
  }
  const std::string hdr = slurp(dw::dem::enviHeaderPath(path));
  EXPECT_EQ(hdr.rfind("ENVI\n", 0), 0u);
  for (const char* line : {"samples = 3\n", "lines = 4\n", "bands = 1\n", "data type = 4\n", "interleave = bsq\n",
                           "byte order = 0\n", "map info = {Arbitrary, 1, 1, 636000.25, 849001.5, 0.5, 0.5}\n",
                           "data ignore value = -9999\n", "coordinate system string = {PROJCS[\"x\"]}\n"})
    EXPECT_NE(hdr.find(line), std::string::npos) << line << " missing from\n" << hdr;
  std::remove(path.c_str());
  std::remove(dw::dem::enviHeaderPath(path).c_str());
}

TEST(EnviWriter, Float64KeepsEveryBit) {
  const dw::dem::RasterGrid g = grid3x4();
  std::vector<double> v(g.size());
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = 1.0 / double(i + 3);
  const std::string path = tempPath("f64.raw");
  dw::dem::EnviOptions o;
  o.float64 = true;
  dw::dem::EnviWriter w(path, g, o);
  w.writeRows(0, 4, v.data());
  w.commit();
  const std::string raw = slurp(path);
  ASSERT_EQ(raw.size(), g.size() * sizeof(double));
  EXPECT_EQ(std::memcmp(raw.data(), v.data(), raw.size()), 0);
  EXPECT_NE(slurp(dw::dem::enviHeaderPath(path)).find("data type = 5\n"), std::string::npos);
  EXPECT_EQ(slurp(dw::dem::enviHeaderPath(path)).find("coordinate system string"), std::string::npos);
  std::remove(path.c_str());
  std::remove(dw::dem::enviHeaderPath(path).c_str());
}

TEST(EnviWriter, OutOfOrderRowsAndAnIncompleteRasterAreErrorsThatKeepTheOldFile) {
  const dw::dem::RasterGrid g = grid3x4();
  const std::string path = tempPath("keep.raw");
  { std::ofstream(path) << "old"; }
  const std::vector<double> v(g.size(), 1.0);
  {
    dw::dem::EnviWriter w(path, g);
    EXPECT_THROW(w.writeRows(1, 1, v.data()), dw::Error);
    w.writeRows(0, 2, v.data());
    EXPECT_THROW(w.writeRows(2, 3, v.data()), dw::Error);  // past the last row
    EXPECT_THROW(w.commit(), dw::Error);
  }
  EXPECT_EQ(slurp(path), "old");
  std::ifstream hdr(dw::dem::enviHeaderPath(path));
  EXPECT_FALSE(hdr.good());
  std::remove(path.c_str());
  dw::dem::RasterGrid empty = g;
  empty.rows = 0;
  EXPECT_THROW(dw::dem::EnviWriter(path, empty), dw::Error);
}
