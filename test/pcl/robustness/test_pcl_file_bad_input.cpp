// Hostile PCD and PLY files on the path our apps take (dw_graph, dw_icp, dw_tin, dw_viewer read them
// with PCL's pcl::io readers, then hand the cloud to pcl::search::DelaunayWalk). The readers are PCL's,
// not ours, so the contract checked here is the pipeline's: the reader refuses the file (negative
// return or an exception), or it returns a cloud that is consistent and that the walk searches
// exactly (equal to pcl::search::KdTree). Each load runs in a child process (a gtest death test
// expecting a clean exit), so a crash inside PCL is reported as this test's failure with the case
// named, instead of taking the whole test binary down. Some files break PCL 1.13 itself; they are
// pinned as expected failures until the apps guard against them (docs/robustness.md, B10-B14).
#include <gtest/gtest.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/search/delaunay_walk.h"

using Cloud = pcl::PointCloud<pcl::PointXYZ>;

namespace {

/// What PCL 1.13 does with a file. Anything but Handles is a PCL defect listed in docs/robustness.md
/// (B10-B14); when a PCL upgrade fixes one, its expectation fails: then mark the case Handles.
enum class Pcl {
  Handles,          ///< the contract holds: the child exits cleanly
  Crashes,          ///< PCL crashes (SEGV, assertion) in every build: the child must die
  DiesInstrumented  ///< fine in Release, but UB or an allocation sized by the header, fatal under ASan/UBSan
};

struct HostileFile {
  std::string name;
  std::string bytes;
  Pcl pcl = Pcl::Handles;
};

#ifdef __SANITIZE_ADDRESS__
constexpr bool kInstrumented = true;  // scripts/sanitize.sh builds ASan and UBSan together
#else
constexpr bool kInstrumented = false;
#endif

std::string pcdHeader(const std::string& fields, const std::string& size, const std::string& type,
                      const std::string& count, const std::string& width, const std::string& height,
                      const std::string& points, const std::string& data) {
  return "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS " + fields + "\nSIZE " + size +
         "\nTYPE " + type + "\nCOUNT " + count + "\nWIDTH " + width + "\nHEIGHT " + height +
         "\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + points + "\nDATA " + data + "\n";
}

std::string xyzHeader(const std::string& width, const std::string& points, const std::string& data) {
  return pcdHeader("x y z", "4 4 4", "F F F", "1 1 1", width, "1", points, data);
}

std::string floats(const std::vector<float>& v) {
  return std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(float));
}

std::string u32(std::uint32_t v) {
  return std::string(reinterpret_cast<const char*>(&v), 4);
}

std::vector<HostileFile> hostilePcdFiles() {
  const std::string six = floats({0.f, 0.f, 0.f, 1.f, 2.f, 3.f});
  return {
      {"empty", "", Pcl::Crashes},  // B10: SEGV at address 0 in PCDReader::read
      // B13: zero points; fromPCLPointCloud2 takes &cloud[0] of the empty cloud (UB, benign in Release).
      {"header_without_data_line", "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n",
       Pcl::DiesInstrumented},
      {"ascii_fewer_lines_than_points", xyzHeader("5", "5", "ascii") + "0 0 0\n1 1 1\n"},
      {"ascii_garbage_numbers", xyzHeader("2", "2", "ascii") + "0 0 zero\n1e999 -- 1\n"},
      {"ascii_nan_and_inf", xyzHeader("3", "3", "ascii") + "nan 0 0\n0 inf 0\n1 2 3\n"},
      {"binary_truncated", xyzHeader("1000", "1000", "binary") + six},
      // B14: PCL allocates what the header claims (48 GiB): std::bad_alloc in Release, ASan's OOM report.
      {"binary_huge_point_count", xyzHeader("4294967295", "4294967295", "binary") + six,
       Pcl::DiesInstrumented},
      // B11: WIDTH x HEIGHT wraps in 32 bits and disagrees with POINTS; fromPCLPointCloud2 then copies
      // 2^32 rows: past the cloud's buffer (SEGV under the sanitizers), or for minutes (Release).
      {"binary_width_height_overflow",
       pcdHeader("x y z", "4 4 4", "F F F", "1 1 1", "4294967295", "4294967295", "1", "binary") + six,
       Pcl::Crashes},
      {"negative_counts", pcdHeader("x y z", "4 4 4", "F F F", "1 1 1", "-1", "-1", "-1", "binary") + six},
      {"zero_size_and_count", pcdHeader("x y z", "0 0 0", "F F F", "0 0 0", "2", "1", "2", "binary") + six},
      {"field_lists_of_different_lengths",
       pcdHeader("x y z", "4 4", "F", "1 1 1 1", "2", "1", "2", "binary") + six},
      {"no_xyz_fields", pcdHeader("intensity", "4", "F", "1", "2", "1", "2", "ascii") + "1\n2\n"},
      {"compressed_sizes_lie",
       xyzHeader("2", "2", "binary_compressed") + u32(0x7fffffff) + u32(0xffffffff) + six},
      {"compressed_truncated", xyzHeader("2", "2", "binary_compressed") + u32(24) + u32(24) + "\x01\x02"},
      {"compressed_garbage_stream",
       xyzHeader("2", "2", "binary_compressed") + u32(24) + u32(24) + std::string(24, '\xff')},
      {"unknown_data_kind", xyzHeader("2", "2", "base64") + six},
  };
}

