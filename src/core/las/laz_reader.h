/// \file laz_reader.h
/// \brief A LAZ file's chunks: the LASzip VLR, the chunk table (checked against the header's point
/// count and the file's size before anything is allocated from it) and decoding of one chunk into
/// raw LAS records. Chunks are read with pread, so any number of threads decode chunks of one file
/// at once, each with its own ChunkDecoder and buffers.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/las/laz_codec.h"
#include "pcl_delaunay_walk/core/las/las_format.h"

namespace dw {
namespace las {

class LazChunks {
 public:
  /// `fd` stays owned by the caller. Throws LasError naming `path` on every inconsistency.
  LazChunks(int fd, const std::string& path, const LasHeader& header, std::uint64_t file_size);

  std::size_t size() const { return first_.size() - 1; }
  std::uint64_t firstPoint(std::size_t c) const { return first_[c]; }
  std::uint64_t points(std::size_t c) const { return first_[c + 1] - first_[c]; }
  /// The chunk holding point `index` (< point count).
  std::size_t chunkOf(std::uint64_t index) const;
  std::unique_ptr<laz::ChunkDecoder> makeDecoder() const;
  /// Decodes chunk `c` into `records` (points(c) * record_length bytes); `compressed` is scratch.
  void decode(std::size_t c, laz::ChunkDecoder& decoder, std::vector<std::uint8_t>& compressed,
              std::vector<std::uint8_t>& records) const;
  const laz::LaszipVlr& vlr() const { return vlr_; }

 private:
  void readVlrs(const LasHeader& h, std::uint64_t file_size);
  void readChunkTable(const LasHeader& h, std::uint64_t file_size);
  void readExact(std::uint64_t offset, std::size_t n, std::uint8_t* out, const char* what) const;

  int fd_;
  std::string path_;
  unsigned record_length_;
  laz::LaszipVlr vlr_;
  std::vector<std::uint64_t> first_;   ///< first point of each chunk, plus the total
  std::vector<std::uint64_t> offset_;  ///< byte offset of each chunk, plus the end of the last
};

}  // namespace las
}  // namespace dw
