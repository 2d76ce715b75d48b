// libFuzzer target: the LAS reader on arbitrary bytes, through both entry points: parseHeader on the
// bytes in memory (with the true size and with a lying file size) and readLasFile / LasReader on a
// per-process temporary file. Contract: dw::las::LasError (a dw::Error), or records whose count
// matches the header and never exceeds what the file can hold; no other exception, no crash, and no
// allocation sized by an untrusted header field (run with -malloc_limit_mb).
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "fuzz_common.h"
#include "pcl_delaunay_walk/core/las/las_reader.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dw::las;
  try {
    const LasHeader h = parseHeader(data, size, size, "fuzz");
    // An empty file may point past its end (nothing is read there); a non-empty one may not.
    DW_FUZZ_CHECK(h.point_count == 0 || h.offset_to_points <= size,
                  "accepted a point offset past the end of the file");
    const std::size_t base = baseRecordSize(h.point_format);
    DW_FUZZ_CHECK(base != 0 && h.record_length >= base, "accepted a record shorter than its format");
    DW_FUZZ_CHECK(h.point_count <= (size - h.offset_to_points) / h.record_length,
                  "accepted more points than the file holds");
  } catch (const dw::Error&) {
  }
  try {  // a header that claims a huge file while only a few bytes are here
    parseHeader(data, size, std::uint64_t(1) << 50, "fuzz-lying-size");
  } catch (const dw::Error&) {
  }

  static const std::string path = "/tmp/dw_fuzz_las_" + std::to_string(::getpid()) + ".las";
  {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    DW_FUZZ_CHECK(f != nullptr, "cannot write the temporary file");
    std::fwrite(data, 1, size, f);
    std::fclose(f);
  }
  try {
    LasReadOptions options;
    options.keep_attributes = size % 2 == 0;
    const LasCloud cloud = readLasFile(path, options);
    DW_FUZZ_CHECK(cloud.size() <= cloud.header.point_count, "more records than the header counts");
    DW_FUZZ_CHECK(cloud.size() * std::size_t(cloud.header.record_length) <= size, "more records than bytes");
    if (options.keep_attributes)
      DW_FUZZ_CHECK(cloud.classification.size() == cloud.size(), "attribute arrays differ");
  } catch (const dw::Error&) {
  }
  try {
    LasReader reader(path);
    std::vector<LasRecord> records;
    std::uint64_t total = 0;
    while (std::size_t got = reader.read(records, 7)) {
      DW_FUZZ_CHECK(got == records.size() && got <= 7, "read() count");
      total += got;
      DW_FUZZ_CHECK(total <= reader.header().point_count, "read past the point count");
    }
    if (reader.header().point_count > 0) reader.seek(reader.header().point_count - 1);
  } catch (const dw::Error&) {
  }
  std::remove(path.c_str());
  return 0;
}
