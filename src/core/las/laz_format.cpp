/// \file laz_format.cpp
/// \brief The LASzip VLR, the item lists LASzip uses for each point format, and the chunk table
/// (chunk sizes, and point counts for variable chunks, each predicted from the previous chunk's by
/// the integer compressor: 32 bits, context 0 counts, context 1 sizes).
#include <stdexcept>
#include <string>

#include "core/las/laz_codec.h"
#include "core/las/laz_items.h"

namespace dw {
namespace las {
namespace laz {

LaszipVlr parseLaszipVlr(const std::uint8_t* p, std::size_t n) {
  if (n < 34) throw std::runtime_error("LASzip VLR of " + std::to_string(n) + " bytes is too short");
  LaszipVlr v;
  v.compressor = loadLe<std::uint16_t>(p);
  v.coder = loadLe<std::uint16_t>(p + 2);
  v.version_major = p[4];
  v.version_minor = p[5];
  v.version_revision = loadLe<std::uint16_t>(p + 6);
  v.options = loadLe<std::uint32_t>(p + 8);
  v.chunk_size = loadLe<std::uint32_t>(p + 12);
  v.special_evlr_count = loadLe<std::int64_t>(p + 16);
  v.special_evlr_offset = loadLe<std::int64_t>(p + 24);
  const std::uint16_t count = loadLe<std::uint16_t>(p + 32);
  if (34 + 6 * std::size_t(count) > n)
    throw std::runtime_error("LASzip VLR announces " + std::to_string(count) + " items but holds " +
                             std::to_string((n - 34) / 6));
  for (std::uint16_t i = 0; i < count; ++i) {
    Item it;
    it.type = loadLe<std::uint16_t>(p + 34 + 6 * i);
    it.size = loadLe<std::uint16_t>(p + 36 + 6 * i);
    it.version = loadLe<std::uint16_t>(p + 38 + 6 * i);
    v.items.push_back(it);
  }
  return v;
}

std::vector<std::uint8_t> serializeLaszipVlr(const LaszipVlr& v) {
  std::vector<std::uint8_t> b(34 + 6 * v.items.size());
  storeLe(b.data(), v.compressor);
  storeLe(b.data() + 2, v.coder);
  b[4] = v.version_major;
  b[5] = v.version_minor;
  storeLe(b.data() + 6, v.version_revision);
  storeLe(b.data() + 8, v.options);
  storeLe(b.data() + 12, v.chunk_size);
  storeLe(b.data() + 16, v.special_evlr_count);
  storeLe(b.data() + 24, v.special_evlr_offset);
  storeLe(b.data() + 32, std::uint16_t(v.items.size()));
  for (std::size_t i = 0; i < v.items.size(); ++i) {
    storeLe(b.data() + 34 + 6 * i, v.items[i].type);
    storeLe(b.data() + 36 + 6 * i, v.items[i].size);
    storeLe(b.data() + 38 + 6 * i, v.items[i].version);
  }
  return b;
}

LaszipVlr defaultLaszipVlr(unsigned format, unsigned extra, std::uint32_t chunk_size) {
  LaszipVlr v;
  v.chunk_size = chunk_size;
  if (format <= 3) {
    v.compressor = kPointwiseChunked;
    v.items.push_back({kPoint10, 20, 2});
    if (format == 1 || format == 3) v.items.push_back({kGpsTime11, 8, 2});
    if (format == 2 || format == 3) v.items.push_back({kRgb12, 6, 2});
    if (extra) v.items.push_back({kByte, std::uint16_t(extra), 2});
  } else if (format >= 6 && format <= 8) {
    v.compressor = kLayeredChunked;
    v.items.push_back({kPoint14, 30, 3});
    if (format == 7) v.items.push_back({kRgb14, 6, 3});
    if (format == 8) v.items.push_back({kRgbNir14, 8, 3});
    if (extra) v.items.push_back({kByte14, std::uint16_t(extra), 3});
  } else {
    throw std::runtime_error("LAZ of point format " + std::to_string(format) +
                             " (waveform packets) is not supported; formats 0-3 and 6-8 are");
  }
  return v;
}

void validateItems(const LaszipVlr& v, unsigned format, unsigned record_length) {
  if (v.coder != 0) throw std::runtime_error("unknown LASzip coder " + std::to_string(v.coder));
  if (v.compressor != kPointwise && v.compressor != kPointwiseChunked && v.compressor != kLayeredChunked)
    throw std::runtime_error("unknown LASzip compressor " + std::to_string(v.compressor));
  if (v.chunk_size == 0) throw std::runtime_error("LASzip chunk size is 0");
  const unsigned base_extra = [&] {
    static const unsigned sizes[11] = {20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67};
    if (format > 10) throw std::runtime_error("unknown point format " + std::to_string(format));
    if (record_length < sizes[format]) throw std::runtime_error("record length below the format's size");
    return record_length - sizes[format];
  }();
  LaszipVlr expect = defaultLaszipVlr(format, base_extra, v.chunk_size);  // throws for 4, 5, 9, 10
  if ((format <= 3) != (v.compressor != kLayeredChunked))
    throw std::runtime_error("LASzip compressor " + std::to_string(v.compressor) +
                             " does not fit point format " + std::to_string(format));
  if (v.items.size() != expect.items.size())
    throw std::runtime_error("LASzip VLR lists " + std::to_string(v.items.size()) + " items, point format " +
                             std::to_string(format) + " with " + std::to_string(base_extra) +
                             " extra bytes needs " + std::to_string(expect.items.size()));
  for (std::size_t i = 0; i < v.items.size(); ++i) {
    const Item& a = v.items[i];
    const Item& e = expect.items[i];
    if (a.type != e.type || a.size != e.size)
      throw std::runtime_error("LASzip item " + std::to_string(i) + " (type " + std::to_string(a.type) +
                               ", " + std::to_string(a.size) + " bytes) does not fit point format " +
                               std::to_string(format));
    const bool ok = format <= 3 ? a.version == 2 : (a.version == 3 || a.version == 4);
    if (!ok)
      throw std::runtime_error("LASzip item type " + std::to_string(a.type) + " version " +
                               std::to_string(a.version) + " is not supported (" +
                               (format <= 3 ? "version 2" : "versions 3 and 4") + " are)");
  }
}

std::unique_ptr<ChunkDecoder> makeChunkDecoder(const LaszipVlr& v, unsigned record_length) {
  return v.compressor == kLayeredChunked ? makeLayeredDecoder(v.items, record_length)
                                         : makePointwiseDecoder(v.items, record_length);
}
std::unique_ptr<ChunkEncoder> makeChunkEncoder(const LaszipVlr& v, unsigned record_length) {
  return v.compressor == kLayeredChunked ? makeLayeredEncoder(v.items, record_length)
                                         : makePointwiseEncoder(v.items, record_length);
}

void decodeChunkTable(const std::uint8_t* p, std::size_t n, std::uint32_t chunk_count, bool variable,
                      ChunkTable& table) {
  table.bytes.assign(chunk_count, 0);
  table.counts.assign(chunk_count, 0);
  if (chunk_count == 0) return;
  ArithmeticDecoder dec;
  dec.init(p, n);
  IntegerCodec ic(32, 2, true);
  std::int32_t last_count = 0, last_bytes = 0;
  for (std::uint32_t i = 0; i < chunk_count; ++i) {
    if (variable) table.counts[i] = std::uint32_t(last_count = ic.decompress(dec, last_count, 0));
    table.bytes[i] = std::uint32_t(last_bytes = ic.decompress(dec, last_bytes, 1));
    if (dec.overrun() > 4) throw std::runtime_error("the chunk table runs out at chunk " + std::to_string(i));
  }
  if (dec.corrupt()) throw std::runtime_error("the chunk table is corrupt");
}

std::vector<std::uint8_t> encodeChunkTable(const ChunkTable& table, bool variable) {
  std::vector<std::uint8_t> out(8);
  storeLe(out.data(), std::uint32_t(0));
  storeLe(out.data() + 4, std::uint32_t(table.bytes.size()));
  if (table.bytes.empty()) return out;
  ArithmeticEncoder enc;
  enc.init();
  IntegerCodec ic(32, 2, false);
  for (std::size_t i = 0; i < table.bytes.size(); ++i) {
    if (variable)
      ic.compress(enc, i ? std::int32_t(table.counts[i - 1]) : 0, std::int32_t(table.counts[i]), 0);
    ic.compress(enc, i ? std::int32_t(table.bytes[i - 1]) : 0, std::int32_t(table.bytes[i]), 1);
  }
  enc.done();
  out.insert(out.end(), enc.bytes().begin(), enc.bytes().end());
  return out;
}

}  // namespace laz
}  // namespace las
}  // namespace dw
