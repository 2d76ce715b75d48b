/// \file test_las_io.cpp
/// \brief pcl::io::loadLASFile: fields per point type, centring origin, class filter, errors, real tile.
#include <gtest/gtest.h>
#include <pcl/point_types.h>

#include <cstdio>
#include <fstream>

#include "pcl_delaunay_walk/core/las/las_writer.h"
#include "pcl_delaunay_walk/io/las_io.h"

namespace {

std::string tmp(const std::string& n) {
  return std::string(DW_BINARY_DIR) + "/test_las_io_" + n;
}

std::string writeSmall(const std::string& name) {
  dw::las::LasHeader h;
  h.version_minor = 2;
  h.point_format = 3;
  h.scale[0] = h.scale[1] = h.scale[2] = 0.01;
  h.offset[0] = 400000.0;
  h.offset[1] = 5000000.0;
  h.offset[2] = 100.0;
  const std::string path = tmp(name);
  dw::las::LasWriter w(path, h);
  for (int i = 0; i < 100; ++i) {
    dw::las::LasRecord r;
    r.X = 1000000 + i * 37;
    r.Y = 2000000 - i * 11;
    r.Z = i * 5;
    r.intensity = std::uint16_t(i * 100);
    r.classification = std::uint8_t(i % 4 == 0 ? 2 : 1);
    r.rgb[0] = std::uint16_t(i * 256);  // 16-bit colour
    r.rgb[1] = 0;
    r.rgb[2] = 65535;
    r.return_number = r.number_of_returns = 1;
    w.write(r);
  }
  w.close();
  return path;
}

TEST(LasIo, FieldsOriginAndFilter) {
  const std::string path = writeSmall("small.las");
  pcl::PointCloud<pcl::PointXYZRGB> rgb;
  Eigen::Vector3d origin;
  ASSERT_EQ(pcl::io::loadLASFile(path, rgb, &origin), 0);
  ASSERT_EQ(rgb.size(), 100u);
  for (int i : {0, 42, 99}) {
    const double wx = (1000000 + i * 37) * 0.01 + 400000.0, wy = (2000000 - i * 11) * 0.01 + 5000000.0;
    EXPECT_NEAR(rgb[i].x + origin.x(), wx, 1e-3);
    EXPECT_NEAR(rgb[i].y + origin.y(), wy, 1e-3);
    EXPECT_NEAR(rgb[i].z + origin.z(), i * 0.05 + 100.0, 1e-4);
    EXPECT_EQ(rgb[i].r, (i * 256) >> 8);
    EXPECT_EQ(rgb[i].b, 255);
  }
  EXPECT_LT(std::abs(rgb[50].x), 100.0f);  // centred: small floats keep centimetres

  pcl::PointCloud<pcl::PointXYZI> inten;
  ASSERT_EQ(pcl::io::loadLASFile(path, inten), 0);
  EXPECT_EQ(inten[7].intensity, 700.0f);

  pcl::PointCloud<pcl::PointXYZL> ground;
  pcl::io::LASLoadOptions o;
  o.classification = 2;
  ASSERT_EQ(pcl::io::loadLASFile(path, ground, nullptr, o), 0);
  EXPECT_EQ(ground.size(), 25u);
  for (const auto& p : ground) EXPECT_EQ(p.label, 2u);
  std::remove(path.c_str());
}

TEST(LasIo, BadFilesThrow) {
  pcl::PointCloud<pcl::PointXYZ> c;
  EXPECT_THROW(pcl::io::loadLASFile(tmp("missing.las"), c), dw::las::LasError);
  const std::string path = writeSmall("trunc.las");
  {
    std::ifstream f(path, std::ios::binary);
    std::string b((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    std::ofstream o(path, std::ios::binary | std::ios::trunc);
    o.write(b.data(), std::streamsize(b.size() - 10));
  }
  try {
    pcl::io::loadLASFile(path, c);
    FAIL() << "no exception";
  } catch (const dw::las::LasError& e) {
    EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos) << e.what();
  }
  std::remove(path.c_str());
  // A truncated LAZ file: a clear LasError, never a partial cloud.
  const std::string laz = std::string(DW_SHARED_DATA_DIR) + "/airborne/las_with_several_extra_byte_bloc.laz";
  if (std::ifstream(laz).good()) {
    const std::string cut = std::string(DW_BINARY_DIR) + "/las_io_truncated.laz";
    {
      std::ifstream f(laz, std::ios::binary);
      std::string b((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
      std::ofstream o(cut, std::ios::binary | std::ios::trunc);
      o.write(b.data(), std::streamsize(b.size() / 2));
    }
    EXPECT_THROW(pcl::io::loadLASFile(cut, c), dw::las::LasError);
    std::remove(cut.c_str());
  }
}

TEST(LasIo, LazLoadsAsItsLasTwin) {
  const std::string base = std::string(DW_SHARED_DATA_DIR) + "/airborne/las_with_several_extra_byte_bloc";
  if (!std::ifstream(base + ".laz").good()) GTEST_SKIP() << base << ".laz absent";
  pcl::PointCloud<pcl::PointXYZ> a, b;
  pcl::io::loadLASFile(base + ".laz", a);
  pcl::io::loadLASFile(base + ".las", b);
  ASSERT_EQ(a.size(), b.size());
  ASSERT_GT(a.size(), 0u);
  for (std::size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a[i].x, b[i].x) << i;
    ASSERT_EQ(a[i].y, b[i].y) << i;
    ASSERT_EQ(a[i].z, b[i].z) << i;
  }
}

TEST(LasIo, RealTile) {
  const std::string path = std::string(DW_SHARED_DATA_DIR) + "/airborne/autzen_trim.las";
  if (!std::ifstream(path).good()) GTEST_SKIP() << "shared data not present: " << path;
  pcl::PointCloud<pcl::PointXYZ> all, ground;
  Eigen::Vector3d o;
  ASSERT_EQ(pcl::io::loadLASFile(path, all, &o), 0);
  EXPECT_EQ(all.size(), 110000u);
  pcl::io::LASLoadOptions opt;
  opt.classification = 2;
  ASSERT_EQ(pcl::io::loadLASFile(path, ground, nullptr, opt), 0);
  EXPECT_EQ(ground.size(), 26107u);
  for (std::size_t i = 0; i < all.size(); i += 1000) {
    EXPECT_GT(all[i].z + o.z(), 405.0);
    EXPECT_LT(all[i].z + o.z(), 522.0);
  }
}

}  // namespace
