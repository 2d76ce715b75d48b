// dw::checkPointFileHeader: the headers that crash PCL 1.13's readers (docs/robustness.md B10-B14) are
// refused with a clear error; real files pass.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <string>

#include "core/util/file_header_check.h"
#include "pcl_delaunay_walk/core/graph/types.h"

namespace {

std::string write(const std::string& name, const std::string& bytes) {
  const std::string path = ::testing::TempDir() + "/dw_hdr_" + name;
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}

void expectRefused(const std::string& name, const std::string& bytes, const std::string& why) {
  const std::string path = write(name, bytes);
  try {
    dw::checkPointFileHeader(path);
    ADD_FAILURE() << name << " was accepted";
  } catch (const dw::Error& e) {
    EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << name << ": " << e.what();
  }
  std::remove(path.c_str());
}

const std::string kPcdHead = "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n";

}  // namespace

TEST(FileHeaderCheck, RefusesTheHeadersThatBreakPclReaders) {
  expectRefused("empty.pcd", "", "empty");  // B10
  expectRefused(
      "wrap.pcd",
      kPcdHead + "WIDTH 4294967295\nHEIGHT 4294967295\nPOINTS 1\nDATA binary\n" + std::string(12, '\0'),
      "WIDTH x HEIGHT");  // B11
  expectRefused("huge.ply",
                "ply\nformat binary_little_endian 1.0\nelement vertex 1099511627776\n"
                "property float x\nproperty float y\nproperty float z\nend_header\n" +
                    std::string(12, '\0'),
                "vertex count");                                                                       // B12
  expectRefused("nopoints.pcd", kPcdHead + "WIDTH 0\nHEIGHT 1\nPOINTS 0\nDATA ascii\n", "no points");  // B13
  expectRefused(
      "claims.pcd",
      kPcdHead + "WIDTH 100000000\nHEIGHT 1\nPOINTS 100000000\nDATA binary\n" + std::string(24, '\0'),
      "truncated");  // B14
  expectRefused("negative.ply", "ply\nformat ascii 1.0\nelement vertex -1\nproperty float x\nend_header\n1\n",
                "non-negative");  // B14
  expectRefused("nodata.pcd", kPcdHead + "WIDTH 1\nHEIGHT 1\nPOINTS 1\n", "truncated");
  expectRefused("mismatch.pcd", kPcdHead + "WIDTH 2\nHEIGHT 1\nPOINTS 3\nDATA ascii\n1 2 3\n", "disagrees");
  expectRefused("magic.ply", "plx\nformat ascii 1.0\nelement vertex 1\nend_header\n1\n", "magic");
  expectRefused("short.ply",
                "ply\nformat binary_little_endian 1.0\nelement vertex 10\nproperty double x\n"
                "end_header\n" +
                    std::string(40, '\0'),
                "truncated");
  expectRefused("missing.pcd", std::string(), "empty");
}

TEST(FileHeaderCheck, AcceptsRealFiles) {
  for (const char* f : {"pcl_bun0.pcd", "fastgicp_251370668.pcd", "bun000.ply", "teapot_points.ply",
                        "dragon_vrip_res3.ply"}) {
    const dw::PointFileHeader h = dw::checkPointFileHeader(std::string(DW_TEST_DATA_DIR) + "/" + f);
    EXPECT_GT(h.points, 100u) << f;
  }
  const std::string ok =
      write("ok.pcd", kPcdHead + "WIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA ascii\n1 2 3\n4 5 6\n");
  EXPECT_EQ(dw::checkPointFileHeader(ok).points, 2u);
  std::remove(ok.c_str());
  EXPECT_THROW(dw::checkPointFileHeader("/nonexistent/file.pcd"), dw::Error);
}