std::vector<HostileFile> hostilePlyFiles() {
  const std::string head = "ply\nformat binary_little_endian 1.0\n";
  const std::string xyz = "property float x\nproperty float y\nproperty float z\nend_header\n";
  return {
      {"empty", ""},
      {"magic_only", "ply\n"},
      {"ascii_fewer_vertices", "ply\nformat ascii 1.0\nelement vertex 4\n" + xyz + "0 0 0\n1 1 1\n"},
      {"ascii_garbage", "ply\nformat ascii 1.0\nelement vertex 2\n" + xyz + "a b c\n1 2\n"},
      {"binary_truncated", head + "element vertex 100\n" + xyz + floats({1.f, 2.f, 3.f})},
      // B12: the 64-bit count is truncated; PLYReader then asserts (abort) on the first vertex.
      {"binary_huge_vertex_count", head + "element vertex 1099511627776\n" + xyz + floats({1.f, 2.f, 3.f}),
       Pcl::Crashes},
      // B14 again: -1 read as 2^32-1 vertices, allocated before reading.
      {"negative_vertex_count", head + "element vertex -1\n" + xyz + floats({1.f, 2.f, 3.f}),
       Pcl::DiesInstrumented},
      {"face_list_count_huge", head + "element vertex 3\n" +
                                   "property float x\nproperty float y\nproperty float z\n" +
                                   "element face 1\nproperty list uchar int vertex_indices\nend_header\n" +
                                   floats({0, 0, 0, 1, 0, 0, 0, 1, 0}) + "\xff" + u32(0)},
      {"unknown_format",
       "ply\nformat binary_middle_endian 1.0\nelement vertex 1\n" + xyz + floats({1, 2, 3})},
      {"no_end_header", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n1\n"},
  };
}

std::string writeFile(const std::string& dir, const std::string& name, const std::string& bytes) {
  const std::string path = dir + "/" + name;
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}

/// The pipeline's contract for one file; exits 0 when it holds, 1 with a message otherwise.
[[noreturn]] void loadAndSearch(const std::string& path, bool pcd) {
  alarm(10);  // a hang is a failure too (SIGALRM ends the child); every file here is under 200 bytes
  Cloud::Ptr cloud(new Cloud);
  int rc = -1;
  try {
    rc = pcd ? pcl::io::loadPCDFile(path, *cloud) : pcl::io::loadPLYFile(path, *cloud);
  } catch (const std::exception&) {
    // A refusal the apps report as an error (pcl::IOException, or std::bad_alloc where PCL sizes an
    // allocation by the header): no crash, no cloud.
    std::exit(0);
  }
  if (rc < 0) std::exit(0);
  if (cloud->size() != std::size_t(cloud->width) * cloud->height) {
    std::fprintf(stderr, "accepted, but %zu points != width %u x height %u\n", cloud->size(), cloud->width,
                 cloud->height);
    std::exit(1);
  }
  pcl::search::DelaunayWalk<pcl::PointXYZ> walk;
  pcl::search::KdTree<pcl::PointXYZ> kd;
  try {
    walk.setInputCloud(cloud);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "accepted cloud of %zu points not searchable: %s\n", cloud->size(), e.what());
    std::exit(1);
  }
  kd.setInputCloud(cloud);
  pcl::Indices wi, ki;
  std::vector<float> wd, kdd;
  for (const pcl::PointXYZ q : {pcl::PointXYZ(0, 0, 0), pcl::PointXYZ(1, 2, 3), pcl::PointXYZ(-5, 7, 0.5f)}) {
    const int nw = walk.nearestKSearch(q, 3, wi, wd);
    const int nk = kd.nearestKSearch(q, 3, ki, kdd);
    if (nw != nk || wd != kdd) {
      std::fprintf(stderr, "walk found %d neighbours, KdTree %d (or distances differ)\n", nw, nk);
      std::exit(1);
    }
  }
  std::exit(0);
}

void checkAll(const std::vector<HostileFile>& files, bool pcd) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  const std::string dir = ::testing::TempDir();
  for (const HostileFile& f : files) {
    const std::string path = writeFile(dir, "dw_hostile_" + f.name + (pcd ? ".pcd" : ".ply"), f.bytes);
    if (f.pcl == Pcl::Crashes || (f.pcl == Pcl::DiesInstrumented && kInstrumented))
      EXPECT_EXIT(
          loadAndSearch(path, pcd), [](int status) { return !testing::ExitedWithCode(0)(status); }, "")
          << f.name << ": PCL no longer fails here; mark the case Pcl::Handles";
    else
      EXPECT_EXIT(loadAndSearch(path, pcd), ::testing::ExitedWithCode(0), "") << f.name;
    std::remove(path.c_str());
  }
}

}  // namespace

TEST(PclFileBadInput, HostilePcdFilesAreRefusedOrSearchedExactly) {
  checkAll(hostilePcdFiles(), true);
}

TEST(PclFileBadInput, HostilePlyFilesAreRefusedOrSearchedExactly) {
  checkAll(hostilePlyFiles(), false);
}
