/// \file las_writer.cpp
/// \brief Uncompressed LAS writer (header rewritten with counts and bounds on close).
#include "pcl_delaunay_walk/core/las/las_writer.h"

#include <algorithm>
#include <cstring>
#include <exception>

namespace dw {
namespace las {
namespace {

template <typename T>
void put(unsigned char* p, T v) {
  std::memcpy(p, &v, sizeof v);
}

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
  h_.point_count = 0;
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
  const std::int32_t v[3] = {r.X, r.Y, r.Z};
  for (int k = 0; k < 3; ++k) {
    lo_[k] = any_ ? std::min(lo_[k], v[k]) : v[k];
    hi_[k] = any_ ? std::max(hi_[k], v[k]) : v[k];
  }
  any_ = true;
  if (r.return_number >= 1 && r.return_number <= 15) ++by_return_[r.return_number - 1];
  ++h_.point_count;
}

void LasWriter::writeHeader() {
  unsigned char b[375] = {0};
  std::memcpy(b, "LASF", 4);
  b[24] = h_.version_major;
  b[25] = h_.version_minor;
  std::strncpy(reinterpret_cast<char*>(b + 26),
               h_.system_id.empty() ? "pcl_delaunay_walk" : h_.system_id.c_str(), 31);
  std::strncpy(reinterpret_cast<char*>(b + 58),
               h_.software.empty() ? "dw::las::LasWriter" : h_.software.c_str(), 31);
  put(b + 94, h_.header_size);
  put(b + 96, h_.offset_to_points);
  put(b + 100, h_.num_vlrs);
  b[104] = h_.point_format;
  put(b + 105, h_.record_length);
  // Legacy counts are 0 for formats 6-10 and for counts beyond 32 bits (LAS 1.4 rule).
  const bool legacy_ok = h_.point_format <= 5 && h_.point_count <= 0xFFFFFFFFu;
  put(b + 107, legacy_ok ? static_cast<std::uint32_t>(h_.point_count) : std::uint32_t{0});
  for (int k = 0; k < 5; ++k)
    put(b + 111 + 4 * k, legacy_ok ? static_cast<std::uint32_t>(by_return_[k]) : 0u);
  for (int k = 0; k < 3; ++k) {
    put(b + 131 + 8 * k, h_.scale[k]);
    put(b + 155 + 8 * k, h_.offset[k]);
    const double mn = any_ ? lo_[k] * h_.scale[k] + h_.offset[k] : 0.0;
    const double mx = any_ ? hi_[k] * h_.scale[k] + h_.offset[k] : 0.0;
    put(b + 179 + 16 * k, mx);
    put(b + 187 + 16 * k, mn);
  }
  if (h_.version_minor >= 4) {
    put(b + 247, h_.point_count);
    for (int k = 0; k < 15; ++k) put(b + 255 + 8 * k, by_return_[k]);
  }
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
