/// \file laz_writer.h
/// \brief Writer of LASzip-compressed LAS (LAZ) files, point formats 0-3 (pointwise chunks, LASzip v2
/// items) and 6-8 (layered chunks, v3 items), with optional zero-filled extra bytes: the same
/// interface as LasWriter. Records are buffered one chunk at a time, so memory stays a chunk's.
/// Chunks are fixed (every chunk but the last holds chunk_size points, LASzip's default) or variable
/// (the caller ends each chunk with endChunk(); the chunk table then stores every chunk's count, as
/// LASzip's variable chunking does). laz-perf (LASzip compiled to WASM) decodes both
/// (test/core/las/laz_perf_check.js).
/// As LasWriter, it writes a temporary that close() renames over `path` (dw::SafeOutputFile).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/las/las_format.h"
#include "pcl_delaunay_walk/core/util/safe_output_file.h"

namespace dw {
namespace las {

namespace laz {
class ChunkEncoder;
}

/// How a LazWriter cuts the points into chunks.
enum class LazChunking {
  kFixed,    ///< chunk_size points per chunk (the last may hold fewer)
  kVariable  ///< a chunk ends at endChunk(), or when it reaches chunk_size points
};

class LazWriter {
 public:
  /// Starts `path` (as a temporary beside it). `header` gives version, point format, scale and offset;
  /// counts and bounds are filled in by close(). `chunk_size` points per chunk (LASzip's default 50000);
  /// with variable chunking the most points one chunk may hold (the buffer's size, 1 to 2^24).
  LazWriter(const std::string& path, const LasHeader& header, unsigned extra_bytes = 0,
            std::uint32_t chunk_size = 50000, LazChunking chunking = LazChunking::kFixed);
  /// As ~LasWriter: closes unless an exception is unwinding or a write failed (then `path` is left as
  /// it was).
  ~LazWriter();
  LazWriter(const LazWriter&) = delete;
  LazWriter& operator=(const LazWriter&) = delete;

  void write(const LasRecord& r);
  /// Variable chunking: ends the current chunk after the last record written (nothing happens when it
  /// is empty). Throws LasError with fixed chunking, whose chunk boundaries the format fixes.
  void endChunk();
  /// Number of chunks written so far (the one being buffered not counted).
  std::size_t chunksWritten() const { return chunk_bytes_.size(); }
  /// Writes the last chunk, the chunk table and the final header, then renames the file over `path`;
  /// throws LasError naming the file and the reason on I/O failure (then `path` is untouched).
  void close();

 private:
  void flushChunk();
  void writeHeader();
  void put(const void* p, std::size_t n);
  std::string path_;
  SafeOutputFile out_;
  int uncaught_at_start_ = 0;  ///< std::uncaught_exceptions() when constructed
  bool closed_ = false;
  LasHeader h_;
  unsigned extra_;
  std::uint32_t chunk_size_;
  LazChunking chunking_;
  std::vector<std::uint8_t> vlr_;
  std::unique_ptr<laz::ChunkEncoder> encoder_;
  std::vector<std::uint8_t> records_, chunk_;
  std::size_t buffered_ = 0;
  std::vector<std::uint64_t> chunk_bytes_, chunk_counts_;
  LasTally tally_;
};

}  // namespace las
}  // namespace dw
