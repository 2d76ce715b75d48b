// pcl::io::loadLASFile on lying LAS headers: dw::las::LasError, never another exception or an
// allocation sized by the header.
#include <gtest/gtest.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>

#include "pcl_delaunay_walk/core/las/las_writer.h"
#include "pcl_delaunay_walk/io/las_io.h"

namespace {

std::string tempPath(const std::string& name) {
  return std::string(DW_BINARY_DIR) + "/robustness_pcl_" + std::to_string(::getpid()) + "_" + name;
}

/// A valid LAS 1.4 file (format 0) of three points, as bytes.
std::vector<char> validLas14() {
  const std::string path = tempPath("valid.las");
  dw::las::LasHeader h;
  h.version_minor = 4;
  h.point_format = 0;
  {
    dw::las::LasWriter w(path, h);
    for (int i = 0; i < 3; ++i) {
      dw::las::LasRecord r;
      r.X = 100 * i;
      w.write(r);
    }
    w.close();
  }
  std::ifstream f(path, std::ios::binary);
  std::vector<char> b((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  std::remove(path.c_str());
  return b;
}

}  // namespace

TEST(PclLasBadInput, DirectoryAndLyingCounts) {
  pcl::PointCloud<pcl::PointXYZ> cloud;
  EXPECT_THROW(pcl::io::loadLASFile(DW_BINARY_DIR, cloud), dw::Error) << "a directory";
  auto bytes = validLas14();
  ASSERT_GE(bytes.size(), 375u);
  const std::uint32_t zero = 0;
  std::memcpy(bytes.data() + 107, &zero, 4);  // legacy count 0: the 64-bit count rules
  // 2^40 points in a 400-byte file, and 2^62 x 20 bytes, which overflows 64 bits (bug B6 of
  // docs/robustness.md, fixed in parseHeader): both must be a LasError.
  for (std::uint64_t count : {std::uint64_t(1) << 40, std::uint64_t(1) << 62}) {
    std::memcpy(bytes.data() + 247, &count, 8);
    const std::string path = tempPath("lying.las");
    std::ofstream(path, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
    try {
      pcl::io::loadLASFile(path, cloud);
      ADD_FAILURE() << "count " << count << " accepted";
    } catch (const dw::Error&) {
    } catch (const std::exception& e) {
      ADD_FAILURE() << "count " << count << ": " << typeid(e).name() << " (" << e.what()
                    << "), not dw::Error";
    }
    std::remove(path.c_str());
  }
}
