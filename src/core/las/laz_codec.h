/// \file laz_codec.h
/// \brief The LASzip VLR and the chunk codecs: a LAZ chunk is decoded from (and encoded to) the raw
/// LAS records it stands for, record_length bytes each, so every field, extra bytes included, is
/// compared byte for byte with the uncompressed twin.
///   - pointwise (compressor 1/2, LASzip v2 items POINT10, GPSTIME11, RGB12, BYTE; formats 0-3):
///     laz_pointwise.cpp
///   - layered (compressor 3, POINT14, RGB14, RGBNIR14, BYTE14; formats 6-8): laz_layered.cpp
/// Chunks are independent: a codec holds only models that are reset at each chunk's start, so one
/// codec per thread decodes any chunk.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace dw {
namespace las {
namespace laz {

enum ItemType : std::uint16_t {
  kByte = 0,
  kPoint10 = 6,
  kGpsTime11 = 7,
  kRgb12 = 8,
  kWavePacket13 = 9,
  kPoint14 = 10,
  kRgb14 = 11,
  kRgbNir14 = 12,
  kWavePacket14 = 13,
  kByte14 = 14
};

enum Compressor : std::uint16_t { kNone = 0, kPointwise = 1, kPointwiseChunked = 2, kLayeredChunked = 3 };

struct Item {
  std::uint16_t type = 0, size = 0, version = 0;
};

/// The "laszip encoded" VLR (record 22204).
struct LaszipVlr {
  std::uint16_t compressor = kPointwiseChunked, coder = 0;
  std::uint8_t version_major = 3, version_minor = 4;
  std::uint16_t version_revision = 3;
  std::uint32_t options = 0;
  std::uint32_t chunk_size = 50000;  ///< 0xFFFFFFFF: variable (the chunk table holds the counts)
  std::int64_t special_evlr_count = -1, special_evlr_offset = -1;
  std::vector<Item> items;
  bool variableChunks() const { return chunk_size == 0xFFFFFFFFu; }
};

constexpr std::uint16_t kLaszipRecordId = 22204;
constexpr std::uint32_t kVariableChunkSize = 0xFFFFFFFFu;

/// Parses the VLR payload; throws std::runtime_error naming what is wrong.
LaszipVlr parseLaszipVlr(const std::uint8_t* p, std::size_t n);
std::vector<std::uint8_t> serializeLaszipVlr(const LaszipVlr& v);
/// The VLR LASzip writes for `point_format` with `extra_bytes` per record.
LaszipVlr defaultLaszipVlr(unsigned point_format, unsigned extra_bytes, std::uint32_t chunk_size);

/// Checks that the items cover exactly one record of `point_format`/`record_length` and that every
/// item version is one this codec implements; throws std::runtime_error otherwise.
void validateItems(const LaszipVlr& v, unsigned point_format, unsigned record_length);

class ChunkDecoder {
 public:
  virtual ~ChunkDecoder() = default;
  /// Decodes `count` records from the chunk's `n` bytes into `out` (count * record_length bytes).
  /// Throws std::runtime_error on a chunk that is inconsistent or whose stream runs out.
  virtual void decode(const std::uint8_t* bytes, std::size_t n, std::uint64_t count, std::uint8_t* out) = 0;
};

class ChunkEncoder {
 public:
  virtual ~ChunkEncoder() = default;
  /// Appends the chunk that codes `count` records (record_length bytes each) to `out`.
  virtual void encode(const std::uint8_t* records, std::size_t count, std::vector<std::uint8_t>& out) = 0;
};

std::unique_ptr<ChunkDecoder> makeChunkDecoder(const LaszipVlr& v, unsigned record_length);
std::unique_ptr<ChunkEncoder> makeChunkEncoder(const LaszipVlr& v, unsigned record_length);

// Implemented in laz_pointwise.cpp / laz_layered.cpp.
std::unique_ptr<ChunkDecoder> makePointwiseDecoder(const std::vector<Item>& items, unsigned record_length);
std::unique_ptr<ChunkEncoder> makePointwiseEncoder(const std::vector<Item>& items, unsigned record_length);
std::unique_ptr<ChunkDecoder> makeLayeredDecoder(const std::vector<Item>& items, unsigned record_length);
std::unique_ptr<ChunkEncoder> makeLayeredEncoder(const std::vector<Item>& items, unsigned record_length);

/// The chunk table: per chunk its byte size and (variable chunks) its point count.
struct ChunkTable {
  std::vector<std::uint64_t> bytes;   ///< compressed size of each chunk
  std::vector<std::uint64_t> counts;  ///< points in each chunk
};
/// Decodes the table's compressed body (after version and count); `variable` says whether counts are
/// stored. Throws std::runtime_error on a body that runs out.
void decodeChunkTable(const std::uint8_t* p, std::size_t n, std::uint32_t chunk_count, bool variable,
                      ChunkTable& table);
std::vector<std::uint8_t> encodeChunkTable(const ChunkTable& table, bool variable);

}  // namespace laz
}  // namespace las
}  // namespace dw
