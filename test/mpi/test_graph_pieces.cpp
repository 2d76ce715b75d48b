// The distributed graph builder's input and output without MPI: the xyz input set reads any range of
// one or several files exactly as the single-process reader does; graph pieces round-trip; and, run by
// test/mpi_run after a real dw_graph_mpi run (DW_MPI_GRAPH_MANIFEST), the pieces of the manifest
// assemble into exactly dw::buildDelaunayGraph's graph of the input.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/graph/graph_io.h"
#include "pcl_delaunay_walk/core/util/point_file.h"
#include "pcl_delaunay_walk/mpi/distributed_graph.h"
#include "pcl_delaunay_walk/mpi/point_input_set.h"

namespace {

using dw::mpi::PointInputSet;

const std::string kDir = std::string(DW_BINARY_DIR) + "/test_graph_pieces";

std::vector<std::string> splitList(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ';');)
    if (!item.empty()) out.push_back(item);
  return out;
}

TEST(GraphPieces, ManifestPiecesEqualSingleProcessGraph) {
  const char* m = std::getenv("DW_MPI_GRAPH_MANIFEST");
  const char* in = std::getenv("DW_MPI_GRAPH_INPUT");
  if (!m || !in)
    GTEST_SKIP() << "DW_MPI_GRAPH_MANIFEST/INPUT not set (runs from test/mpi_run after an mpirun)";
  const dw::DelaunayGraph got = dw::mpi::readGraphPieces(m);
  // The reference reads the files with the core's own reader, not the input set.
  std::vector<double> xyz;
  for (const std::string& f : splitList(in)) {
    const std::vector<double> part = dw::readPointsXyz(f);
    xyz.insert(xyz.end(), part.begin(), part.end());
  }
  const dw::DelaunayGraph ref = dw::buildDelaunayGraph(dw::PointView::fromDouble(xyz.data(), xyz.size() / 3));
  EXPECT_EQ(got.numVertices(), ref.numVertices());
  EXPECT_EQ(got.numDirectedEdges(), ref.numDirectedEdges());
  EXPECT_EQ(got.dimension, ref.dimension);
  EXPECT_TRUE(dw::serializeGraph(got) == dw::serializeGraph(ref))
      << "the pieces are not the single-process graph";
}

/// Writes `pts` as a binary little-endian PLY with an extra property before x and a list element after.
void writeBinaryPly(const std::string& path, const std::vector<double>& pts, bool as_double) {
  std::ofstream f(path, std::ios::binary);
  const std::size_t n = pts.size() / 3;
  const char* t = as_double ? "double" : "float";
  f << "ply\nformat binary_little_endian 1.0\ncomment test\nelement vertex " << n
    << "\nproperty uchar flag\nproperty " << t << " x\nproperty " << t << " y\nproperty " << t
    << " z\nproperty float confidence\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n";
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned char flag = 7;
    f.write(reinterpret_cast<const char*>(&flag), 1);
    for (int a = 0; a < 3; ++a) {
      if (as_double) {
        f.write(reinterpret_cast<const char*>(&pts[3 * i + a]), 8);
      } else {
        const float v = static_cast<float>(pts[3 * i + a]);
        f.write(reinterpret_cast<const char*>(&v), 4);
      }
    }
    const float c = 0.5f;
    f.write(reinterpret_cast<const char*>(&c), 4);
  }
}

std::vector<double> randomPoints(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-50, 50);
  std::vector<double> p(3 * n);
  for (double& v : p) v = u(rng);
  return p;
}

TEST(PointInputSet, RangesOfFileSetsMatchTheCoreReader) {
  std::filesystem::create_directories(kDir);
  const std::string a = kDir + "/a.ply", b = kDir + "/b.ply", c = kDir + "/c.ply";
  writeBinaryPly(a, randomPoints(1000, 1), false);
  writeBinaryPly(b, randomPoints(37, 2), true);
  {  // ascii
    std::ofstream f(c);
    const std::vector<double> p = randomPoints(300, 3);
    f << "ply\nformat ascii 1.0\nelement vertex 300\nproperty float x\nproperty float y\nproperty float "
         "z\nend_header\n";
    for (std::size_t i = 0; i < 300; ++i) f << p[3 * i] << " " << p[3 * i + 1] << " " << p[3 * i + 2] << "\n";
  }
  std::vector<double> want;
  for (const std::string& f : {a, b, c}) {
    const std::vector<double> part = dw::readPointsXyz(f);
    want.insert(want.end(), part.begin(), part.end());
  }
  const PointInputSet set({a, b, c});
  ASSERT_EQ(set.size(), 1337u);
  EXPECT_EQ(set.read(0, set.size()), want);
  for (int P : {2, 3, 5}) {
    std::vector<double> joined;
    for (int r = 0; r < P; ++r) {
      const std::vector<double> s = set.read(1337ull * r / P, 1337ull * (r + 1) / P);
      joined.insert(joined.end(), s.begin(), s.end());
    }
    EXPECT_EQ(joined, want) << P << " ranks";
  }
  EXPECT_EQ(set.read(999, 1040), std::vector<double>(want.begin() + 3 * 999, want.begin() + 3 * 1040));
  EXPECT_TRUE(set.read(5, 5).empty());
}

