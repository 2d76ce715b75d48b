// libFuzzer target: dw::readPointsXyz (PLY ascii / binary little endian, KITTI .bin) on arbitrary
// bytes. The reader takes a path, so each input is written to one per-process temporary file.
// Contract: dw::Error or a whole number of xyz triples; never another exception, a crash, or an
// allocation sized by an untrusted header (run with -malloc_limit_mb to catch the latter).
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "fuzz_common.h"
#include "pcl_delaunay_walk/core/graph/types.h"
#include "pcl_delaunay_walk/core/util/point_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  // First byte: which reader (by extension); the rest is the file.
  const bool kitti = data[0] & 1;
  static const std::string base = "/tmp/dw_fuzz_point_file_" + std::to_string(::getpid());
  const std::string path = base + (kitti ? ".bin" : ".ply");
  {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    DW_FUZZ_CHECK(f != nullptr, "cannot write the temporary file");
    std::fwrite(data + 1, 1, size - 1, f);
    std::fclose(f);
  }
  try {
    const std::vector<double> xyz = dw::readPointsXyz(path);
    DW_FUZZ_CHECK(xyz.size() % 3 == 0, "not a whole number of points");
    DW_FUZZ_CHECK(xyz.size() / 3 <= size, "more points than bytes");
  } catch (const dw::Error&) {
  }
  std::remove(path.c_str());
  return 0;
}
