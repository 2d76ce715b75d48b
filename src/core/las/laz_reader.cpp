/// \file laz_reader.cpp
/// \brief Locating and validating a LAZ file's chunks, and decoding one chunk.
#include "core/las/laz_reader.h"

#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <stdexcept>

#include "core/las/laz_items.h"

namespace dw {
namespace las {

using laz::loadLe;

namespace {
/// Chunks are decoded whole; LASzip writes 50000 points per chunk. The cap keeps a lying table from
/// asking for more memory than a few chunks per thread.
constexpr std::uint64_t kMaxChunkPoints = std::uint64_t(1) << 24;
}  // namespace

LazChunks::LazChunks(int fd, const std::string& path, const LasHeader& header, std::uint64_t file_size)
    : fd_(fd), path_(path), record_length_(header.record_length) {
  readVlrs(header, file_size);
  try {
    laz::validateItems(vlr_, header.point_format, header.record_length);
  } catch (const std::runtime_error& e) {
    throw LasError(path_ + ": " + e.what());
  }
  readChunkTable(header, file_size);
}

void LazChunks::readExact(std::uint64_t offset, std::size_t n, std::uint8_t* out, const char* what) const {
  std::size_t done = 0;
  while (done < n) {
    const ssize_t got = ::pread(fd_, out + done, n - done, off_t(offset + done));
    if (got <= 0) throw LasError(path_ + ": cannot read " + what + " (file truncated?)");
    done += std::size_t(got);
  }
}

void LazChunks::readVlrs(const LasHeader& h, std::uint64_t file_size) {
  std::uint64_t at = h.header_size;
  for (std::uint32_t i = 0; i < h.num_vlrs; ++i) {
    if (at + 54 > h.offset_to_points || at + 54 > file_size)
      throw LasError(path_ + ": VLR " + std::to_string(i) + " runs past the point data offset");
    std::uint8_t head[54];
    readExact(at, 54, head, "a VLR header");
    const std::uint16_t record_id = loadLe<std::uint16_t>(head + 18);
    const std::uint16_t length = loadLe<std::uint16_t>(head + 20);
    if (at + 54 + length > h.offset_to_points)
      throw LasError(path_ + ": VLR " + std::to_string(i) + " says it has " + std::to_string(length) +
                     " bytes, which run past the point data offset " + std::to_string(h.offset_to_points));
    if (std::strncmp(reinterpret_cast<const char*>(head + 2), "laszip encoded", 16) == 0 &&
        record_id == laz::kLaszipRecordId) {
      std::vector<std::uint8_t> body(length);
      readExact(at + 54, length, body.data(), "the LASzip VLR");
      try {
        vlr_ = laz::parseLaszipVlr(body.data(), body.size());
      } catch (const std::runtime_error& e) {
        throw LasError(path_ + ": " + e.what());
      }
      return;
    }
    at += 54 + length;
  }
  throw LasError(path_ + ": LAZ file (compressed point format) without a LASzip VLR");
}

void LazChunks::readChunkTable(const LasHeader& h, std::uint64_t file_size) {
  const std::uint64_t data = h.offset_to_points;
  if (vlr_.compressor == laz::kPointwise) {  // one stream, no table
    if (file_size <= data) throw LasError(path_ + ": no point data");
    first_ = {0, h.point_count};
    offset_ = {data, file_size};
    return;
  }
  if (data + 8 > file_size) throw LasError(path_ + ": file ends before the chunk table offset");
  std::uint8_t b8[8];
  readExact(data, 8, b8, "the chunk table offset");
  std::int64_t table = loadLe<std::int64_t>(b8);
  if (table == -1) {  // written by a streaming writer: the offset is the file's last 8 bytes
    readExact(file_size - 8, 8, b8, "the chunk table offset");
    table = loadLe<std::int64_t>(b8);
  }
  if (table < std::int64_t(data + 8) || std::uint64_t(table) + 8 > file_size)
    throw LasError(path_ + ": corrupt chunk table: offset " + std::to_string(table) +
                   " lies outside the file (" + std::to_string(file_size) + " bytes, points from " +
                   std::to_string(data + 8) + ")");
  readExact(std::uint64_t(table), 8, b8, "the chunk table");
  const std::uint32_t version = loadLe<std::uint32_t>(b8), count = loadLe<std::uint32_t>(b8 + 4);
  if (version != 0) throw LasError(path_ + ": unknown chunk table version " + std::to_string(version));
  // Every chunk holds at least one point and one byte, so neither bound allocates beyond the file.
  if (count > h.point_count || count > std::uint64_t(table) - data)
    throw LasError(path_ + ": corrupt chunk table: " + std::to_string(count) + " chunks for " +
                   std::to_string(h.point_count) + " points");
  const std::uint64_t body =
      std::min<std::uint64_t>(file_size - std::uint64_t(table) - 8, 16 * std::uint64_t(count) + 64);
  std::vector<std::uint8_t> bytes(body);
  readExact(std::uint64_t(table) + 8, bytes.size(), bytes.data(), "the chunk table");
  laz::ChunkTable t;
  try {
    laz::decodeChunkTable(bytes.data(), bytes.size(), count, vlr_.variableChunks(), t);
  } catch (const std::runtime_error& e) {
    throw LasError(path_ + ": corrupt chunk table: " + e.what());
  }
  first_.assign(1, 0);
  offset_.assign(1, data + 8);
  for (std::uint32_t c = 0; c < count; ++c) {
    const std::uint64_t n = vlr_.variableChunks()
                                ? t.counts[c]
                                : std::min<std::uint64_t>(vlr_.chunk_size, h.point_count - first_[c]);
    if (offset_[c] + t.bytes[c] > std::uint64_t(table))
      throw LasError(path_ + ": corrupt chunk table: chunk " + std::to_string(c) + " of " +
                     std::to_string(t.bytes[c]) + " bytes runs past the table at " + std::to_string(table));
    if (n > kMaxChunkPoints)
      throw LasError(path_ + ": corrupt chunk table: chunk " + std::to_string(c) + " claims " +
                     std::to_string(n) + " points (at most " + std::to_string(kMaxChunkPoints) +
                     " are accepted)");
    if (n == 0 || first_[c] + n > h.point_count)
      throw LasError(path_ + ": point count mismatch: chunk " + std::to_string(c) + " would hold points " +
                     std::to_string(first_[c]) + " + " + std::to_string(n) + ", the header announces " +
                     std::to_string(h.point_count));
    first_.push_back(first_[c] + n);
    offset_.push_back(offset_[c] + t.bytes[c]);
  }
  if (first_.back() != h.point_count)
    throw LasError(path_ + ": point count mismatch: the chunks hold " + std::to_string(first_.back()) +
                   " points, the header announces " + std::to_string(h.point_count));
}

std::size_t LazChunks::chunkOf(std::uint64_t index) const {
  return std::size_t(std::upper_bound(first_.begin(), first_.end(), index) - first_.begin()) - 1;
}

std::unique_ptr<laz::ChunkDecoder> LazChunks::makeDecoder() const {
  return laz::makeChunkDecoder(vlr_, record_length_);
}

void LazChunks::decode(std::size_t c, laz::ChunkDecoder& decoder, std::vector<std::uint8_t>& compressed,
                       std::vector<std::uint8_t>& records) const {
  compressed.resize(offset_[c + 1] - offset_[c]);
  readExact(offset_[c], compressed.size(), compressed.data(), "a chunk");
  records.resize(points(c) * record_length_);
  try {
    decoder.decode(compressed.data(), compressed.size(), points(c), records.data());
  } catch (const std::runtime_error& e) {
    throw LasError(path_ + ": chunk " + std::to_string(c) + " (points " + std::to_string(first_[c]) + "-" +
                   std::to_string(first_[c + 1] - 1) + "): " + e.what());
  }
}

}  // namespace las
}  // namespace dw