TEST(PointInputSet, UniformIsReproducibleAndBadFilesThrow) {
  const PointInputSet u = PointInputSet::uniform(1000, 4);
  const std::vector<double> all = u.read(0, 1000), tail = u.read(600, 1000);
  EXPECT_EQ(std::vector<double>(all.begin() + 1800, all.end()), tail);
  for (double v : all) EXPECT_TRUE(v >= 0.0 && v < 1.0);
  EXPECT_NE(PointInputSet::uniform(1000, 5).read(0, 1), u.read(0, 1));

  std::filesystem::create_directories(kDir);
  EXPECT_THROW(PointInputSet({kDir + "/missing.ply"}), dw::Error);
  EXPECT_THROW(PointInputSet(std::vector<std::string>{}), dw::Error);
  std::ofstream(kDir + "/junk.ply") << "not a ply";
  EXPECT_THROW(PointInputSet({kDir + "/junk.ply"}), dw::Error);
  {  // a header that promises more vertices than the file holds
    std::ofstream f(kDir + "/short.ply", std::ios::binary);
    f << "ply\nformat binary_little_endian 1.0\nelement vertex 100\nproperty float x\nproperty float y\n"
         "property float z\nend_header\n";
    const float v[3] = {1, 2, 3};
    f.write(reinterpret_cast<const char*>(v), sizeof v);
  }
  EXPECT_THROW(PointInputSet({kDir + "/short.ply"}), dw::Error);
  std::ofstream(kDir + "/odd.bin", std::ios::binary) << "12345";
  EXPECT_THROW(PointInputSet({kDir + "/odd.bin"}), dw::Error);
  {  // vertex x as an integer type is refused
    std::ofstream f(kDir + "/int.ply");
    f << "ply\nformat ascii 1.0\nelement vertex 1\nproperty int x\nproperty float y\nproperty float "
         "z\nend_header\n1 2 3\n";
  }
  EXPECT_THROW(PointInputSet({kDir + "/int.ply"}), dw::Error);
}

/// Splits a single-process graph into `parts` blocks of consecutive vertices, as ranks hold them.
std::vector<dw::mpi::RankGraph> splitGraph(const dw::DelaunayGraph& g, int parts) {
  std::vector<dw::mpi::RankGraph> out(parts);
  const std::size_t n = g.numVertices();
  for (int r = 0; r < parts; ++r) {
    dw::mpi::RankGraph& p = out[r];
    p.rank = r;
    p.size = parts;
    p.input_points = g.numInputPoints();
    p.vertices = n;
    p.origin = g.origin;
    const std::size_t first = n * r / parts, last = n * (r + 1) / parts;
    p.first_vertex = static_cast<dw::index_t>(first);
    p.originals_offsets.push_back(0);
    for (std::size_t v = first; v < last; ++v) {
      p.points.push_back(g.points[v]);
      for (dw::index_t k = g.originals_offsets[v]; k < g.originals_offsets[v + 1]; ++k)
        p.originals.push_back(g.originals[k]);
      p.originals_offsets.push_back(static_cast<dw::index_t>(p.originals.size()));
      for (dw::index_t e = g.offsets[v]; e < g.offsets[v + 1]; ++e)
        if (g.edges[e].j > v) p.edges.emplace_back(static_cast<dw::index_t>(v), g.edges[e].j);
    }
  }
  return out;
}

TEST(GraphPieces, PiecesRoundTripAndDefectsAreErrors) {
  std::filesystem::create_directories(kDir);
  std::vector<double> xyz = randomPoints(3000, 9);
  xyz.insert(xyz.end(), xyz.begin(), xyz.begin() + 30);  // duplicates
  xyz.push_back(std::nan(""));                           // a skipped point
  xyz.push_back(0);
  xyz.push_back(0);
  const dw::DelaunayGraph g = dw::buildDelaunayGraph(dw::PointView::fromDouble(xyz.data(), xyz.size() / 3));
  const std::vector<dw::mpi::RankGraph> parts = splitGraph(g, 3);
  std::ostringstream js;
  js << "{\n  \"pieces\": [\n";
  for (int r = 0; r < 3; ++r) {
    dw::mpi::writeGraphPiece(kDir + "/g.rank" + std::to_string(r) + ".dwgp", parts[r]);
    js << "    {\"file\": \"g.rank" << r << ".dwgp\"}" << (r < 2 ? "," : "") << "\n";
  }
  js << "  ],\n  \"complete\": true\n}\n";
  std::ofstream(kDir + "/g.manifest.json") << js.str();
  const dw::DelaunayGraph back = dw::mpi::readGraphPieces(kDir + "/g.manifest.json");
  EXPECT_TRUE(dw::serializeGraph(back) == dw::serializeGraph(g));

  // Pieces out of order, truncated, or a manifest that does not claim completeness: errors.
  std::ofstream(kDir + "/swapped.manifest.json") << "{\"pieces\": [{\"file\": \"g.rank1.dwgp\"}, {\"file\": "
                                                    "\"g.rank0.dwgp\"}, {\"file\": \"g.rank2.dwgp\"}],\n"
                                                    "  \"complete\": true}\n";
  EXPECT_THROW(dw::mpi::readGraphPieces(kDir + "/swapped.manifest.json"), dw::Error);
  std::ofstream(kDir + "/partial.manifest.json") << "{\"pieces\": [{\"file\": \"g.rank0.dwgp\"}]}\n";
  EXPECT_THROW(dw::mpi::readGraphPieces(kDir + "/partial.manifest.json"), dw::Error);
  std::filesystem::resize_file(kDir + "/g.rank2.dwgp",
                               std::filesystem::file_size(kDir + "/g.rank2.dwgp") - 5);
  EXPECT_THROW(dw::mpi::readGraphPieces(kDir + "/g.manifest.json"), dw::Error);
  EXPECT_THROW(dw::mpi::readGraphPieces(kDir + "/none.manifest.json"), dw::Error);
  EXPECT_THROW(dw::mpi::writeGraphPiece("/nonexistent-dir/x.dwgp", parts[0]), dw::Error);
}

}  // namespace
