// Graph files: exact round trip; every truncation, byte flip and foreign file is a clean GraphFileError.
#include <gtest/gtest.h>

#include <cstddef>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <memory>
#include <random>

#include "core/brute_force.h"
#include "pcl_delaunay_walk/core/graph/graph_io.h"

using namespace dw;

namespace {

DelaunayGraph smallGraph(std::size_t n = 60) {
  auto xyz = dw_test::uniformCube(n, 21);
  xyz.insert(xyz.end(), {xyz[0], xyz[1], xyz[2]});  // one duplicate
  xyz.insert(xyz.end(), {std::nan(""), 0.0, 0.0});  // one skipped point
  return buildDelaunayGraph(PointView::fromDouble(xyz.data(), xyz.size() / 3));
}

void expectEqual(const DelaunayGraph& a, const DelaunayGraph& b) {
  EXPECT_EQ(a.origin, b.origin);
  EXPECT_EQ(a.dimension, b.dimension);
  ASSERT_EQ(a.points.size(), b.points.size());
  if (!a.points.empty()) {  // memcmp of null pointers is undefined even for 0 bytes
    EXPECT_EQ(0, std::memcmp(a.points.data(), b.points.data(), a.points.size() * sizeof(Vec3f)));
  }
  EXPECT_EQ(a.offsets, b.offsets);
  ASSERT_EQ(a.edges.size(), b.edges.size());
  if (!a.edges.empty()) {
    EXPECT_EQ(0, std::memcmp(a.edges.data(), b.edges.data(), a.edges.size() * sizeof(EdgeRecord)));
  }
  EXPECT_EQ(a.safe_radius2, b.safe_radius2);  // derived on load: must equal the built graph's
  EXPECT_EQ(a.input_to_vertex, b.input_to_vertex);
  EXPECT_EQ(a.originals_offsets, b.originals_offsets);
  EXPECT_EQ(a.originals, b.originals);
}

}  // namespace

TEST(GraphIo, RoundTripInMemoryAndFile) {
  const DelaunayGraph g = smallGraph(500);
  const auto bytes = serializeGraph(g);
  expectEqual(g, deserializeGraph(bytes.data(), bytes.size()));
  const std::string path = std::string(DW_BINARY_DIR) + "/test_graph_io_roundtrip.graph";
  saveGraph(g, path);
  expectEqual(g, loadGraph(path));
  std::remove(path.c_str());
}

TEST(GraphIo, EmptyGraphRoundTrip) {
  const DelaunayGraph g = buildDelaunayGraph(PointView::fromDouble(nullptr, 0));
  const auto bytes = serializeGraph(g);
  expectEqual(g, deserializeGraph(bytes.data(), bytes.size()));
}

TEST(GraphIo, EveryTruncationIsAnError) {
  const auto bytes = serializeGraph(smallGraph());
  for (std::size_t len = 0; len < bytes.size(); ++len)
    EXPECT_THROW(deserializeGraph(bytes.data(), len), GraphFileError) << "length " << len;
  auto longer = bytes;
  longer.push_back(0);
  EXPECT_THROW(deserializeGraph(longer.data(), longer.size()), GraphFileError);
}

TEST(GraphIo, EveryByteFlipIsAnError) {
  const auto bytes = serializeGraph(smallGraph());
  for (std::size_t pos = 0; pos < bytes.size(); ++pos) {
    auto bad = bytes;
    bad[pos] ^= static_cast<std::uint8_t>(1u << (pos % 8));
    EXPECT_THROW(deserializeGraph(bad.data(), bad.size()), GraphFileError) << "flip at " << pos;
  }
}

TEST(GraphIo, VersionOneFilesStillLoad) {
  // Version 1 differs only in its payload checksum (one chain instead of per-block hashes).
  const DelaunayGraph g = smallGraph(500);
  auto v1 = serializeGraph(g);
  const std::uint32_t one = 1;
  std::memcpy(v1.data() + 8, &one, 4);  // the version field follows the 8-byte magic
  resealGraphFile(v1);
  expectEqual(g, deserializeGraph(v1.data(), v1.size()));
  auto flipped = v1;
  flipped[v1.size() / 2] ^= 0x10;
  EXPECT_THROW(deserializeGraph(flipped.data(), flipped.size()), GraphFileError);
  auto other_sum = v1;  // a version-2 checksum under a version-1 header is a mismatch
  const std::uint32_t two = kGraphFileVersion;
  std::memcpy(other_sum.data() + 8, &two, 4);
  resealGraphFile(other_sum);
  std::memcpy(other_sum.data() + 8, &one, 4);
  EXPECT_THROW(deserializeGraph(other_sum.data(), other_sum.size()), GraphFileError);
}

