/// \file las_writer.h
/// \brief Writer of uncompressed LAS 1.0-1.4 (formats 0-10, optional zero-filled extra bytes per record):
/// used by the synthetic LiDAR generator and by the tests that cover every format. The file is written
/// to a temporary and renamed over `path` by close() (dw::SafeOutputFile), so an existing `path` stays
/// as it was until the new file is complete.
#pragma once

#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/las/las_format.h"
#include "pcl_delaunay_walk/core/util/safe_output_file.h"

namespace dw {
namespace las {

class LasWriter {
 public:
  /// Starts `path` (as a temporary beside it). `header` gives version, point format, scale and offset;
  /// counts and bounds are filled in by close(). `extra_bytes` are appended (zero) to every record.
  LasWriter(const std::string& path, const LasHeader& header, unsigned extra_bytes = 0);
  /// Closes (and so replaces `path`) unless an exception is unwinding through the writer's scope or a
  /// write failed: then the temporary is removed and `path` is left as it was. An error of that close
  /// cannot be reported; call close() to see it.
  ~LasWriter();
  LasWriter(const LasWriter&) = delete;
  LasWriter& operator=(const LasWriter&) = delete;

  void write(const LasRecord& r);
  /// Finalises the header (counts, bounds) and renames the finished file over `path`; throws
  /// dw::las::LasError naming the file and the reason on an I/O failure (then `path` is untouched).
  void close();

 private:
  void writeHeader();
  std::string path_;
  SafeOutputFile out_;
  int uncaught_at_start_ = 0;  ///< std::uncaught_exceptions() when constructed
  bool closed_ = false;
  LasHeader h_;
  unsigned extra_;
  LasTally tally_;
  std::vector<unsigned char> rec_;
};

}  // namespace las
}  // namespace dw
