// A pre-split set of LAS files read as one sequence (las_input_set.h): any range of the set gives the
// records and frame coordinates the single file gives, so a rank's share does not depend on how the
// cloud was split. Also the helper that splits a real LAS file for test/mpi_run (DW_MPI_SPLIT).
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/las/las_writer.h"
#include "pcl_delaunay_walk/core/las/laz_writer.h"
#include "pcl_delaunay_walk/mpi/las_input_set.h"

namespace {

using dw::las::LasHeader;
using dw::las::LasReader;
using dw::las::LasRecord;
using dw::las::LasWriter;
using dw::mpi::LasInputSet;

// One directory per test: ctest runs the tests of this binary as parallel processes, and a shared
// source.las written by one test while another reads it made them flaky.
std::string testDir() {
  return std::string(DW_BINARY_DIR) + "/test_las_input_set/" +
         ::testing::UnitTest::GetInstance()->current_test_info()->name();
}

/// Writes records [first, last) of `src` into `path`, with the source's header but the x/y offset moved
/// by `shift` scaled units (records moved back, so world coordinates stay put).
void writePart(const std::string& src, const std::string& path, std::uint64_t first, std::uint64_t last,
               std::int32_t shift = 0) {
  LasReader in(src);
  LasHeader h = in.header();
  h.offset[0] += shift * h.scale[0];
  h.offset[1] += shift * h.scale[1];
  LasWriter out(path, h);
  in.seek(first);
  std::vector<LasRecord> buf;
  for (std::uint64_t at = first; at < last;) {
    const std::size_t got = in.read(buf, static_cast<std::size_t>(std::min<std::uint64_t>(last - at, 4096)));
    ASSERT_GT(got, 0u);
    for (std::size_t i = 0; i < got; ++i) {
      LasRecord r = buf[i];
      r.X -= shift;
      r.Y -= shift;
      out.write(r);
    }
    at += got;
  }
  out.close();
}

std::string makeSource(std::size_t n) {
  std::filesystem::create_directories(testDir());
  const std::string path = testDir() + "/source.las";
  LasHeader h;
  h.point_format = 1;
  h.scale[0] = h.scale[1] = h.scale[2] = 0.01;
  h.offset[0] = 500000;
  h.offset[1] = 4000000;
  LasWriter w(path, h);
  std::mt19937 rng(3);
  std::uniform_int_distribution<std::int32_t> c(-100000, 100000);
  for (std::size_t i = 0; i < n; ++i) {
    LasRecord r;
    r.X = c(rng), r.Y = c(rng), r.Z = c(rng) / 10;
    r.classification = static_cast<std::uint8_t>(i % 3);
    w.write(r);
  }
  w.close();
  return path;
}

struct Pt {
  double x, y, z;
  int cls;
  bool operator==(const Pt& o) const { return x == o.x && y == o.y && z == o.z && cls == o.cls; }
};

std::vector<Pt> collect(const LasInputSet& s, std::uint64_t first, std::uint64_t last) {
  std::vector<Pt> out;
  s.forEach(first, last, [&](const LasRecord& r, double x, double y, double z) {
    out.push_back({x, y, z, r.classification});
  });
  return out;
}

TEST(LasInputSet, SplitFilesReadLikeTheWholeFile) {
  const std::string src = makeSource(5000);
  const std::string a = testDir() + "/a.las", b = testDir() + "/b.las", c = testDir() + "/c.las";
  writePart(src, a, 0, 700);
  writePart(src, b, 700, 701);  // one record
  writePart(src, c, 701, 5000);
  const LasInputSet whole({src});
  const LasInputSet parts({a, b, c});
  ASSERT_EQ(whole.size(), 5000u);
  ASSERT_EQ(parts.size(), 5000u);
  EXPECT_EQ(parts.frame().scale[0], 0.01);  // same scale and offset everywhere: the LAS integer frame
  EXPECT_EQ(parts.frame().offset[1], 4000000);
  const std::vector<Pt> all = collect(whole, 0, 5000);
  EXPECT_EQ(collect(parts, 0, 5000), all);
  // Ranges across file boundaries, as ranks of a run read them.
  for (int P : {2, 3, 7}) {
    std::vector<Pt> joined;
    for (int r = 0; r < P; ++r) {
      const std::vector<Pt> share = collect(parts, 5000ull * r / P, 5000ull * (r + 1) / P);
      joined.insert(joined.end(), share.begin(), share.end());
    }
    EXPECT_EQ(joined, all) << P << " ranks";
  }
  EXPECT_EQ(collect(parts, 699, 702), std::vector<Pt>(all.begin() + 699, all.begin() + 702));
  EXPECT_TRUE(collect(parts, 4000, 4000).empty());
  // max_records cuts the sequence, not each file.
  const LasInputSet cut({a, b, c}, 701);
  EXPECT_EQ(cut.size(), 701u);
  EXPECT_EQ(collect(cut, 0, 5000), std::vector<Pt>(all.begin(), all.begin() + 701));
}

/// A LAZ file's chunk starts are the boundaries a range snaps to (the nearer one; a LAS file in the
/// same set keeps every record a boundary), and ranges cut there read the LAS twin's records.
TEST(LasInputSet, LazRangesSnapToChunkStarts) {
  const std::string las = makeSource(3500);
  const std::string laz = testDir() + "/source.laz", tail = testDir() + "/tail.las";
  {
    LasReader in(las);
    dw::las::LazWriter w(laz, in.header(), 0, 1000);
    std::vector<LasRecord> buf;
    while (in.read(buf) > 0)
      for (const LasRecord& r : buf) w.write(r);
    w.close();
  }
  writePart(las, tail, 0, 500);
  const LasInputSet set({laz, tail});
  ASSERT_EQ(set.size(), 4000u);
  const std::vector<std::pair<std::uint64_t, std::uint64_t>> expect = {
      {0, 0},       {400, 0},     {500, 0},     {501, 1000}, {1999, 2000},
      {3400, 3500}, {3600, 3600}, {3999, 3999}, {4000, 4000}};
  for (const auto& [at, want] : expect) EXPECT_EQ(set.alignToChunk(at), want) << at;
  std::uint64_t prev = 0;
  for (std::uint64_t i = 0; i <= set.size(); i += 7) {
    EXPECT_GE(set.alignToChunk(i), prev) << i;
    prev = set.alignToChunk(i);
  }
  // max_records cuts the LAZ file inside its third chunk: the cut is the file's end.
  const LasInputSet cut({laz}, 2500);
  EXPECT_EQ(cut.alignToChunk(2300), 2500u);
  EXPECT_EQ(cut.alignToChunk(2200), 2000u);

  const LasInputSet twin({las, tail});
  for (int P : {2, 3}) {
    for (int r = 0; r < P; ++r) {
      const std::uint64_t a = set.alignToChunk(4000u * r / P), b = set.alignToChunk(4000u * (r + 1) / P);
      EXPECT_EQ(collect(set, a, b), collect(twin, a, b)) << P << " " << r;
    }
  }
}

TEST(LasInputSet, DifferentOffsetsShareOneScaledFrame) {
  const std::string src = makeSource(1000);
  const std::string a = testDir() + "/s0.las", b = testDir() + "/s1.las";
  writePart(src, a, 0, 400);
  writePart(src, b, 400, 1000, 12345);
  const LasInputSet parts({a, b});
  EXPECT_EQ(parts.frame().scale[0], 1.0);
  EXPECT_EQ(parts.frame().offset[0], 500000);
  LasReader rb(b);
  std::vector<LasRecord> recs;
  rb.read(recs, 10);
  const std::vector<Pt> got = collect(parts, 400, 410);
  const double dx = rb.header().offset[0] - 500000;
  for (int i = 0; i < 10; ++i) EXPECT_EQ(got[i].x, recs[i].X * 0.01 + dx);
  // Same world position as in the unshifted source, up to the rounding of the scaled frame.
  const std::vector<Pt> ref = collect(LasInputSet({src}), 400, 410);
  for (int i = 0; i < 10; ++i) EXPECT_NEAR(got[i].x, ref[i].x * 0.01, 1e-6);
}

TEST(LasInputSet, PathListAndBadInput) {
  makeSource(10);
  {
    std::ofstream l(testDir() + "/list.txt");
    l << "# parts\n\nsource.las\n  " << testDir() << "/source.las  \r\n";
  }
  const std::vector<std::string> p = dw::mpi::readPathList(testDir() + "/list.txt");
  ASSERT_EQ(p.size(), 2u);
  EXPECT_EQ(p[0], testDir() + "/source.las");
  EXPECT_EQ(p[1], testDir() + "/source.las");
  EXPECT_EQ(LasInputSet(p).size(), 20u);
  { std::ofstream l(testDir() + "/empty.txt"); }
  EXPECT_THROW(dw::mpi::readPathList(testDir() + "/empty.txt"), dw::Error);
  EXPECT_THROW(dw::mpi::readPathList(testDir() + "/no-such-list.txt"), dw::Error);
  EXPECT_THROW(LasInputSet({}), dw::Error);
  EXPECT_THROW(LasInputSet({testDir() + "/source.las", testDir() + "/missing.las"}), dw::Error);
  {
    std::ofstream bad(testDir() + "/bad.las");
    bad << "not a LAS file at all";
  }
  EXPECT_THROW(LasInputSet({testDir() + "/bad.las"}), dw::Error);
}

// Helper for test/mpi_run: DW_MPI_SPLIT="in.las;outdir" writes three unequal parts of in.las and
// outdir/parts.txt (relative names), plus outdir/shifted.txt whose middle part has another offset.
TEST(LasSplit, WriteParts) {
  const char* env = std::getenv("DW_MPI_SPLIT");
  if (!env) GTEST_SKIP() << "DW_MPI_SPLIT not set (test/mpi_run uses this helper)";
  const std::string spec = env;
  const std::size_t semi = spec.find(';');
  ASSERT_NE(semi, std::string::npos);
  const std::string src = spec.substr(0, semi), dir = spec.substr(semi + 1);
  const std::uint64_t n = LasReader(src).header().point_count;
  const std::uint64_t cut[4] = {0, n * 15 / 100, n * 50 / 100, n};
  for (int k = 0; k < 3; ++k) {
    writePart(src, dir + "/part" + std::to_string(k) + ".las", cut[k], cut[k + 1]);
    writePart(src, dir + "/shifted" + std::to_string(k) + ".las", cut[k], cut[k + 1], k == 1 ? 777 : 0);
  }
  std::ofstream(dir + "/parts.txt") << "# three unequal parts\npart0.las\npart1.las\npart2.las\n";
  std::ofstream(dir + "/shifted.txt") << "shifted0.las\nshifted1.las\nshifted2.las\n";
  EXPECT_EQ(LasInputSet(dw::mpi::readPathList(dir + "/parts.txt")).size(), n);
}

}  // namespace