TEST(GraphIo, FlipsInEveryChecksumBlockAreErrors) {
  // Large enough for several 1 MiB checksum blocks, verified on several threads.
  const DelaunayGraph g = smallGraph(40000);
  const auto bytes = serializeGraph(g);
  ASSERT_GT(bytes.size(), std::size_t(3) << 20);
  expectEqual(g, deserializeGraph(bytes.data(), bytes.size()));
  for (std::size_t pos :
       {std::size_t(200), (std::size_t(1) << 20) + 104, (std::size_t(2) << 20) + 7, bytes.size() - 1}) {
    auto bad = bytes;
    bad[pos] ^= 0x01;
    EXPECT_THROW(deserializeGraph(bad.data(), bad.size()), GraphFileError) << "flip at " << pos;
  }
}

TEST(GraphIo, ValidateNamesTheSameFirstErrorOnAnyThreadCount) {
  DelaunayGraph g = smallGraph(120000);
  g.validate(1);
  g.validate(4);
  const std::size_t late = g.numVertices() - 10, early = g.numVertices() / 2;
  g.points[late].x = std::nanf("");
  g.points[early].y = std::nanf("");
  auto message = [&](unsigned threads) -> std::string {
    try {
      g.validate(threads);
    } catch (const Error& e) {
      return e.what();
    }
    return "valid";
  };
  EXPECT_NE(message(1).find("non-finite vertex " + std::to_string(early)), std::string::npos) << message(1);
  for (unsigned threads : {2u, 3u, 4u, 0u}) EXPECT_EQ(message(1), message(threads)) << threads << " threads";
}

TEST(GraphIo, ForeignAndMissingFiles) {
  const std::string path = std::string(DW_BINARY_DIR) + "/test_graph_io_foreign.graph";
  {
    std::ofstream f(path);
    f << "ply\nformat ascii 1.0\nelement vertex 0\nend_header\n";
  }
  EXPECT_THROW(loadGraph(path), GraphFileError);
  std::remove(path.c_str());
  EXPECT_THROW(loadGraph(path + ".does-not-exist"), GraphFileError);
  try {
    loadGraph(path + ".does-not-exist");
  } catch (const GraphFileError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot open"), std::string::npos) << e.what();
  }
}

/// loadGraph parses a mapping of the file: an empty file, a directory and a device are refused with
/// the reason and the path, never mapped or read.
TEST(GraphIo, MappedLoadRefusesEmptyFilesAndNonRegularFiles) {
  const std::string path = std::string(DW_BINARY_DIR) + "/test_graph_io_empty.graph";
  std::ofstream(path).close();
  auto message = [](const std::string& p) {
    try {
      loadGraph(p);
    } catch (const GraphFileError& e) {
      return std::string(e.what());
    }
    return std::string("no exception");
  };
  const std::string empty = message(path);
  EXPECT_NE(empty.find("shorter than its header"), std::string::npos) << empty;
  EXPECT_NE(empty.find(path), std::string::npos) << empty;
  std::remove(path.c_str());
  EXPECT_NE(message(DW_BINARY_DIR).find("not a regular file"), std::string::npos);
  EXPECT_NE(message("/dev/zero").find("not a regular file"), std::string::npos);
}

TEST(GraphIo, HugeClaimedSizesDoNotAllocate) {
  // A header claiming 2^31 vertices on a tiny file must be rejected before any allocation.
  auto bytes = serializeGraph(smallGraph());
  std::uint64_t big = 1ull << 31;
  std::memcpy(bytes.data() + 24, &big, 8);  // num_vertices
  EXPECT_THROW(deserializeGraph(bytes.data(), bytes.size()), GraphFileError);
}

namespace {

std::string mappedTestPath(const std::string& name) {
  return std::string(DW_BINARY_DIR) + "/test_graph_io_mapped_" + name + ".graph";
}

/// Nearest vertex, distance and step count of every query, plus the 8 nearest inputs of each: a
/// walk over a mapped graph must follow the same records as over the built one.
struct Answers {
  std::vector<WalkResult> nearest;
  std::vector<index_t> knn;
  std::vector<float> knn_d2;
};

Answers answers(const DelaunayGraph::ConstPtr& g, const std::vector<Vec3f>& queries) {
  const NeighbourSearch s(g);
  Answers a;
  std::vector<index_t> idx;
  std::vector<float> d2;
  for (const Vec3f& q : queries) {
    a.nearest.push_back(s.nearest(q, StartStrategy::KdAnn));
    s.knn(q, 8, a.nearest.back(), idx, d2);
    a.knn.insert(a.knn.end(), idx.begin(), idx.end());
    a.knn_d2.insert(a.knn_d2.end(), d2.begin(), d2.end());
  }
  return a;
}

void expectSameAnswers(const Answers& a, const Answers& b) {
  ASSERT_EQ(a.nearest.size(), b.nearest.size());
  for (std::size_t i = 0; i < a.nearest.size(); ++i) {
    EXPECT_EQ(a.nearest[i].vertex, b.nearest[i].vertex) << "query " << i;
    EXPECT_EQ(a.nearest[i].dist2, b.nearest[i].dist2) << "query " << i;
    EXPECT_EQ(a.nearest[i].steps, b.nearest[i].steps) << "query " << i;
  }
  EXPECT_EQ(a.knn, b.knn);
  EXPECT_EQ(a.knn_d2, b.knn_d2);
}

std::vector<Vec3f> queriesIn(const DelaunayGraph& g, std::size_t n) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-0.1f, 1.1f);
  std::vector<Vec3f> q(n);
  for (auto& p : q) p = g.toLocal(u(rng), u(rng), u(rng));
  return q;
}

}  // namespace

