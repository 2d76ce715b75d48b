/// \file las_format.cpp
/// \brief Record layouts of LAS point formats 0-10 (little-endian, as the format prescribes).
#include "pcl_delaunay_walk/core/las/las_format.h"

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

}  // namespace las
}  // namespace dw
