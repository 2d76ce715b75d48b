// Re-reads the per-rank PLY pieces that a dw_tin_mpi run listed in its manifest and checks, independently
// of the app, that together they are exactly the single-process TIN of the input: every triangle once,
// every vertex at its input coordinates. Run by test/mpi_run with DW_MPI_MANIFEST set; skipped otherwise.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>

#include "pcl_delaunay_walk/core/las/las_reader.h"
#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"
#include "pcl_delaunay_walk/mpi/distributed_tin.h"
#include "pcl_delaunay_walk/mpi/las_input_set.h"

namespace {

using dw::index_t;
using Tri = std::array<index_t, 3>;

Tri canonical(index_t a, index_t b, index_t c) {
  if (b < a && b < c) return {b, c, a};
  if (c < a && c < b) return {c, a, b};
  return {a, b, c};
}

/// Values of every `"key": "..."` (strings) in a small JSON text, in order.
std::vector<std::string> stringValues(const std::string& js, const std::string& key) {
  std::vector<std::string> out;
  const std::string pat = "\"" + key + "\": \"";
  for (std::size_t at = js.find(pat); at != std::string::npos; at = js.find(pat, at + 1)) {
    const std::size_t b = at + pat.size(), e = js.find('"', b);
    out.push_back(js.substr(b, e - b));
  }
  return out;
}

/// The strings of a `"key": ["a", "b"]` list in a small JSON text.
std::vector<std::string> listValues(const std::string& js, const std::string& key) {
  std::vector<std::string> out;
  const std::string pat = "\"" + key + "\": [";
  const std::size_t at = js.find(pat);
  if (at == std::string::npos) return out;
  const std::size_t end = js.find(']', at);
  for (std::size_t b = js.find('"', at + pat.size()); b < end; b = js.find('"', b + 1)) {
    const std::size_t e = js.find('"', b + 1);
    out.push_back(js.substr(b + 1, e - b - 1));
    b = e;
  }
  return out;
}

struct Piece {
  std::vector<index_t> gid;
  std::vector<std::array<double, 3>> xyz;
  std::vector<Tri> faces;  // as gids
};

Piece readPiece(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw dw::Error(path + ": cannot open");
  std::string line;
  std::size_t nv = 0, nf = 0;
  bool binary = false;
  std::vector<std::string> vprops;
  while (std::getline(in, line) && line != "end_header") {
    std::istringstream ls(line);
    std::string w, a, b;
    ls >> w >> a >> b;
    if (w == "format") binary = a == "binary_little_endian";
    if (w == "element" && a == "vertex") nv = std::stoul(b);
    if (w == "element" && a == "face") nf = std::stoul(b);
    if (w == "property" && a != "list") vprops.push_back(a + " " + b);
  }
  if (!binary || vprops != std::vector<std::string>{"double x", "double y", "double z", "uint gid"})
    throw dw::Error(path + ": unexpected PLY layout");
  Piece p;
  p.gid.resize(nv);
  p.xyz.resize(nv);
  for (std::size_t i = 0; i < nv; ++i) {
    in.read(reinterpret_cast<char*>(p.xyz[i].data()), 24);
    in.read(reinterpret_cast<char*>(&p.gid[i]), 4);
  }
  for (std::size_t k = 0; k < nf; ++k) {
    unsigned char cnt = 0;
    std::int32_t v[3];
    in.read(reinterpret_cast<char*>(&cnt), 1);
    in.read(reinterpret_cast<char*>(v), 12);
    if (cnt != 3) throw dw::Error(path + ": a face is not a triangle");
    for (int c = 0; c < 3; ++c)
      if (v[c] < 0 || std::size_t(v[c]) >= nv) throw dw::Error(path + ": face index out of range");
    p.faces.push_back(canonical(p.gid[v[0]], p.gid[v[1]], p.gid[v[2]]));
  }
  if (!in) throw dw::Error(path + ": truncated");
  return p;
}

TEST(Pieces, ManifestPiecesEqualSingleProcessTin) {
  const char* env = std::getenv("DW_MPI_MANIFEST");
  if (!env) GTEST_SKIP() << "DW_MPI_MANIFEST not set (this test runs from test/mpi_run after an mpirun)";
  const std::string manifest = env;
  std::ifstream mf(manifest);
  ASSERT_TRUE(mf.good()) << manifest;
  const std::string js((std::istreambuf_iterator<char>(mf)), std::istreambuf_iterator<char>());
  ASSERT_NE(js.find("\"complete\": true"), std::string::npos);
  const std::vector<std::string> inputs = listValues(js, "inputs");
  const std::vector<std::string> files = stringValues(js, "file");
  ASSERT_FALSE(inputs.empty());
  ASSERT_FALSE(files.empty());
  const std::string dir = manifest.substr(0, manifest.find_last_of('/') + 1);

  // The input's points in the shared frame (las_input_set.h), and in world coordinates.
  const dw::mpi::LasInputSet input(inputs);
  const dw::mpi::Frame& fr = input.frame();
  std::vector<double> x, y;
  std::vector<std::array<double, 3>> world;
  input.forEach(0, input.size(), [&](const dw::las::LasRecord&, double px, double py, double pz) {
    x.push_back(px);
    y.push_back(py);
    world.push_back({px * fr.scale[0] + fr.offset[0], py * fr.scale[1] + fr.offset[1], pz});
  });
  std::vector<Tri> got;
  for (const std::string& f : files) {
    const Piece p = readPiece(dir + f);
    for (std::size_t i = 0; i < p.gid.size(); ++i) {
      ASSERT_LT(p.gid[i], world.size());
      EXPECT_EQ(p.xyz[i], world[p.gid[i]]);
    }
    got.insert(got.end(), p.faces.begin(), p.faces.end());
  }
  std::sort(got.begin(), got.end());
  EXPECT_EQ(std::adjacent_find(got.begin(), got.end()), got.end()) << "a triangle is in two pieces";

  const dw::tin::TinResult ref = dw::tin::triangulate(std::move(x), std::move(y));
  std::vector<Tri> want;
  for (std::size_t t = 0; t < ref.numTriangles(); ++t)
    want.push_back(canonical(ref.triangles[3 * t], ref.triangles[3 * t + 1], ref.triangles[3 * t + 2]));
  std::sort(want.begin(), want.end());
  ASSERT_EQ(got.size(), want.size());
  EXPECT_TRUE(got == want);
}

TEST(Pieces, WritePieceRoundTrips) {
  dw::mpi::RankTin t;
  t.frame.scale[0] = t.frame.scale[1] = 0.01;
  t.frame.offset[0] = 500000;
  t.frame.offset[1] = 6e6;
  t.coords.push(4, 100, 200, 3.5);
  t.coords.push(9, 300, 200, 4.5);
  t.coords.push(12, 100, 400, 5.5);
  t.emitted.triangles = {9, 12, 4};
  const std::string path = std::string(DW_BINARY_DIR) + "/test_mpi_piece.ply";
  EXPECT_EQ(dw::mpi::writePiece(path, t), 3u);
  const Piece p = readPiece(path);
  EXPECT_EQ(p.gid, (std::vector<index_t>{4, 9, 12}));
  EXPECT_EQ(p.xyz[1][0], 300 * 0.01 + 500000);
  EXPECT_EQ(p.xyz[2][2], 5.5);
  ASSERT_EQ(p.faces.size(), 1u);
  EXPECT_EQ(p.faces[0], (Tri{4, 9, 12}));
  EXPECT_THROW(dw::mpi::writePiece("/nonexistent-dir/x.ply", t), dw::Error);
}

}  // namespace
