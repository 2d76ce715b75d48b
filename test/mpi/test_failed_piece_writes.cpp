// The MPI layer's files under a failed write, without MPI: a graph piece, a TIN piece and a manifest
// capped by RLIMIT_FSIZE, in a read-only folder, and killed before their rename leave the old file
// byte for byte, name the file and the reason, and leave no partial file.
#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

#include "core/util/write_failure_harness.h"
#include "mpi/manifest_file.h"
#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/core/util/safe_output_file.h"
#include "pcl_delaunay_walk/mpi/distributed_graph.h"
#include "pcl_delaunay_walk/mpi/distributed_tin.h"

namespace {

/// Rank 0 of a gathered-fallback build: its piece is the whole graph of n random points.
dw::mpi::RankGraph graphPart(std::size_t n) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<double> xyz(3 * n);
  for (double& v : xyz) v = u(rng);
  dw::mpi::RankGraph part;
  dw::BuildOptions o;
  o.num_threads = 1;
  part.fallback = dw::buildDelaunayGraph(dw::PointView::fromDouble(xyz.data(), n), o);
  part.gathered_fallback = true;
  part.input_points = part.vertices = n;
  return part;
}

/// A piece of a k x k grid of vertices with two triangles per cell.
dw::mpi::RankTin tinPart(int k) {
  dw::mpi::RankTin t;
  t.frame.scale[0] = t.frame.scale[1] = 0.01;
  for (int y = 0; y < k; ++y)
    for (int x = 0; x < k; ++x) t.coords.push(dw::index_t(y * k + x), 100 * x, 100 * y, 0.5 * x);
  for (int y = 0; y + 1 < k; ++y)
    for (int x = 0; x + 1 < k; ++x) {
      const dw::index_t a = dw::index_t(y * k + x), b = a + 1, c = a + dw::index_t(k), d = c + 1;
      t.emitted.triangles.insert(t.emitted.triangles.end(), {a, b, d, a, d, c});
    }
  return t;
}

std::string manifestText(std::size_t pieces) {
  std::string js = "{\n  \"pieces\": [\n";
  for (std::size_t r = 0; r < pieces; ++r)
    js += "    {\"file\": \"p.rank" + std::to_string(r) + ".dwgp\"}" + (r + 1 < pieces ? ",\n" : "\n");
  return js + "  ],\n  \"complete\": true\n}\n";
}

struct Case {
  const char* file;
  std::function<void(const std::string&)> write;  ///< well beyond the 16 KB cap
};

std::vector<Case> cases() {
  static const dw::mpi::RankGraph graph = graphPart(2000);
  static const dw::mpi::RankTin tin = tinPart(60);
  return {
      {"p.rank0.dwgp", [](const std::string& p) { dw::mpi::writeGraphPiece(p, graph); }},
      {"p.rank0.ply", [](const std::string& p) { dw::mpi::writePiece(p, tin); }},
      {"p.manifest.json",
       [](const std::string& p) { dw::mpi::detail::writeFileAtomically(p, manifestText(2000)); }},
  };
}

TEST(FailedPieceWrites, FileTooLargeLeavesTheOldPieceOrManifest) {
  for (const Case& c : cases()) {
    SCOPED_TRACE(c.file);
    const std::string dir = dw_test::freshFolder(std::string("mpi_efbig_") + c.file);
    const std::string target = dir + "/" + c.file;
    const auto old = dw_test::writeOldTarget(target);
    const auto child = dw_test::runInChild(16 * 1024, [&] { c.write(target); });
    dw_test::expectFailedWriteLeftTarget(child, target, old, "File too large", {c.file});
    const auto ok = dw_test::runInChild(0, [&] { c.write(target); });
    EXPECT_EQ(ok.exit_code, 0) << ok.message;
    EXPECT_GT(dw_test::readBytes(target).size(), 16u * 1024u);
  }
}

TEST(FailedPieceWrites, ReadOnlyFolderLeavesTheOldPieceOrManifest) {
  if (dw_test::runningAsRoot()) GTEST_SKIP() << "running as root: a read-only folder does not stop root";
  for (const Case& c : cases()) {
    SCOPED_TRACE(c.file);
    const std::string dir = dw_test::freshFolder(std::string("mpi_readonly_") + c.file);
    const std::string target = dir + "/" + c.file;
    const auto old = dw_test::writeOldTarget(target);
    dw_test::ReadOnlyFolder lock(dir);
    const auto child = dw_test::runInChild(0, [&] { c.write(target); });
    dw_test::expectFailedWriteLeftTarget(child, target, old, "Permission denied", {c.file});
  }
}

TEST(FailedPieceWrites, KilledManifestWriterLeavesNoManifestThatClaimsCompleteness) {
  // The manifest is the file readers trust: a writer killed before its rename leaves the old one.
  const std::string dir = dw_test::freshFolder("mpi_killed");
  const std::string target = dir + "/p.manifest.json";
  const auto old = dw_test::writeOldTarget(target);
  ASSERT_TRUE(dw_test::killChild(
      [&](const std::function<void()>& ready) {
        dw::SafeOutputFile f(target);
        const std::string text = manifestText(100);
        f.write(text.data(), text.size());
        ready();
        f.commit();
      },
      true));
  EXPECT_EQ(dw_test::readBytes(target), old);
  EXPECT_LE(dw_test::temporariesOf(dir, "p.manifest.json").size(), 1u);
}

}  // namespace
