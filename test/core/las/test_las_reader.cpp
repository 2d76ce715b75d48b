/// \file test_las_reader.cpp
/// \brief LAS reader/writer: every point format 0-10 in every version that allows it, extra bytes,
/// class filtering, corrupt/truncated/LAZ files, and the real airborne tiles.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/las/las_reader.h"
#include "pcl_delaunay_walk/core/las/las_writer.h"

namespace {

using dw::las::LasError;
using dw::las::LasHeader;
using dw::las::LasReader;
using dw::las::LasRecord;
using dw::las::LasWriter;

std::string tmpPath(const std::string& name) {
  return std::string(DW_BINARY_DIR) + "/test_las_" + std::to_string(::getpid()) + "_" + name;
}

std::vector<LasRecord> sampleRecords(unsigned format, std::size_t n) {
  std::mt19937 rng(format * 31 + 7);
  std::vector<LasRecord> v(n);
  const unsigned max_class = format <= 5 ? 31 : 255;
  const unsigned max_ret = format <= 5 ? 7 : 15;
  for (auto& r : v) {
    r.X = int(rng() % 2000000) - 1000000;
    r.Y = int(rng() % 2000000) - 1000000;
    r.Z = int(rng() % 100000);
    r.intensity = std::uint16_t(rng());
    r.number_of_returns = std::uint8_t(1 + rng() % max_ret);
    r.return_number = std::uint8_t(1 + rng() % r.number_of_returns);
    r.classification = std::uint8_t(rng() % (max_class + 1));
    r.flags = std::uint8_t(rng() % (format <= 5 ? 8 : 16));
    r.scan_angle =
        format <= 5 ? std::int16_t(int(rng() % 181) - 90) : std::int16_t(int(rng() % 60001) - 30000);
    r.user_data = std::uint8_t(rng());
    r.point_source_id = std::uint16_t(rng());
    if (dw::las::formatHasGpsTime(format)) r.gps_time = double(rng()) * 0.001;
    if (dw::las::formatHasRgb(format))
      for (auto& c : r.rgb) c = std::uint16_t(rng());
    if (dw::las::formatHasNir(format)) r.nir = std::uint16_t(rng());
  }
  return v;
}

void writeFile(const std::string& path, unsigned minor, unsigned format, const std::vector<LasRecord>& recs,
               unsigned extra = 0) {
  LasHeader h;
  h.version_minor = std::uint8_t(minor);
  h.point_format = std::uint8_t(format);
  h.scale[0] = h.scale[1] = 0.01;
  h.scale[2] = 0.001;
  h.offset[0] = 500000.0;
  h.offset[1] = 6000000.0;
  h.offset[2] = 0.0;
  LasWriter w(path, h, extra);
  for (const auto& r : recs) w.write(r);
  w.close();
}

std::vector<unsigned char> slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::vector<unsigned char>((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}
void spit(const std::string& path, const std::vector<unsigned char>& b) {
  std::ofstream f(path, std::ios::binary);
  f.write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
}

std::string errorOf(const std::string& path) {
  try {
    LasReader r(path);
    std::vector<LasRecord> v;
    while (r.read(v) > 0) {
    }
  } catch (const LasError& e) {
    return e.what();
  }
  return "";
}

TEST(LasReader, EveryFormatAndVersionRoundTrips) {
  int files = 0;
  for (unsigned minor = 0; minor <= 4; ++minor)
    for (unsigned format = 0; format <= 10; ++format) {
      if (format >= 6 && minor < 4) continue;
      if (format >= 4 && format <= 5 && minor < 3) continue;  // waveform formats arrived in 1.3
      if ((format == 2 || format == 3) && minor < 2) continue;
      for (unsigned extra : {0u, 3u}) {
        const auto recs = sampleRecords(format, 300);
        const std::string path =
            tmpPath("f" + std::to_string(format) + "_v1" + std::to_string(minor) + ".las");
        writeFile(path, minor, format, recs, extra);
        LasReader reader(path);
        EXPECT_EQ(reader.header().point_format, format);
        EXPECT_EQ(reader.header().version_minor, minor);
        EXPECT_EQ(reader.header().point_count, recs.size());
        EXPECT_EQ(reader.header().record_length, dw::las::baseRecordSize(format) + extra);
        std::vector<LasRecord> got, chunk;
        while (reader.read(chunk, 77) > 0) got.insert(got.end(), chunk.begin(), chunk.end());
        ASSERT_EQ(got.size(), recs.size());
        for (std::size_t i = 0; i < recs.size(); ++i) {
          const LasRecord &a = recs[i], &b = got[i];
          ASSERT_EQ(a.X, b.X);
          ASSERT_EQ(a.Y, b.Y);
          ASSERT_EQ(a.Z, b.Z);
          ASSERT_EQ(a.intensity, b.intensity);
          ASSERT_EQ(a.return_number, b.return_number);
          ASSERT_EQ(a.number_of_returns, b.number_of_returns);
          ASSERT_EQ(a.classification, b.classification);
          ASSERT_EQ(a.flags, b.flags);
          ASSERT_EQ(a.scan_angle, b.scan_angle);
          ASSERT_EQ(a.user_data, b.user_data);
          ASSERT_EQ(a.point_source_id, b.point_source_id);
          ASSERT_EQ(a.gps_time, b.gps_time);
          ASSERT_EQ(a.rgb[0], b.rgb[0]);
          ASSERT_EQ(a.rgb[2], b.rgb[2]);
          ASSERT_EQ(a.nir, b.nir);
        }
        // Header bounds are the world coordinates of the extremes.
        double mx = -1e300;
        for (const auto& r : recs) mx = std::max(mx, r.X * 0.01 + 500000.0);
        EXPECT_DOUBLE_EQ(reader.header().max[0], mx);
        std::remove(path.c_str());
        ++files;
      }
    }
  EXPECT_EQ(files, 2 * (11 + 6 + 4 + 2 + 2));  // 1.4: 0-10; 1.3: 0-5; 1.2: 0-3; 1.0/1.1: 0-1
}

TEST(LasReader, ClassFilterAndWorldCoordinates) {
  auto recs = sampleRecords(1, 1000);
  for (std::size_t i = 0; i < recs.size(); ++i) recs[i].classification = (i % 3 == 0) ? 2 : 1;
  const std::string path = tmpPath("filter.las");
  writeFile(path, 2, 1, recs);
  dw::las::LasReadOptions o;
  o.classification = 2;
  o.keep_attributes = true;
  const auto cloud = dw::las::readLasFile(path, o);
  ASSERT_EQ(cloud.size(), 334u);
  for (std::size_t i = 0; i < cloud.size(); ++i) EXPECT_EQ(cloud.classification[i], 2);
  EXPECT_DOUBLE_EQ(cloud.x(1), recs[3].X * 0.01 + 500000.0);
  EXPECT_DOUBLE_EQ(cloud.y(1), recs[3].Y * 0.01 + 6000000.0);
  std::remove(path.c_str());
}

TEST(LasReader, CorruptFilesGiveClearErrors) {
  const auto recs = sampleRecords(3, 100);
  const std::string good = tmpPath("good.las");
  writeFile(good, 2, 3, recs);
  const auto bytes = slurp(good);
  const std::string bad = tmpPath("bad.las");
  auto expectError = [&](std::vector<unsigned char> b, const std::string& needle) {
    spit(bad, b);
    const std::string msg = errorOf(bad);
    EXPECT_NE(msg.find(needle), std::string::npos) << "message: '" << msg << "', wanted '" << needle << "'";
  };
  expectError({bytes.begin(), bytes.end() - 50}, "truncated");
  expectError({bytes.begin(), bytes.begin() + 100}, "too short");
  auto b = bytes;
  b[0] = 'X';
  expectError(b, "signature");
  b = bytes;
  b[24] = 2;
  expectError(b, "unsupported LAS version 2.2");
  b = bytes;
  b[104] = 11;
  expectError(b, "unsupported point data record format 11");
  b = bytes;
  b[104] = 3 | 0x80;  // LASzip's compressed marker
  expectError(b, "LAZ");
  b = bytes;
  b[105] = 20;  // record length shorter than format 3 needs
  b[106] = 0;
  expectError(b, "shorter");
  b = bytes;
  b[94] = 100;  // header size
  b[95] = 0;
  expectError(b, "header size");
  b = bytes;
  b[104] = 6;  // format 6 in a LAS 1.2 file
  expectError(b, "requires LAS 1.4");
  b = bytes;
  std::memset(b.data() + 131, 0, 8);  // x scale 0
  expectError(b, "scale");
  EXPECT_NE(errorOf(tmpPath("does_not_exist.las")).find("cannot open"), std::string::npos);
  std::remove(good.c_str());
  std::remove(bad.c_str());
}

std::string shared(const std::string& rel) {
  return std::string(DW_SHARED_DATA_DIR) + "/" + rel;
}
bool haveShared(const std::string& rel) {
  return std::ifstream(shared(rel)).good();
}

TEST(LasReader, RealAirborneTiles) {
  if (!haveShared("airborne/autzen_trim.las"))
    GTEST_SKIP() << "shared data (../shared/data/airborne) not present";
  dw::las::LasReadOptions o;
  o.keep_attributes = true;
  const auto autzen = dw::las::readLasFile(shared("airborne/autzen_trim.las"), o);
  EXPECT_EQ(autzen.header.point_format, 3);
  EXPECT_EQ(autzen.size(), 110000u);
  std::size_t ground = 0, c1 = 0;
  for (auto c : autzen.classification) {
    ground += c == 2;
    c1 += c == 1;
  }
  EXPECT_EQ(ground, 26107u);  // counts published in shared/data/README.md
  EXPECT_EQ(c1, 83893u);
  for (std::size_t i = 0; i < autzen.size(); i += 997) {
    EXPECT_GE(autzen.x(i), autzen.header.min[0] - 1e-6);
    EXPECT_LE(autzen.x(i), autzen.header.max[0] + 1e-6);
    EXPECT_GE(autzen.z(i), 406.0);
    EXPECT_LE(autzen.z(i), 521.0);
  }
  const auto hexbin = dw::las::readLasFile(shared("airborne/hexbin-crop.las"));
  EXPECT_EQ(hexbin.header.point_format, 1);
  EXPECT_EQ(hexbin.size(), 38367u);

  LasReader big(shared("airborne/las_with_several_extra_byte_bloc.las"));
  EXPECT_EQ(big.header().version_minor, 4);
  EXPECT_EQ(big.header().point_format, 8);
  EXPECT_EQ(big.header().record_length, 41);
  EXPECT_EQ(big.header().point_count, 697721u);

  // The LAZ twin opens with the same header (test_laz.cpp compares its records).
  LasReader laz(shared("airborne/las_with_several_extra_byte_bloc.laz"));
  EXPECT_EQ(laz.header().point_format, 8);
  EXPECT_EQ(laz.header().point_count, 697721u);
}

}  // namespace
