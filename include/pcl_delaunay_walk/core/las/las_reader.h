/// \file las_reader.h
/// \brief Streaming reader of LAS 1.0-1.4 files, point formats 0-10 (extra bytes skipped), and of
/// LASzip-compressed LAZ files of formats 0-3 and 6-8 (decoded chunk by chunk, so memory stays a
/// chunk's records however large the file). Every inconsistency (bad signature, version, sizes,
/// truncation, a corrupt chunk) throws dw::las::LasError with the file name, the chunk and what was
/// wrong.
#pragma once

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/las/las_format.h"

namespace dw {
namespace las {

class LazChunks;
namespace laz {
class ChunkDecoder;
}

class LasReader {
 public:
  /// Opens `path` and validates its header against the file size (LAZ: against the chunk table).
  explicit LasReader(const std::string& path);
  ~LasReader();
  LasReader(const LasReader&) = delete;
  LasReader& operator=(const LasReader&) = delete;

  const LasHeader& header() const { return header_; }
  /// Number of records still to read.
  std::uint64_t remaining() const { return header_.point_count - next_; }
  /// Reads up to `max_records` records into `out` (replacing its content); returns how many (0 at end).
  std::size_t read(std::vector<LasRecord>& out, std::size_t max_records = 1 << 16);
  /// Positions the reader at record `index` (for byte-range readers such as the MPI driver). In a LAZ
  /// file the chunk holding `index` is decoded from its start: readers that split a file should split
  /// it at chunkStarts().
  void seek(std::uint64_t index);
  /// LAZ: the first record of every chunk, ascending, starting with 0 (chunks are decoded whole, so
  /// they are the units in which a LAZ file is best split). LAS: empty (any record is a boundary).
  std::vector<std::uint64_t> chunkStarts() const;

 private:
  std::string path_;
  std::FILE* file_ = nullptr;
  LasHeader header_;
  std::uint64_t next_ = 0;
  std::vector<unsigned char> buffer_;
  // LAZ only: the chunks, a decoder, and the decoded records of chunk `laz_chunk_`.
  std::unique_ptr<LazChunks> laz_;
  std::unique_ptr<laz::ChunkDecoder> laz_decoder_;
  std::vector<unsigned char> laz_compressed_;
  std::size_t laz_chunk_ = ~std::size_t(0);
  std::size_t readLaz(std::vector<LasRecord>& out, std::size_t n);
};

/// Parses and validates a header from the first bytes of a file of `file_size` bytes (exposed for
/// tests and tools). `name` is used in messages. A LAZ header is refused here (its point count cannot
/// be checked against the file size); LasReader reads LAZ files.
LasHeader parseHeader(const unsigned char* bytes, std::size_t available, std::uint64_t file_size,
                      const std::string& name);

/// A whole file as structure-of-arrays, optionally filtered by class: the compact form the TIN app
/// and the PCL loader use (12 bytes of coordinates per point plus what is asked for).
struct LasCloud {
  LasHeader header;
  std::vector<std::int32_t> X, Y, Z;
  std::vector<std::uint8_t> classification;  ///< filled when keep_attributes
  std::vector<std::uint16_t> intensity;      ///< filled when keep_attributes
  std::vector<std::uint8_t> return_number;   ///< filled when keep_attributes
  std::size_t size() const { return X.size(); }
  double x(std::size_t i) const { return X[i] * header.scale[0] + header.offset[0]; }
  double y(std::size_t i) const { return Y[i] * header.scale[1] + header.offset[1]; }
  double z(std::size_t i) const { return Z[i] * header.scale[2] + header.offset[2]; }
};

struct LasReadOptions {
  int classification = -1;       ///< keep only this class (e.g. 2 = ground); -1: all
  unsigned threads = 0;          ///< LAZ: chunks decoded at once (0: all cores); results do not depend on it
  bool keep_attributes = false;  ///< also fill classification, intensity, return_number
  /// Optional progress in [0, 1].
  void (*progress)(double fraction, void* user) = nullptr;
  void* progress_user = nullptr;
};

/// Reads a LAS or LAZ file; LAZ chunks are decoded on options.threads threads, a few chunks per
/// thread at a time.
LasCloud readLasFile(const std::string& path, const LasReadOptions& options = {});

}  // namespace las
}  // namespace dw
