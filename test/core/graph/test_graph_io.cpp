// Graph files: exact round trip; every truncation, byte flip and foreign file is a clean GraphFileError.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <fstream>

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
