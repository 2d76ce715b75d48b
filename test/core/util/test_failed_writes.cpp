// Every writer of the core under a failed write: dw::saveGraph, the PLY writer, LasWriter and LazWriter
// capped by RLIMIT_FSIZE ("File too large"), in a read-only folder, and killed before their commit or
// in the middle of a large write. The old target stays byte for byte and no partial file stays.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "core/util/write_failure_harness.h"
#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/core/graph/graph_io.h"
#include "pcl_delaunay_walk/core/las/las_reader.h"
#include "pcl_delaunay_walk/core/las/las_writer.h"
#include "pcl_delaunay_walk/core/las/laz_writer.h"
#include "pcl_delaunay_walk/core/las/synthetic_lidar.h"
#include "pcl_delaunay_walk/core/tin/ply_writer.h"

namespace {

using dw_test::readBytes;

/// The graph of n random points (built here, in the parent: the children only write).
const dw::DelaunayGraph& graphOf(std::size_t n) {
  static std::map<std::size_t, dw::DelaunayGraph> cache;
  auto it = cache.find(n);
  if (it != cache.end()) return it->second;
  std::mt19937 rng(static_cast<unsigned>(n));
  std::uniform_real_distribution<double> u(-10, 10);
  std::vector<double> xyz(3 * n);
  for (double& v : xyz) v = u(rng);
  dw::BuildOptions o;
  o.num_threads = 1;
  return cache[n] = dw::buildDelaunayGraph(dw::PointView::fromDouble(xyz.data(), n), o);
}

/// A mesh of a (k+1) x (k+1) grid of points, two triangles per cell.
void writeGridPly(const std::string& path, int k, const std::function<void()>& before_close = {}) {
  const std::uint64_t nv = std::uint64_t(k + 1) * (k + 1), nf = 2 * std::uint64_t(k) * k;
  dw::tin::PlyMeshWriter w(path, nv, nf, {"grid"});
  for (int y = 0; y <= k; ++y)
    for (int x = 0; x <= k; ++x) w.vertex(x, y, 0.5 * x);
  for (int y = 0; y < k; ++y)
    for (int x = 0; x < k; ++x) {
      const dw::index_t a = dw::index_t(y * (k + 1) + x), b = a + 1, c = a + dw::index_t(k + 1), d = c + 1;
      w.face(a, b, d);
      w.face(a, d, c);
    }
  if (before_close) before_close();
  w.close();
}

/// n synthetic records through Writer (LasWriter or LazWriter); before_close runs after the last.
template <typename Writer>
void writeTile(const std::string& path, std::uint64_t n, const std::function<void()>& before_close = {},
               bool close = true) {
  dw::las::LidarGenOptions o;
  o.num_points = n;
  Writer w(path, dw::las::syntheticHeader(o));
  dw::las::generateLidar(o, [&](const dw::las::LasRecord& r) { w.write(r); });
  if (before_close) before_close();
  if (close) w.close();
}

struct Case {
  const char* name;
  const char* file;
  std::function<void(const std::string&)> write_big;  ///< well beyond the 64 KB cap
};

std::vector<Case> writers() {
  return {
      {"graph", "out.graph", [](const std::string& p) { dw::saveGraph(graphOf(4000), p); }},
      {"ply", "out.ply", [](const std::string& p) { writeGridPly(p, 120); }},
      {"las", "out.las", [](const std::string& p) { writeTile<dw::las::LasWriter>(p, 20000); }},
      {"laz", "out.laz", [](const std::string& p) { writeTile<dw::las::LazWriter>(p, 60000); }},
      {"las_destructor", "out.las",
       [](const std::string& p) { writeTile<dw::las::LasWriter>(p, 20000, {}, false); }},
  };
}

TEST(FailedWrites, FileTooLargeLeavesEveryWritersOldTarget) {
  for (const Case& c : writers()) {
    SCOPED_TRACE(c.name);
    const std::string dir = dw_test::freshFolder(std::string("efbig_") + c.name);
    const std::string target = dir + "/" + c.file;
    const auto old = dw_test::writeOldTarget(target);
    const auto child = dw_test::runInChild(64 * 1024, [&] { c.write_big(target); });
    dw_test::expectFailedWriteLeftTarget(child, target, old, "File too large", {c.file});
    // Uncapped, the same write replaces the target: the cap is what failed it.
    const auto ok = dw_test::runInChild(0, [&] { c.write_big(target); });
    EXPECT_EQ(ok.exit_code, 0) << ok.message;
    EXPECT_GT(readBytes(target).size(), 64u * 1024u);
    EXPECT_EQ(dw_test::otherFiles(dir, {c.file}), std::vector<std::string>());
  }
}

TEST(FailedWrites, ReadOnlyFolderLeavesEveryWritersOldTarget) {
  if (dw_test::runningAsRoot()) GTEST_SKIP() << "running as root: a read-only folder does not stop root";
  for (const Case& c : writers()) {
    SCOPED_TRACE(c.name);
    const std::string dir = dw_test::freshFolder(std::string("readonly_") + c.name);
    const std::string target = dir + "/" + c.file;
    const auto old = dw_test::writeOldTarget(target);
    dw_test::ReadOnlyFolder lock(dir);
    const auto child = dw_test::runInChild(0, [&] { c.write_big(target); });
    dw_test::expectFailedWriteLeftTarget(child, target, old, "Permission denied", {c.file});
  }
}

TEST(FailedWrites, WriterKilledBeforeItsCloseLeavesTheOldTarget) {
  using Hook = std::function<void()>;
  const std::vector<std::pair<const char*, std::function<void(const std::string&, const Hook&)>>> cases = {
      {"out.ply", [](const std::string& p, const Hook& h) { writeGridPly(p, 120, h); }},
      {"out.las", [](const std::string& p, const Hook& h) { writeTile<dw::las::LasWriter>(p, 20000, h); }},
      {"out.laz", [](const std::string& p, const Hook& h) { writeTile<dw::las::LazWriter>(p, 60000, h); }},
  };
  for (const auto& [file, write] : cases) {
    SCOPED_TRACE(file);
    const std::string dir = dw_test::freshFolder(std::string("killed_") + file);
    const std::string target = dir + "/" + file;
    const auto old = dw_test::writeOldTarget(target);
    ASSERT_TRUE(dw_test::killChild([&](const Hook& ready) { write(target, ready); }, true));
    EXPECT_EQ(readBytes(target), old);
    // At most the dead writer's temporary remains (safe_output_file.h: removed by a later write).
    EXPECT_LE(dw_test::temporariesOf(dir, file).size(), 1u);
    EXPECT_EQ(dw_test::otherFiles(dir, {file}), dw_test::temporariesOf(dir, file));
  }
}

TEST(FailedWrites, GraphSaveKilledMidWriteLeavesAWholeFile) {
  const std::string dir = dw_test::freshFolder("killed_graph");
  const std::string target = dir + "/out.graph";
  dw::saveGraph(graphOf(500), target);
  const auto old = readBytes(target);
  const dw::DelaunayGraph& big = graphOf(10000);
  const auto fresh = dw::serializeGraph(big);  // ~3 MB
  // Kills spread from before the save to past its end (its time measured here): whenever one lands,
  // the file is whole, the old one or the new one.
  const auto t0 = std::chrono::steady_clock::now();
  dw::saveGraph(big, dir + "/timing.graph");
  const double save_us =
      std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
  std::remove((dir + "/timing.graph").c_str());
  int saw_old = 0, saw_new = 0;
  for (int step = 0; step <= 24; ++step) {
    const unsigned delay_us = unsigned(save_us * step / 20);
    dw::saveGraph(graphOf(500), target);
    ASSERT_TRUE(dw_test::killChild(
        [&](const std::function<void()>& ready) {
          ready();
          dw::saveGraph(big, target);
        },
        false, delay_us));
    const auto now = readBytes(target);
    const bool is_old = now == old;
    const bool is_new =
        now.size() == fresh.size() && std::equal(now.begin(), now.end(), fresh.begin(),
                                                 [](char a, std::uint8_t b) { return std::uint8_t(a) == b; });
    saw_old += is_old;
    saw_new += is_new;
    ASSERT_TRUE(is_old || is_new) << "after a kill " << delay_us << " us in, the graph file is neither "
                                  << "the old nor the new one (" << now.size() << " bytes)";
    ASSERT_NO_THROW(dw::loadGraph(target));
    EXPECT_LE(dw_test::temporariesOf(dir, "out.graph").size(), 1u);
    for (const auto& stray : dw_test::temporariesOf(dir, "out.graph"))
      std::remove((dir + "/" + stray).c_str());
  }
  std::printf("save %.0f us; kills that left the old graph: %d, the new one: %d\n", save_us, saw_old,
              saw_new);
}

TEST(FailedWrites, LasWriterUnwoundByAnExceptionLeavesTheOldTarget) {
  const std::string dir = dw_test::freshFolder("las_unwind");
  for (const char* file : {"out.las", "out.laz"}) {
    const std::string target = dir + "/" + file;
    const auto old = dw_test::writeOldTarget(target);
    const auto fail = [] { throw dw::Error("the caller's own failure"); };
    if (std::string(file) == "out.las")
      EXPECT_THROW(writeTile<dw::las::LasWriter>(target, 1000, fail), dw::Error);
    else
      EXPECT_THROW(writeTile<dw::las::LazWriter>(target, 1000, fail), dw::Error);
    EXPECT_EQ(readBytes(target), old) << file;
  }
  EXPECT_EQ(dw_test::otherFiles(dir, {"out.las", "out.laz"}), std::vector<std::string>());
  // A writer that goes out of scope normally still finishes its file (as before: the destructor closes).
  writeTile<dw::las::LasWriter>(dir + "/out.las", 1000, {}, false);
  EXPECT_EQ(dw::las::LasReader(dir + "/out.las").header().point_count, 1000u);
}

}  // namespace
