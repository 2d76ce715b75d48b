/// \file las_writer.h
/// \brief Writer of uncompressed LAS 1.0-1.4 (formats 0-10, optional zero-filled extra bytes per record):
/// used by the synthetic LiDAR generator and by the tests that cover every format.
#pragma once

#include <cstdio>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/las/las_format.h"

namespace dw {
namespace las {

class LasWriter {
 public:
  /// Creates `path`. `header` gives version, point format, scale and offset; counts and bounds are
  /// filled in by close(). `extra_bytes` are appended (zero) to every record.
  LasWriter(const std::string& path, const LasHeader& header, unsigned extra_bytes = 0);
  ~LasWriter();
  LasWriter(const LasWriter&) = delete;
  LasWriter& operator=(const LasWriter&) = delete;

  void write(const LasRecord& r);
  /// Finalises the header (counts, bounds); throws dw::las::LasError on an I/O failure.
  void close();

 private:
  void writeHeader();
  std::string path_;
  std::FILE* file_ = nullptr;
  LasHeader h_;
  unsigned extra_;
  std::uint64_t by_return_[15] = {0};
  bool any_ = false;
  std::int32_t lo_[3] = {0, 0, 0}, hi_[3] = {0, 0, 0};
  std::vector<unsigned char> rec_;
};

}  // namespace las
}  // namespace dw
