// dw::readPointsXyz (PLY / KITTI .bin) on foreign, truncated and lying files: dw::Error, never a crash
// and never an allocation sized by an untrusted header.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>

#include "pcl_delaunay_walk/core/graph/types.h"
#include "pcl_delaunay_walk/core/util/point_file.h"
#include "robustness_util.h"

using namespace dw;

namespace {

std::string writeTemp(const std::string& name, const std::string& content) {
  const std::string path =
      std::string(DW_BINARY_DIR) + "/robustness_" + std::to_string(::getpid()) + "_" + name;
  std::ofstream(path, std::ios::binary) << content;
  return path;
}

std::string asciiHeader(const std::string& count, const std::string& extra = "") {
  return "ply\nformat ascii 1.0\nelement vertex " + count +
         "\nproperty float x\nproperty float y\nproperty float z\n" + extra + "end_header\n";
}

void expectError(const std::string& name, const std::string& content) {
  const std::string path = writeTemp(name, content);
  EXPECT_THROW(readPointsXyz(path), Error) << name;
  std::remove(path.c_str());
}

}  // namespace

TEST(PointFileBadInput, ValidFilesStillRead) {
  const std::string path = writeTemp("ok.ply", asciiHeader("2") + "1 2 3\n4 5 6\n");
  EXPECT_EQ(readPointsXyz(path), (std::vector<double>{1, 2, 3, 4, 5, 6}));
  std::remove(path.c_str());
}

TEST(PointFileBadInput, ForeignAndBrokenFiles) {
  EXPECT_THROW(readPointsXyz(std::string(DW_BINARY_DIR) + "/robustness_missing.ply"), Error);
  expectError("empty.ply", "");
  expectError("foreign.ply", "# .PCD v0.7\nFIELDS x y z\n");
  expectError("no_format.ply", "ply\nelement vertex 1\nproperty float x\nend_header\n1\n");
  expectError("big_endian.ply",
              "ply\nformat binary_big_endian 1.0\nelement vertex 1\nproperty float x\n"
              "property float y\nproperty float z\nend_header\n123456789012");
  expectError("no_z.ply",
              "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
              "end_header\n1 2\n");
  expectError("list_in_vertex.ply", asciiHeader("1", "property list uchar int idx\n") + "1 2 3 0\n");
  expectError("unknown_type.ply", asciiHeader("1", "property quaternion w\n") + "1 2 3 4\n");
  expectError("truncated_ascii.ply", asciiHeader("3") + "1 2 3\n4 5\n");
  expectError("garbage_ascii.ply", asciiHeader("1") + "1 two 3\n");
  expectError("truncated_binary.ply",
              "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\n"
              "property float y\nproperty float z\nend_header\n" +
                  std::string(13, '\0'));
  expectError("int_xyz_binary.ply",
              "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty int x\n"
              "property int y\nproperty int z\nend_header\n" +
                  std::string(12, '\0'));
  expectError("kitti.bin", std::string(17, '\0'));
}

TEST(PointFileBadInput, HugeVertexCountIsRejectedBeforeAllocation) {
  // BUG (src/core/point_file.cpp, readPointsXyz): the vertex count of the header is used for
  // xyz.reserve(count * 3) before a single vertex is read, so a 100-byte file claiming 2^40 vertices
  // asks for 24 TiB: std::length_error / std::bad_alloc (not dw::Error), or an ASan abort.
  for (const char* count : {"1099511627776", "18446744073709551615", "-1", "6148914691236517206"}) {
    const std::string path = writeTemp("huge_count.ply", asciiHeader(count) + "1 2 3\n");
    dw_robust::AllocationProbe probe;
    try {
      readPointsXyz(path);
      ADD_FAILURE() << "count " << count << ": a 1-vertex file claiming more was accepted";
    } catch (const Error&) {
    } catch (const std::exception& e) {
      ADD_FAILURE() << "count " << count << ": threw " << typeid(e).name() << " (" << e.what()
                    << "), not dw::Error";
    }
    EXPECT_LE(probe.largest(), std::size_t(1) << 20)
        << "count " << count << ": allocation sized by the header";
    std::remove(path.c_str());
  }
}