TEST(GraphIoMapped, MappedLoadViewsTheFileAndAnswersLikeTheBuiltGraph) {
  const auto built = std::make_shared<const DelaunayGraph>(smallGraph(3000));
  const std::string path = mappedTestPath("answers");
  saveGraph(*built, path);
  const auto mapped = std::make_shared<const DelaunayGraph>(loadGraph(path));
  ASSERT_TRUE(mapped->isMapped());
  EXPECT_FALSE(built->isMapped());
  expectEqual(*built, *mapped);
  const auto queries = queriesIn(*built, 500);
  expectSameAnswers(answers(built, queries), answers(mapped, queries));

  const DelaunayGraph copied = loadGraph(path, GraphStorage::Copied);
  EXPECT_FALSE(copied.isMapped());
  expectEqual(*built, copied);
  const DelaunayGraph copy_of_mapped = *mapped;  // a copy owns its records
  EXPECT_FALSE(copy_of_mapped.isMapped());
  expectEqual(*built, copy_of_mapped);
  std::remove(path.c_str());
}

TEST(GraphIoMapped, MappedGraphOutlivesItsPathAndSavesAgain) {
  const auto built = std::make_shared<const DelaunayGraph>(smallGraph(2000));
  const auto queries = queriesIn(*built, 300);
  const Answers expected = answers(built, queries);
  const std::string path = mappedTestPath("outlives"), renamed = mappedTestPath("outlives_renamed");
  saveGraph(*built, path);
  auto removed = std::make_shared<const DelaunayGraph>(loadGraph(path));
  ASSERT_EQ(0, std::rename(path.c_str(), renamed.c_str()));
  auto moved = std::make_shared<const DelaunayGraph>(loadGraph(renamed));
  ASSERT_EQ(0, std::remove(renamed.c_str()));
  ASSERT_TRUE(removed->isMapped() && moved->isMapped());
  expectSameAnswers(expected, answers(removed, queries));
  expectSameAnswers(expected, answers(moved, queries));

  // Saved again, over the path a mapping was made from: the mapping keeps the old file.
  saveGraph(*moved, path);
  const auto again = std::make_shared<const DelaunayGraph>(loadGraph(path));
  saveGraph(*again, path);
  expectEqual(*built, *again);
  expectEqual(*built, *moved);
  expectSameAnswers(expected, answers(again, queries));
  std::remove(path.c_str());
}

TEST(GraphIoMapped, EditsStayInTheProcessAndResizingCopies) {
  const DelaunayGraph built = smallGraph(400);
  const std::string path = mappedTestPath("edits");
  saveGraph(built, path);
  DelaunayGraph g = loadGraph(path);
  ASSERT_TRUE(g.isMapped());
  g.edges[0].m += 1.f;  // copy-on-write: this page becomes the process's own
  EXPECT_TRUE(g.isMapped());
  expectEqual(built, loadGraph(path));  // the file did not change
  g.edges.resize(g.edges.size() + 1);
  EXPECT_FALSE(g.isMapped());
  EXPECT_EQ(g.edges[0].m, built.edges[0].m + 1.f);
  EXPECT_EQ(0, std::memcmp(g.edges.data() + 1, built.edges.data() + 1,
                           (built.edges.size() - 1) * sizeof(EdgeRecord)));
  std::remove(path.c_str());
}

/// A checksummed file whose structure lies is refused on the mapped path as on the copying one, with
/// the file named: the walk never follows an index past the arrays.
TEST(GraphIoMapped, LyingFilesAreRefusedWithThePath) {
  const DelaunayGraph built = smallGraph(300);
  const auto good = serializeGraph(built);
  const std::size_t n = built.numVertices(), header = 104;
  const std::size_t offsets_at = header + n * sizeof(Vec3f),
                    edges_at = offsets_at + (n + 1) * sizeof(index_t);
  struct Lie {
    const char* what;
    std::size_t at;
    index_t value;
  };
  const Lie lies[] = {{"neighbour index = n", edges_at + offsetof(EdgeRecord, j), index_t(n)},
                      {"neighbour index huge", edges_at + 7 * sizeof(EdgeRecord) + offsetof(EdgeRecord, j),
                       index_t(0xFFFFFFF0u)},
                      {"offsets not monotone", offsets_at + 5 * sizeof(index_t), index_t(1u << 30)}};
  const std::string path = mappedTestPath("lies");
  for (const Lie& lie : lies) {
    auto f = good;
    std::memcpy(f.data() + lie.at, &lie.value, sizeof(index_t));
    resealGraphFile(f);
    std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(f.data()), f.size());
    try {
      loadGraph(path);
      ADD_FAILURE() << lie.what << ": accepted";
    } catch (const GraphFileError& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("invalid graph"), std::string::npos) << e.what();
    }
  }
  std::remove(path.c_str());
}
