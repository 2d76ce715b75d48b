/// \file test_las_crs.cpp
/// \brief The CRS records of a LAS file: the WKT and GeoTIFF-key VLRs (only under LASF_Projection), a
/// LAS 1.4 WKT EVLR, records that run past their bounds, and the real airborne tiles.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/las/las_crs.h"
#include "pcl_delaunay_walk/core/las/las_reader.h"
#include "pcl_delaunay_walk/core/las/las_writer.h"

namespace {

using Bytes = std::vector<unsigned char>;

std::string tmpPath(const std::string& name) {
  return std::string(DW_BINARY_DIR) + "/test_las_crs_" + std::to_string(::getpid()) + "_" + name;
}

Bytes readAll(const std::string& p) {
  std::ifstream f(p, std::ios::binary);
  return Bytes(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

void writeAll(const std::string& p, const Bytes& b) {
  std::ofstream(p, std::ios::binary)
      .write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
}

template <typename T>
void put(Bytes& b, std::size_t at, T v) {
  std::memcpy(b.data() + at, &v, sizeof v);
}
template <typename T>
T get(const Bytes& b, std::size_t at) {
  T v;
  std::memcpy(&v, b.data() + at, sizeof v);
  return v;
}

/// A VLR (54-byte header) or, with `extended`, an EVLR (60-byte header).
Bytes record(const char* user, std::uint16_t id, const Bytes& body, bool extended = false) {
  const std::size_t head = extended ? 60 : 54;
  Bytes r(head + body.size(), 0);
  for (std::size_t i = 0; i < 16 && user[i]; ++i) r[2 + i] = static_cast<unsigned char>(user[i]);
  put(r, 18, id);
  if (extended)
    put(r, 20, std::uint64_t(body.size()));
  else
    put(r, 20, std::uint16_t(body.size()));
  std::copy(body.begin(), body.end(), r.begin() + std::ptrdiff_t(head));
  return r;
}

Bytes text(const std::string& s) {
  Bytes b(s.begin(), s.end());
  b.push_back(0);
  b.push_back(0);  // padding NULs are allowed and removed
  return b;
}

/// A small LAS file of version 1.`minor` with `vlrs` spliced in after its header.
std::string lasWith(const std::string& name, unsigned minor, const std::vector<Bytes>& vlrs) {
  const std::string path = tmpPath(name);
  dw::las::LasHeader h;
  h.version_minor = std::uint8_t(minor);
  {
    dw::las::LasWriter w(path, h);
    for (int i = 0; i < 10; ++i) {
      dw::las::LasRecord r;
      r.X = i;
      r.Y = 2 * i;
      w.write(r);
    }
    w.close();
  }
  Bytes b = readAll(path);
  const std::uint16_t header_size = get<std::uint16_t>(b, 94);
  Bytes all;
  for (const Bytes& v : vlrs) all.insert(all.end(), v.begin(), v.end());
  b.insert(b.begin() + header_size, all.begin(), all.end());
  put(b, 96, std::uint32_t(get<std::uint32_t>(b, 96) + all.size()));
  put(b, 100, std::uint32_t(vlrs.size()));
  writeAll(path, b);
  return path;
}

TEST(LasCrs, ProjectionRecordsAreReadAndOthersIgnored) {
  const Bytes keys = {1,    0,    1, 0, 0, 0, 1,    0,
                      0x00, 0x0C, 0, 0, 1, 0, 0x5A, 0x7D};  // ProjectedCSTypeGeoKey 32090
  Bytes doubles(16);
  put(doubles, 0, 1.5);
  put(doubles, 8, -2.25);
  const std::string path =
      lasWith("vlrs.las", 2,
              {record("liblas", 2112, text("NOT THIS")), record("LASF_Projection", 34735, keys),
               record("LASF_Projection", 34736, doubles), record("LASF_Projection", 34737, text("UTM|")),
               record("LASF_Projection", 2112, text("PROJCS[\"x\"]")),
               record("LASF_Projection", 2112, text("PROJCS[\"second\"]"))});
  const dw::las::LasCrs crs = dw::las::readLasCrs(path);
  EXPECT_EQ(crs.wkt, "PROJCS[\"x\"]");
  ASSERT_EQ(crs.geo_keys.size(), 8u);
  EXPECT_EQ(crs.geo_keys[3], 1u);
  EXPECT_EQ(crs.geo_keys[4], 3072u);
  EXPECT_EQ(crs.geo_keys[7], 32090u);
  EXPECT_EQ(crs.geo_doubles, (std::vector<double>{1.5, -2.25}));
  EXPECT_EQ(crs.geo_ascii, std::string("UTM|\0\0", 6));
  EXPECT_EQ(dw::las::readLasFile(path).size(), 10u);  // the points still read past the VLRs
  std::remove(path.c_str());
}

TEST(LasCrs, Las14WktEvlrIsFound) {
  std::string path = lasWith("evlr.las", 4, {});
  Bytes b = readAll(path);
  const Bytes evlr = record("LASF_Projection", 2112, text("GEOGCS[\"evlr\"]"), true);
  put(b, 235, std::uint64_t(b.size()));
  put(b, 243, std::uint32_t(1));
  b.insert(b.end(), evlr.begin(), evlr.end());
  writeAll(path, b);
  EXPECT_EQ(dw::las::readLasCrs(path).wkt, "GEOGCS[\"evlr\"]");
  EXPECT_TRUE(dw::las::readLasCrs(path).geo_keys.empty());
  // An EVLR announced beyond the end of the file is an error naming it.
  put(b, 235, std::uint64_t(b.size() + 100));
  writeAll(path, b);
  try {
    dw::las::readLasCrs(path);
    FAIL();
  } catch (const dw::las::LasError& e) {
    EXPECT_NE(std::string(e.what()).find("EVLR 0"), std::string::npos) << e.what();
  }
  std::remove(path.c_str());
}

TEST(LasCrs, NoRecordsGiveAnEmptyCrsAndBadRecordsAnError) {
  const std::string plain = lasWith("plain.las", 2, {});
  EXPECT_TRUE(dw::las::readLasCrs(plain).empty());
  std::remove(plain.c_str());
  // A VLR claiming more bytes than lie before the points.
  const std::string path = lasWith("long.las", 2, {record("LASF_Projection", 2112, text("PROJCS[]"))});
  Bytes b = readAll(path);
  put(b, 227 + 20, std::uint16_t(5000));
  writeAll(path, b);
  try {
    dw::las::readLasCrs(path);
    FAIL();
  } catch (const dw::las::LasError& e) {
    EXPECT_NE(std::string(e.what()).find("VLR 0 runs past the point data offset"), std::string::npos)
        << e.what();
  }
  std::remove(path.c_str());
  EXPECT_THROW(dw::las::readLasCrs(tmpPath("missing.las")), dw::las::LasError);
}

TEST(LasCrs, BundledCropKeepsTheAutzenRecords) {
  const auto crop = dw::las::readLasCrs(std::string(DW_TEST_DATA_DIR) + "/autzen_crop.las");
  EXPECT_EQ(crop.wkt.rfind("PROJCS[\"NAD_1983_HARN_Lambert_Conformal_Conic\"", 0), 0u) << crop.wkt;
  EXPECT_EQ(crop.geo_keys.size(), 92u);
  EXPECT_EQ(crop.geo_doubles.size(), 9u);  // a 72-byte GeoDoubleParamsTag
  EXPECT_EQ(dw::las::readLasFile(std::string(DW_TEST_DATA_DIR) + "/autzen_crop.las").size(), 5779u);
}

TEST(LasCrs, RealTilesCarryTheirCoordinateSystems) {
  const std::string dir = std::string(DW_SHARED_DATA_DIR) + "/airborne/";
  if (!std::ifstream(dir + "autzen_trim.las").good())
    GTEST_SKIP() << dir << " is absent (the shared real data set)";
  const auto autzen = dw::las::readLasCrs(dir + "autzen_trim.las");
  EXPECT_EQ(autzen.wkt.rfind("PROJCS[\"NAD_1983_HARN_Lambert_Conformal_Conic\"", 0), 0u) << autzen.wkt;
  EXPECT_EQ(autzen.geo_keys.size(), 92u);  // a 184-byte GeoKeyDirectoryTag
  const auto laz = dw::las::readLasCrs(dir + "las_with_several_extra_byte_bloc.laz");
  EXPECT_EQ(laz.wkt.rfind("PROJCRS[\"RGF93 / Lambert-93\"", 0), 0u) << laz.wkt.substr(0, 60);
  EXPECT_EQ(laz.wkt, dw::las::readLasCrs(dir + "las_with_several_extra_byte_bloc.las").wkt);
}

}  // namespace
