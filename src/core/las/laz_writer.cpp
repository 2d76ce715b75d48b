/// \file laz_writer.cpp
/// \brief LAZ writer: header, LASzip VLR, chunk-table offset, chunks, chunk table; the header and
/// the offset are rewritten on close().
#include "pcl_delaunay_walk/core/las/laz_writer.h"

#include <algorithm>
#include <cstring>
#include <exception>
#include <stdexcept>

#include "core/las/laz_codec.h"
#include "core/las/laz_items.h"

namespace dw {
namespace las {

using laz::storeLe;

namespace {

/// Runs f, turning the dw::Error of a failed file operation into the LasError this writer promises.
template <typename F>
void asLasError(F&& f) {
  try {
    f();
  } catch (const LasError&) {
    throw;
  } catch (const Error& e) {
    throw LasError(e.what());
  }
}

}  // namespace

LazWriter::LazWriter(const std::string& path, const LasHeader& header, unsigned extra_bytes,
                     std::uint32_t chunk_size, LazChunking chunking)
    : path_(path),
      uncaught_at_start_(std::uncaught_exceptions()),
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
  encoder_ = laz::makeChunkEncoder(v, h_.record_length);
  records_.resize(std::size_t(chunk_size_) * h_.record_length);
  asLasError([&] { out_.open(path); });
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
  if (closed_ || !out_.isOpen() || std::uncaught_exceptions() > uncaught_at_start_) return;  // discarded
  try {
    close();
  } catch (...) {
  }
}

void LazWriter::put(const void* p, std::size_t n) {
  asLasError([&] { out_.write(p, n); });
}

void LazWriter::write(const LasRecord& r) {
  if (closed_) throw LasError(path_ + ": write() after close()");
  std::uint8_t* rec = records_.data() + buffered_ * h_.record_length;
  encodeRecord(r, h_.point_format, rec);
  std::memset(rec + baseRecordSize(h_.point_format), 0, extra_);
  tally_.add(r);
  if (++buffered_ == chunk_size_) flushChunk();
}

void LazWriter::endChunk() {
  if (chunking_ != LazChunking::kVariable)
    throw LasError(path_ + ": endChunk() needs variable chunking (fixed chunks hold " +
                   std::to_string(chunk_size_) + " points each)");
  if (closed_) throw LasError(path_ + ": endChunk() after close()");
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
  unsigned char b[375];
  encodeHeaderBlock(h_, tally_, true, "dw::las::LazWriter", b);
  asLasError([&] { out_.seek(0); });
  put(b, h_.header_size);
}

void LazWriter::close() {
  if (closed_) return;
  flushChunk();
  std::int64_t table_offset = 0;
  asLasError([&] {
    out_.seekToEnd();
    table_offset = std::int64_t(out_.tell());
  });
  laz::ChunkTable t;
  t.bytes = chunk_bytes_;
  t.counts = chunk_counts_;
  const std::vector<std::uint8_t> table = laz::encodeChunkTable(t, chunking_ == LazChunking::kVariable);
  put(table.data(), table.size());
  writeHeader();
  asLasError([&] { out_.seek(h_.offset_to_points); });
  put(&table_offset, 8);
  asLasError([&] { out_.commit(); });
  closed_ = true;
}

}  // namespace las
}  // namespace dw
