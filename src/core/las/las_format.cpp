/// \file las_format.cpp
/// \brief Record layouts of LAS point formats 0-10 (little-endian, as the format prescribes).
#include "pcl_delaunay_walk/core/las/las_format.h"

#include <algorithm>
#include <cstring>

namespace dw {
namespace las {
namespace {

static_assert(sizeof(double) == 8 && sizeof(float) == 4, "LAS needs IEEE double");

template <typename T>
T get(const unsigned char* p) {
  T v;
  std::memcpy(&v, p, sizeof v);  // the module targets little-endian hosts (x86-64, aarch64)
  return v;
}
template <typename T>
void put(unsigned char* p, T v) {
  std::memcpy(p, &v, sizeof v);
}

}  // namespace

void decodeRecord(const unsigned char* p, unsigned format, LasRecord& r) {
  r.X = get<std::int32_t>(p);
  r.Y = get<std::int32_t>(p + 4);
  r.Z = get<std::int32_t>(p + 8);
  r.intensity = get<std::uint16_t>(p + 12);
  const std::uint8_t ret = p[14];
  if (format <= 5) {
    r.return_number = ret & 7;
    r.number_of_returns = (ret >> 3) & 7;
    const std::uint8_t c = p[15];
    r.classification = c & 31;
    r.flags = static_cast<std::uint8_t>((c >> 5) & 7);
    r.scan_angle = static_cast<std::int8_t>(p[16]);
    r.user_data = p[17];
    r.point_source_id = get<std::uint16_t>(p + 18);
    std::size_t o = 20;
    if (formatHasGpsTime(format)) {
      r.gps_time = get<double>(p + o);
      o += 8;
    }
    if (formatHasRgb(format))
      for (int k = 0; k < 3; ++k) r.rgb[k] = get<std::uint16_t>(p + o + 2 * k);
    return;
  }
  r.return_number = ret & 15;
  r.number_of_returns = ret >> 4;
  r.flags = p[15] & 15;
  r.classification = p[16];
  r.user_data = p[17];
  r.scan_angle = get<std::int16_t>(p + 18);
  r.point_source_id = get<std::uint16_t>(p + 20);
  r.gps_time = get<double>(p + 22);
  if (formatHasRgb(format))
    for (int k = 0; k < 3; ++k) r.rgb[k] = get<std::uint16_t>(p + 30 + 2 * k);
  if (formatHasNir(format)) r.nir = get<std::uint16_t>(p + 36);
}

void encodeRecord(const LasRecord& r, unsigned format, unsigned char* p) {
  std::memset(p, 0, baseRecordSize(format));
  put(p, r.X);
  put(p + 4, r.Y);
  put(p + 8, r.Z);
  put(p + 12, r.intensity);
  if (format <= 5) {
    p[14] = static_cast<unsigned char>((r.return_number & 7) | ((r.number_of_returns & 7) << 3));
    p[15] = static_cast<unsigned char>((r.classification & 31) | ((r.flags & 7) << 5));
    p[16] = static_cast<unsigned char>(static_cast<std::int8_t>(r.scan_angle));
    p[17] = r.user_data;
    put(p + 18, r.point_source_id);
    std::size_t o = 20;
    if (formatHasGpsTime(format)) {
      put(p + o, r.gps_time);
      o += 8;
    }
    if (formatHasRgb(format))
      for (int k = 0; k < 3; ++k) put(p + o + 2 * k, r.rgb[k]);
    return;
  }
  p[14] = static_cast<unsigned char>((r.return_number & 15) | ((r.number_of_returns & 15) << 4));
  p[15] = r.flags & 15;
  p[16] = r.classification;
  p[17] = r.user_data;
  put(p + 18, r.scan_angle);
  put(p + 20, r.point_source_id);
  put(p + 22, r.gps_time);
  if (formatHasRgb(format))
    for (int k = 0; k < 3; ++k) put(p + 30 + 2 * k, r.rgb[k]);
  if (formatHasNir(format)) put(p + 36, r.nir);
}

void LasTally::add(const LasRecord& r) {
  const std::int32_t v[3] = {r.X, r.Y, r.Z};
  for (int k = 0; k < 3; ++k) {
    lo[k] = points ? std::min(lo[k], v[k]) : v[k];
    hi[k] = points ? std::max(hi[k], v[k]) : v[k];
  }
  if (r.return_number >= 1 && r.return_number <= 15) ++by_return[r.return_number - 1];
  ++points;
}

void encodeHeaderBlock(const LasHeader& h, const LasTally& t, bool compressed, const char* software,
                       unsigned char out[375]) {
  unsigned char b[375] = {0};
  std::memcpy(b, "LASF", 4);
  b[24] = h.version_major;
  b[25] = h.version_minor;
  std::strncpy(reinterpret_cast<char*>(b + 26),
               h.system_id.empty() ? "pcl_delaunay_walk" : h.system_id.c_str(), 31);
  std::strncpy(reinterpret_cast<char*>(b + 58), h.software.empty() ? software : h.software.c_str(), 31);
  put(b + 94, h.header_size);
  put(b + 96, h.offset_to_points);
  put(b + 100, h.num_vlrs);
  b[104] = static_cast<unsigned char>(compressed ? h.point_format | 0x80 : h.point_format);
  put(b + 105, h.record_length);
  // Legacy counts are 0 for formats 6-10 and for counts beyond 32 bits (LAS 1.4 rule).
  const bool legacy_ok = h.point_format <= 5 && t.points <= 0xFFFFFFFFu;
  put(b + 107, legacy_ok ? static_cast<std::uint32_t>(t.points) : std::uint32_t{0});
  for (int k = 0; k < 5; ++k)
    put(b + 111 + 4 * k, legacy_ok ? static_cast<std::uint32_t>(t.by_return[k]) : 0u);
  for (int k = 0; k < 3; ++k) {
    put(b + 131 + 8 * k, h.scale[k]);
    put(b + 155 + 8 * k, h.offset[k]);
    put(b + 179 + 16 * k, t.points ? t.hi[k] * h.scale[k] + h.offset[k] : 0.0);
    put(b + 187 + 16 * k, t.points ? t.lo[k] * h.scale[k] + h.offset[k] : 0.0);
  }
  if (h.version_minor >= 4) {
    put(b + 247, t.points);
    for (int k = 0; k < 15; ++k) put(b + 255 + 8 * k, t.by_return[k]);
  }
  std::memcpy(out, b, std::min<std::size_t>(h.header_size, sizeof b));
}

}  // namespace las
}  // namespace dw
