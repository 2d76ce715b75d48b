/// \file las_format.h
/// \brief ASPRS LAS 1.0-1.4 public header and point records (formats 0-10) as the core reads and writes
/// them. PCL-free. Facts from the ASPRS LAS specifications 1.0-1.4 R15.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {
namespace las {

/// A LAS file that is corrupt, truncated, compressed (LAZ) or of an unsupported version/format.
class LasError : public Error {
 public:
  using Error::Error;
};

/// The fields of the public header block the module uses.
struct LasHeader {
  std::uint8_t version_major = 1, version_minor = 2;
  std::uint16_t header_size = 227;
  std::uint32_t offset_to_points = 227;
  std::uint32_t num_vlrs = 0;
  std::uint8_t point_format = 0;
  std::uint16_t record_length = 20;  ///< may exceed the format's base size (extra bytes, skipped)
  std::uint64_t point_count = 0;
  double scale[3] = {0.01, 0.01, 0.01};
  double offset[3] = {0, 0, 0};
  double min[3] = {0, 0, 0}, max[3] = {0, 0, 0};
  std::string system_id, software;
};

/// One decoded point record. Coordinates stay as the stored integers: world = X * scale + offset,
/// applied by the caller in double (the integers are also an exact frame for triangulation).
struct LasRecord {
  std::int32_t X = 0, Y = 0, Z = 0;
  std::uint16_t intensity = 0;
  std::uint8_t return_number = 0, number_of_returns = 0;
  std::uint8_t classification = 0;  ///< class code (0-31 for formats 0-5, 0-255 for 6-10)
  std::uint8_t flags = 0;           ///< bit0 synthetic, bit1 key-point, bit2 withheld, bit3 overlap
  std::int16_t scan_angle = 0;      ///< degrees (rank) for 0-5; 0.006-degree units for 6-10
  std::uint8_t user_data = 0;
  std::uint16_t point_source_id = 0;
  double gps_time = 0;
  std::uint16_t rgb[3] = {0, 0, 0};
  std::uint16_t nir = 0;
};

/// Size in bytes of a point record of `format` without extra bytes; 0 for an unknown format.
inline std::size_t baseRecordSize(unsigned format) {
  static const std::size_t sizes[11] = {20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67};
  return format <= 10 ? sizes[format] : 0;
}

inline bool formatHasGpsTime(unsigned f) {
  return f == 1 || f >= 3;
}
inline bool formatHasRgb(unsigned f) {
  return f == 2 || f == 3 || f == 5 || f == 7 || f == 8 || f == 10;
}
inline bool formatHasNir(unsigned f) {
  return f == 8 || f == 10;
}

/// Decodes one record of `format` from `p` (at least baseRecordSize(format) bytes).
void decodeRecord(const unsigned char* p, unsigned format, LasRecord& r);
/// Encodes one record; writes baseRecordSize(format) bytes (extra bytes are the caller's).
void encodeRecord(const LasRecord& r, unsigned format, unsigned char* p);

/// What a writer tallies over the records it wrote, for the header it finishes with: the point count,
/// the bounds of the stored coordinates and the points per return number.
struct LasTally {
  std::uint64_t points = 0;
  std::uint64_t by_return[15] = {0};
  std::int32_t lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  void add(const LasRecord& r);
};

/// The public header block of `h` with the tally's counts and bounds: h.header_size (at most 375)
/// bytes into `out`. `compressed` sets LASzip's marker bit on the point format; `software` names the
/// writer when h.software is empty.
void encodeHeaderBlock(const LasHeader& h, const LasTally& tally, bool compressed, const char* software,
                       unsigned char out[375]);

}  // namespace las
}  // namespace dw
