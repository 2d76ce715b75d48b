/// \file laz_writer.cpp
/// \brief LAZ writer: header, LASzip VLR, chunk-table offset, chunks, chunk table; the header and
/// the offset are rewritten on close().
#include "pcl_delaunay_walk/core/las/laz_writer.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>

#include "core/las/laz_codec.h"
#include "core/las/laz_items.h"

namespace dw {
namespace las {

using laz::storeLe;

LazWriter::LazWriter(const std::string& path, const LasHeader& header, unsigned extra_bytes,
                     std::uint32_t chunk_size, LazChunking chunking)
    : path_(path),
      h_(header),
      extra_(extra_bytes),
      chunk_size_(std::max<std::uint32_t>(1, chunk_size)),
      chunking_(chunking) {
  if (h_.version_major != 1 || h_.version_minor > 4) throw LasError(path + ": can only write LAS 1.0-1.4");
  if (h_.point_format >= 6 && h_.version_minor < 4) throw LasError(path + ": formats 6-10 need LAS 1.4");
  // The readers accept chunks of at most 2^24 points (a bound on what a lying table can allocate).
  if (chunk_size_ > (1u << 24) ||
      (chunking_ == LazChunking::kFixed && chunk_size_ == laz::kVariableChunkSize))
    throw LasError(path + ": chunk size " + std::to_string(chunk_size) + " is out of range (1 to 16777216)");
  laz::LaszipVlr v;
  try {
    v = laz::defaultLaszipVlr(h_.point_format, extra_,
                              chunking_ == LazChunking::kVariable ? laz::kVariableChunkSize : chunk_size_);
  } catch (const std::runtime_error& e) {
    throw LasError(path + ": " + e.what());
  }
  vlr_ = laz::serializeLaszipVlr(v);
  h_.header_size = h_.version_minor >= 4 ? 375 : (h_.version_minor == 3 ? 235 : 227);
  h_.num_vlrs = 1;
  h_.offset_to_points = std::uint32_t(h_.header_size + 54 + vlr_.size());
  h_.record_length = static_cast<std::uint16_t>(baseRecordSize(h_.point_format) + extra_);
  h_.point_count = 0;
  encoder_ = laz::makeChunkEncoder(v, h_.record_length);
  records_.resize(std::size_t(chunk_size_) * h_.record_length);
  file_ = std::fopen(path.c_str(), "wb");
  if (!file_) throw LasError(path + ": cannot open for writing");
  writeHeader();
  std::uint8_t vh[54] = {0};
  std::strncpy(reinterpret_cast<char*>(vh + 2), "laszip encoded", 16);
  storeLe(vh + 18, laz::kLaszipRecordId);
  storeLe(vh + 20, std::uint16_t(vlr_.size()));
  std::strncpy(reinterpret_cast<char*>(vh + 22), "dw::las::LazWriter", 32);
  put(vh, sizeof vh);
  put(vlr_.data(), vlr_.size());
  const std::int64_t table_offset = -1;  // patched on close()
  put(&table_offset, 8);
}

LazWriter::~LazWriter() {
  if (file_) {
    try {
      close();
    } catch (...) {
    }
  }
}

void LazWriter::put(const void* p, std::size_t n) {
  if (n && std::fwrite(p, 1, n, file_) != n) throw LasError(path_ + ": write failed");
}

void LazWriter::write(const LasRecord& r) {
  if (!file_) throw LasError(path_ + ": write() after close()");
  std::uint8_t* rec = records_.data() + buffered_ * h_.record_length;
  encodeRecord(r, h_.point_format, rec);
  std::memset(rec + baseRecordSize(h_.point_format), 0, extra_);
  const std::int32_t v[3] = {r.X, r.Y, r.Z};
  for (int k = 0; k < 3; ++k) {
    lo_[k] = any_ ? std::min(lo_[k], v[k]) : v[k];
    hi_[k] = any_ ? std::max(hi_[k], v[k]) : v[k];
  }
  any_ = true;
  if (r.return_number >= 1 && r.return_number <= 15) ++by_return_[r.return_number - 1];
  ++h_.point_count;
  if (++buffered_ == chunk_size_) flushChunk();
}

void LazWriter::endChunk() {
  if (chunking_ != LazChunking::kVariable)
    throw LasError(path_ + ": endChunk() needs variable chunking (fixed chunks hold " +
                   std::to_string(chunk_size_) + " points each)");
  if (!file_) throw LasError(path_ + ": endChunk() after close()");
  flushChunk();
}

void LazWriter::flushChunk() {
  if (buffered_ == 0) return;
  chunk_.clear();
  encoder_->encode(records_.data(), buffered_, chunk_);
  put(chunk_.data(), chunk_.size());
  chunk_bytes_.push_back(chunk_.size());
  chunk_counts_.push_back(buffered_);
  buffered_ = 0;
}

void LazWriter::writeHeader() {
  unsigned char b[375] = {0};
  std::memcpy(b, "LASF", 4);
  b[24] = h_.version_major;
  b[25] = h_.version_minor;
  std::strncpy(reinterpret_cast<char*>(b + 26),
               h_.system_id.empty() ? "pcl_delaunay_walk" : h_.system_id.c_str(), 31);
  std::strncpy(reinterpret_cast<char*>(b + 58),
               h_.software.empty() ? "dw::las::LazWriter" : h_.software.c_str(), 31);
  storeLe(b + 94, h_.header_size);
  storeLe(b + 96, h_.offset_to_points);
  storeLe(b + 100, h_.num_vlrs);
  b[104] = std::uint8_t(h_.point_format | 0x80);  // LASzip's compressed marker
  storeLe(b + 105, h_.record_length);
  // Legacy counts are 0 for formats 6-10 and for counts beyond 32 bits (LAS 1.4 rule).
  const bool legacy_ok = h_.point_format <= 5 && h_.point_count <= 0xFFFFFFFFu;
  storeLe(b + 107, legacy_ok ? std::uint32_t(h_.point_count) : std::uint32_t{0});
  for (int k = 0; k < 5; ++k) storeLe(b + 111 + 4 * k, legacy_ok ? std::uint32_t(by_return_[k]) : 0u);
  for (int k = 0; k < 3; ++k) {
    storeLe(b + 131 + 8 * k, h_.scale[k]);
    storeLe(b + 155 + 8 * k, h_.offset[k]);
    storeLe(b + 179 + 16 * k, any_ ? hi_[k] * h_.scale[k] + h_.offset[k] : 0.0);
    storeLe(b + 187 + 16 * k, any_ ? lo_[k] * h_.scale[k] + h_.offset[k] : 0.0);
  }
  if (h_.version_minor >= 4) {
    storeLe(b + 247, h_.point_count);
    for (int k = 0; k < 15; ++k) storeLe(b + 255 + 8 * k, by_return_[k]);
  }
  if (std::fseek(file_, 0, SEEK_SET) != 0) throw LasError(path_ + ": header write failed");
  put(b, h_.header_size);
}

void LazWriter::close() {
  if (!file_) return;
  flushChunk();
  if (std::fseek(file_, 0, SEEK_END) != 0) throw LasError(path_ + ": seek failed");
  const std::int64_t table_offset = std::int64_t(std::ftell(file_));
  laz::ChunkTable t;
  t.bytes = chunk_bytes_;
  t.counts = chunk_counts_;
  const std::vector<std::uint8_t> table = laz::encodeChunkTable(t, chunking_ == LazChunking::kVariable);
  put(table.data(), table.size());
  writeHeader();
  if (std::fseek(file_, h_.offset_to_points, SEEK_SET) != 0) throw LasError(path_ + ": seek failed");
  put(&table_offset, 8);
  const bool ok = std::fclose(file_) == 0;
  file_ = nullptr;
  if (!ok) throw LasError(path_ + ": close failed (disk full?)");
}

}  // namespace las
}  // namespace dw
