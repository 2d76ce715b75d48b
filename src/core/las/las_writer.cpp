/// \file las_writer.cpp
/// \brief Uncompressed LAS writer (header rewritten with counts and bounds on close).
#include "pcl_delaunay_walk/core/las/las_writer.h"

#include <algorithm>
#include <cstring>
#include <exception>

namespace dw {
namespace las {
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

LasWriter::LasWriter(const std::string& path, const LasHeader& header, unsigned extra_bytes)
    : path_(path), uncaught_at_start_(std::uncaught_exceptions()), h_(header), extra_(extra_bytes) {
  if (h_.version_major != 1 || h_.version_minor > 4) throw LasError(path + ": can only write LAS 1.0-1.4");
  if (h_.point_format > 10) throw LasError(path + ": unknown point format");
  if (h_.point_format >= 6 && h_.version_minor < 4) throw LasError(path + ": formats 6-10 need LAS 1.4");
  h_.header_size = h_.version_minor >= 4 ? 375 : (h_.version_minor == 3 ? 235 : 227);
  h_.offset_to_points = h_.header_size;
  h_.num_vlrs = 0;
  h_.record_length = static_cast<std::uint16_t>(baseRecordSize(h_.point_format) + extra_);
  asLasError([&] { out_.open(path); });
  writeHeader();
  rec_.resize(h_.record_length, 0);
}

LasWriter::~LasWriter() {
  if (closed_ || !out_.isOpen() || std::uncaught_exceptions() > uncaught_at_start_) return;  // discarded
  try {
    close();
  } catch (...) {
  }
}

void LasWriter::write(const LasRecord& r) {
  encodeRecord(r, h_.point_format, rec_.data());
  std::memset(rec_.data() + baseRecordSize(h_.point_format), 0, extra_);
  asLasError([&] { out_.write(rec_.data(), rec_.size()); });
  tally_.add(r);
}

void LasWriter::writeHeader() {
  unsigned char b[375];
  encodeHeaderBlock(h_, tally_, false, "dw::las::LasWriter", b);
  asLasError([&] {
    out_.seek(0);
    out_.write(b, h_.header_size);
  });
}

void LasWriter::close() {
  if (closed_) return;
  writeHeader();
  asLasError([&] { out_.commit(); });
  closed_ = true;
}

}  // namespace las
}  // namespace dw
