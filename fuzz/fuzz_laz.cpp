// libFuzzer target: the LAZ decoder on arbitrary bytes, two ways. (1) The first bytes choose a point
// format (0-3, 6-8) and extra bytes, the rest is one chunk fed straight to the chunk decoder, which
// must return or throw std::runtime_error. (2) The bytes as a whole file through LasReader and
// readLasFile: dw::Error or records, never a crash, a hang, or an allocation sized by an untrusted
// field beyond a few chunks (run with -malloc_limit_mb). Seeds: fuzz/corpus/laz (small LazWriter files).
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/las/laz_codec.h"
#include "fuzz_common.h"
#include "pcl_delaunay_walk/core/las/las_reader.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dw::las;
  if (size >= 3) {
    static const unsigned formats[7] = {0, 1, 2, 3, 6, 7, 8};
    const unsigned format = formats[data[0] % 7], extra = data[1] % 4, count = 1 + data[2] % 64;
    const unsigned len = unsigned(baseRecordSize(format)) + extra;
    const auto vlr = laz::defaultLaszipVlr(format, extra, 50000);
    std::vector<std::uint8_t> out(std::size_t(count) * len);
    try {
      laz::makeChunkDecoder(vlr, len)->decode(data + 3, size - 3, count, out.data());
    } catch (const std::runtime_error&) {
    }
  }
  static const std::string path = "/tmp/dw_fuzz_laz_" + std::to_string(::getpid()) + ".laz";
  {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    DW_FUZZ_CHECK(f != nullptr, "cannot write the temporary file");
    std::fwrite(data, 1, size, f);
    std::fclose(f);
  }
  try {
    LasReader reader(path);
    std::vector<LasRecord> records;
    std::uint64_t total = 0;
    while (reader.read(records, 4096) > 0) total += records.size();
    DW_FUZZ_CHECK(total == reader.header().point_count, "streamed a different number of points");
    LasReadOptions o;
    o.threads = 2;
    DW_FUZZ_CHECK(readLasFile(path, o).size() == total, "the parallel reader disagrees");
  } catch (const dw::Error&) {
  }
  return 0;
}
