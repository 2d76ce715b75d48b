/// \file test_laz.cpp
/// \brief The LAZ decoder against uncompressed twins: every byte of every record equal (extra bytes
/// included), through the streaming reader, the parallel whole-file reader, and seeks.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "core/las/laz_reader.h"
#include "pcl_delaunay_walk/core/las/las_reader.h"

namespace {

using dw::las::LasError;
using dw::las::LasReader;
using dw::las::LasRecord;

/// The shared data folder; DW_SHARED_DATA overrides the configured one (a worktree's ../shared).
std::string shared(const std::string& rel) {
  const char* env = std::getenv("DW_SHARED_DATA");
  return std::string(env ? env : DW_SHARED_DATA_DIR) + "/" + rel;
}
bool exists(const std::string& p) {
  return std::ifstream(p).good();
}

std::vector<unsigned char> fileBytes(const std::string& p) {
  std::ifstream in(p, std::ios::binary);
  return std::vector<unsigned char>((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

/// Decodes every chunk of `laz` and compares the raw records with the point block of `las`.
void expectRecordsEqual(const std::string& laz, const std::string& las) {
  const LasReader twin(las);
  const auto raw = fileBytes(las);
  const dw::las::LasHeader& h = twin.header();
  std::FILE* f = std::fopen(laz.c_str(), "rb");
  ASSERT_TRUE(f);
  std::fseek(f, 0, SEEK_END);
  const long size = std::ftell(f);
  const LasReader reader(laz);
  ASSERT_EQ(reader.header().point_count, h.point_count);
  ASSERT_EQ(reader.header().record_length, h.record_length);
  const dw::las::LazChunks chunks(fileno(f), laz, reader.header(), std::uint64_t(size));
  auto decoder = chunks.makeDecoder();
  std::vector<std::uint8_t> compressed, records;
  std::uint64_t mismatches = 0;
  for (std::size_t c = 0; c < chunks.size(); ++c) {
    chunks.decode(c, *decoder, compressed, records);
    const unsigned char* want = raw.data() + h.offset_to_points + chunks.firstPoint(c) * h.record_length;
    for (std::uint64_t i = 0; i < chunks.points(c); ++i)
      if (std::memcmp(records.data() + i * h.record_length, want + i * h.record_length, h.record_length) !=
          0) {
        if (mismatches++ < 3) ADD_FAILURE() << "chunk " << c << " point " << i << " differs";
      }
  }
  std::fclose(f);
  EXPECT_EQ(mismatches, 0u);
}

TEST(Laz, SharedFormat8FileEqualsItsTwinByteForByte) {
  const std::string laz = shared("airborne/las_with_several_extra_byte_bloc.laz");
  const std::string las = shared("airborne/las_with_several_extra_byte_bloc.las");
  if (!exists(laz) || !exists(las)) GTEST_SKIP() << "shared data missing";
  expectRecordsEqual(laz, las);
}

TEST(Laz, StreamingReaderAndParallelReaderGiveTheTwinsRecords) {
  const std::string laz = shared("airborne/las_with_several_extra_byte_bloc.laz");
  const std::string las = shared("airborne/las_with_several_extra_byte_bloc.las");
  if (!exists(laz) || !exists(las)) GTEST_SKIP() << "shared data missing";
  LasReader a(laz), b(las);
  std::vector<LasRecord> ra, rb;
  a.seek(123457);
  b.seek(123457);
  ASSERT_EQ(a.read(ra, 70001), b.read(rb, 70001));
  for (std::size_t i = 0; i < ra.size(); ++i) {
    ASSERT_EQ(ra[i].X, rb[i].X) << i;
    ASSERT_EQ(ra[i].gps_time, rb[i].gps_time) << i;
    ASSERT_EQ(ra[i].classification, rb[i].classification) << i;
  }
  for (unsigned threads : {1u, 3u}) {
    dw::las::LasReadOptions o;
    o.threads = threads;
    o.classification = 2;
    o.keep_attributes = true;
    const auto ca = dw::las::readLasFile(laz, o);
    const auto cb = dw::las::readLasFile(las, o);
    EXPECT_EQ(ca.X, cb.X);
    EXPECT_EQ(ca.Y, cb.Y);
    EXPECT_EQ(ca.Z, cb.Z);
    EXPECT_EQ(ca.intensity, cb.intensity);
    EXPECT_EQ(ca.return_number, cb.return_number);
  }
}

}  // namespace
