/// \file test_ply_and_generator.cpp
/// \brief The streaming PLY writer (header, sizes, vertex compaction, misuse errors) and the synthetic
/// LiDAR generator (exact count, determinism, classes, LAS round trip, a certified TIN of its output).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <set>
#include <sstream>
#include <string>

#include "pcl_delaunay_walk/core/las/las_reader.h"
#include "pcl_delaunay_walk/core/las/synthetic_lidar.h"
#include "pcl_delaunay_walk/core/tin/certificate.h"
#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"
#include "pcl_delaunay_walk/core/tin/ply_writer.h"

namespace {

std::string tmp(const std::string& n) {
  return std::string(DW_BINARY_DIR) + "/test_tin_" + std::to_string(::getpid()) + "_" + n;
}

TEST(PlyWriter, HeaderSizesAndCompaction) {
  // Five points, the middle one unused: the writer keeps four vertices and renumbers the faces.
  const double xyz[5][3] = {{0, 0, 1}, {1, 0, 2}, {9, 9, 9}, {1, 1, 3}, {0, 1, 4}};
  const std::vector<dw::index_t> tris = {0, 1, 3, 0, 3, 4};
  const std::string path = tmp("mesh.ply");
  const auto nv =
      dw::tin::writeTinPly(path, 5, [&](std::size_t i, double* p) { std::memcpy(p, xyz[i], sizeof xyz[i]); },
                           tris.data(), tris.size(), {"unit test"});
  EXPECT_EQ(nv, 4u);
  std::ifstream f(path, std::ios::binary);
  std::string all((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  const auto end = all.find("end_header\n");
  ASSERT_NE(end, std::string::npos);
  const std::string header = all.substr(0, end);
  EXPECT_NE(header.find("format binary_little_endian 1.0"), std::string::npos);
  EXPECT_NE(header.find("element vertex 4"), std::string::npos);
  EXPECT_NE(header.find("element face 2"), std::string::npos);
  EXPECT_NE(header.find("comment unit test"), std::string::npos);
  const std::size_t body = all.size() - end - std::strlen("end_header\n");
  EXPECT_EQ(body, 4 * 24 + 2 * 13);
  const char* p = all.data() + end + std::strlen("end_header\n");
  double v3[3];
  std::memcpy(v3, p + 2 * 24, 24);  // third written vertex is input point 3
  EXPECT_EQ(v3[2], 3.0);
  std::int32_t face2[3];
  EXPECT_EQ(static_cast<unsigned char>(p[4 * 24 + 13]), 3u);
  std::memcpy(face2, p + 4 * 24 + 13 + 1, 12);
  EXPECT_EQ(face2[0], 0);
  EXPECT_EQ(face2[1], 2);  // point 3 -> vertex 2
  EXPECT_EQ(face2[2], 3);  // point 4 -> vertex 3
  std::remove(path.c_str());
}

TEST(PlyWriter, FaceCountPatchedAtClose) {
  // 60 vertices: the count is reserved as 3 digits (2 * 60 = 120) and becomes "007" at close.
  const std::string path = tmp("counted.ply");
  {
    dw::tin::PlyMeshWriter w(path, 60, dw::tin::PlyMeshWriter::kFacesCountedAtClose, {"counted"});
    for (int i = 0; i < 60; ++i) w.vertex(i, i % 7, 0.5 * i);
    for (dw::index_t f = 0; f < 7; ++f) w.face(f, f + 1, f + 2);
    w.close();
  }
  std::ifstream f(path, std::ios::binary);
  std::string all((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  const auto end = all.find("end_header\n");
  ASSERT_NE(end, std::string::npos);
  EXPECT_NE(all.substr(0, end).find("element vertex 60\n"), std::string::npos);
  EXPECT_NE(all.substr(0, end).find("element face 007\n"), std::string::npos);
  EXPECT_EQ(all.size(), end + 11 + 60 * 24 + 7 * 13);
  std::int32_t last[3];
  std::memcpy(last, all.data() + all.size() - 12, 12);
  EXPECT_EQ(last[0], 6);
  EXPECT_EQ(last[2], 8);
  // More faces than a triangulation of the vertices can have are refused.
  dw::tin::PlyMeshWriter w(path, 2, dw::tin::PlyMeshWriter::kFacesCountedAtClose);
  w.vertex(0, 0, 0), w.vertex(1, 0, 0);
  for (int i = 0; i < 4; ++i) w.face(0, 1, 0);
  EXPECT_THROW(w.face(0, 1, 0), dw::Error);
  std::remove(path.c_str());
}

TEST(PlyWriter, MisuseAndIoErrors) {
  {
    dw::tin::PlyMeshWriter w(tmp("bad.ply"), 1, 1);
    EXPECT_THROW(w.face(0, 0, 0), dw::Error);  // before the vertices
    w.vertex(0, 0, 0);
    EXPECT_THROW(w.vertex(1, 1, 1), dw::Error);  // beyond the count
    EXPECT_THROW(w.close(), dw::Error);          // face missing
  }
  std::remove(tmp("bad.ply").c_str());
  EXPECT_THROW(dw::tin::PlyMeshWriter("/nonexistent_dir/x.ply", 0, 0), dw::Error);
  const std::vector<dw::index_t> bad = {0, 1, 7};
  EXPECT_THROW(
      dw::tin::writeTinPly(
          tmp("bad2.ply"), 3, [](std::size_t, double* p) { p[0] = p[1] = p[2] = 0; }, bad.data(), bad.size()),
      dw::Error);
  std::remove(tmp("bad2.ply").c_str());
}

std::vector<dw::las::LasRecord> generate(std::uint64_t n, std::uint64_t seed) {
  dw::las::LidarGenOptions o;
  o.num_points = n;
  o.seed = seed;
  std::vector<dw::las::LasRecord> v;
  dw::las::generateLidar(o, [&](const dw::las::LasRecord& r) { v.push_back(r); });
  return v;
}

TEST(SyntheticLidar, ExactCountDeterministicAndPlausible) {
  const auto a = generate(150000, 5), b = generate(150000, 5), c = generate(150000, 6);
  ASSERT_EQ(a.size(), 150000u);
  ASSERT_EQ(b.size(), 150000u);
  bool same = true, differs = false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    same = same && a[i].X == b[i].X && a[i].Y == b[i].Y && a[i].Z == b[i].Z;
    differs = differs || a[i].X != c[i].X || a[i].Z != c[i].Z;
  }
  EXPECT_TRUE(same);
  EXPECT_TRUE(differs);
  std::set<int> classes;
  std::size_t second_returns = 0;
  for (const auto& r : a) {
    classes.insert(r.classification);
    second_returns += r.return_number == 2;
    EXPECT_GE(r.return_number, 1);
    EXPECT_LE(r.return_number, r.number_of_returns);
  }
  EXPECT_EQ(classes, (std::set<int>{2, 5, 6}));  // ground, vegetation, buildings all present
  EXPECT_GT(second_returns, 0u);                 // crowns let pulses through
}

TEST(SyntheticLidar, LasRoundTripAndCertifiedTin) {
  dw::las::LidarGenOptions o;
  o.num_points = 30000;
  const std::string path = tmp("gen.las");
  EXPECT_EQ(dw::las::writeSyntheticLas(path, o), 30000u);
  const auto cloud = dw::las::readLasFile(path);
  ASSERT_EQ(cloud.size(), 30000u);
  EXPECT_EQ(cloud.header.scale[0], 0.01);
  EXPECT_NEAR(cloud.x(0), o.offset_x + cloud.X[0] * 0.01, 1e-9);
  std::vector<double> x(cloud.X.begin(), cloud.X.end()), y(cloud.Y.begin(), cloud.Y.end());
  dw::tin::TinOptions to;
  to.num_threads = 2;
  to.num_strips = 4;
  const auto r = dw::tin::triangulate(x.data(), y.data(), x.size(), to);
  const auto cert = dw::tin::certifyDelaunay(x.data(), y.data(), x.size(), r.triangles, r.num_vertices);
  EXPECT_TRUE(cert.ok) << cert.message;
  std::remove(path.c_str());
}

}  // namespace
