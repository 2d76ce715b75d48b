/// \file laz_pointwise.cpp
/// \brief LASzip's pointwise chunk codec (point formats 0-3 and their extra bytes): items POINT10,
/// GPSTIME11, RGB12 and BYTE, version 2. A chunk is its first record raw, then one arithmetic stream
/// in which every following point codes its items in order.
#include <stdexcept>
#include <string>

#include "core/las/laz_codec.h"
#include "core/las/laz_items.h"

namespace dw {
namespace las {
namespace laz {
namespace {

// LASzip's v2 return map (laszip_common_v2): r = return number, n = number of returns (0..7).
const std::uint8_t kReturnMap[8][8] = {{15, 14, 13, 12, 11, 10, 9, 8},  {14, 0, 1, 3, 6, 10, 10, 9},
                                       {13, 1, 2, 4, 7, 11, 11, 10},    {12, 3, 4, 5, 8, 12, 12, 11},
                                       {11, 6, 7, 8, 9, 13, 13, 12},    {10, 10, 11, 12, 13, 14, 14, 13},
                                       {9, 10, 11, 12, 13, 14, 15, 14}, {8, 9, 10, 11, 12, 13, 14, 15}};

/// |n - r|, the v2 return level.
inline unsigned returnLevel(unsigned n, unsigned r) {
  return n > r ? n - r : r - n;
}

struct Point10Models {
  std::uint8_t last[20];
  std::uint16_t last_intensity[16];
  StreamingMedian5 median_x[16], median_y[16];
  std::int32_t last_height[8];
  SymbolModel m_changed, m_scan_angle[2], m_bit_byte[256], m_class[256], m_user[256];
  IntegerCodec ic_intensity, ic_psid, ic_dx, ic_dy, ic_z;
  bool created = false;

  void start(const std::uint8_t* first, bool decoder) {
    if (!created) {
      m_changed.create(64, decoder);
      m_scan_angle[0].create(256, decoder);
      m_scan_angle[1].create(256, decoder);
      ic_intensity.create(16, 4, decoder);
      ic_psid.create(16, 1, decoder);
      ic_dx.create(32, 2, decoder);
      ic_dy.create(32, 22, decoder);
      ic_z.create(32, 20, decoder);
      created = true;
    } else {
      m_changed.init();
      m_scan_angle[0].init();
      m_scan_angle[1].init();
      ic_intensity.init();
      ic_psid.init();
      ic_dx.init();
      ic_dy.init();
      ic_z.init();
    }
    for (int i = 0; i < 256; ++i) {
      if (m_bit_byte[i].created()) m_bit_byte[i].init();
      if (m_class[i].created()) m_class[i].init();
      if (m_user[i].created()) m_user[i].init();
    }
    for (int i = 0; i < 16; ++i) {
      median_x[i].init();
      median_y[i].init();
      last_intensity[i] = 0;
      last_height[i / 2] = 0;
    }
    std::memcpy(last, first, 20);
  }
};

inline SymbolModel& lazy256(SymbolModel& m, bool decoder) {
  if (!m.created()) m.create(256, decoder);
  return m;
}

struct GpsModels {
  GpsState s;
  SymbolModel m_multi, m_0diff;
  IntegerCodec ic;
  bool created = false;
  void start(std::int64_t first, bool decoder) {
    if (!created) {
      m_multi.create(kGpsMulti - kGpsMultiMinus + 6, decoder);
      m_0diff.create(6, decoder);
      ic.create(32, 9, decoder);
      created = true;
    } else {
      m_multi.init();
      m_0diff.init();
      ic.init();
    }
    s.init(first);
  }
};

/// Which items follow POINT10 and where they sit in the record.
struct Layout10 {
  bool gps = false, rgb = false;
  unsigned gps_at = 0, rgb_at = 0, extra_at = 0, extra = 0;
};

Layout10 layoutOf(const std::vector<Item>& items, unsigned record_length) {
  Layout10 L;
  unsigned at = 0;
  for (const Item& it : items) {
    if (it.type == kGpsTime11) {
      L.gps = true;
      L.gps_at = at;
    } else if (it.type == kRgb12) {
      L.rgb = true;
      L.rgb_at = at;
    } else if (it.type == kByte) {
      L.extra_at = at;
      L.extra = it.size;
    }
    at += it.size;
  }
  if (at != record_length) throw std::runtime_error("LASzip items do not add up to the record length");
  return L;
}

class PointwiseDecoder final : public ChunkDecoder {
 public:
  PointwiseDecoder(const std::vector<Item>& items, unsigned record_length)
      : L_(layoutOf(items, record_length)), record_length_(record_length) {}

  void decode(const std::uint8_t* bytes, std::size_t n, std::uint64_t count, std::uint8_t* out) override {
    if (count == 0) return;
    if (n < record_length_)
      throw std::runtime_error("chunk of " + std::to_string(n) + " bytes lacks its first point");
    std::memcpy(out, bytes, record_length_);
    p10_.start(bytes, true);
    if (L_.gps) gps_.start(loadLe<std::int64_t>(bytes + L_.gps_at), true);
    if (L_.rgb)
      for (int k = 0; k < 3; ++k) last_rgb_[k] = loadLe<std::uint16_t>(bytes + L_.rgb_at + 2 * k);
    if (L_.rgb) {
      if (!rgb_created_) rgb_.create(true);
      rgb_created_ = true;
      rgb_.init();
    }
    startBytes(bytes + L_.extra_at);
    if (count > 1) dec_.init(bytes + record_length_, n - record_length_);
    for (std::uint64_t i = 1; i < count; ++i) {
      std::uint8_t* rec = out + i * record_length_;
      readPoint10(rec);
      if (L_.gps) readGps(rec + L_.gps_at);
      if (L_.rgb) {
        decodeRgb(dec_, rgb_, last_rgb_, last_rgb_);
        for (int k = 0; k < 3; ++k) storeLe(rec + L_.rgb_at + 2 * k, last_rgb_[k]);
      }
      for (unsigned b = 0; b < L_.extra; ++b) {
        last_bytes_[b] = fold8(std::int32_t(last_bytes_[b]) + std::int32_t(dec_.decodeSymbol(m_bytes_[b])));
        rec[L_.extra_at + b] = last_bytes_[b];
      }
    }
    if (count > 1 && dec_.corrupt()) throw std::runtime_error("the arithmetic stream is corrupt");
    if (count > 1 && dec_.overrun() > 4)
      throw std::runtime_error("the arithmetic stream runs out (" + std::to_string(n) + " bytes for " +
                               std::to_string(count) + " points)");
  }

 private:
  void startBytes(const std::uint8_t* first) {
    if (m_bytes_.size() != L_.extra) {
      m_bytes_.assign(L_.extra, SymbolModel());
      for (auto& m : m_bytes_) m.create(256, true);
    } else {
      for (auto& m : m_bytes_) m.init();
    }
    last_bytes_.assign(first, first + L_.extra);
  }
  void readPoint10(std::uint8_t* rec);
  void readGps(std::uint8_t* rec);

  Layout10 L_;
  unsigned record_length_;
  ArithmeticDecoder dec_;
  Point10Models p10_;
  GpsModels gps_;
  RgbModels rgb_;
  bool rgb_created_ = false;
  std::uint16_t last_rgb_[3] = {0, 0, 0};
  std::vector<SymbolModel> m_bytes_;
  std::vector<std::uint8_t> last_bytes_;
};

void PointwiseDecoder::readPoint10(std::uint8_t* rec) {
  Point10Models& p = p10_;
  std::uint8_t* last = p.last;
  const std::uint32_t changed = dec_.decodeSymbol(p.m_changed);
  if (changed & 32) last[14] = std::uint8_t(dec_.decodeSymbol(lazy256(p.m_bit_byte[last[14]], true)));
  const unsigned r = last[14] & 7, n = (last[14] >> 3) & 7;
  const unsigned m = kReturnMap[n][r], l = returnLevel(n, r);
  if (changed) {
    std::uint16_t intensity = p.last_intensity[m];
    if (changed & 16) {
      intensity = std::uint16_t(p.ic_intensity.decompress(dec_, p.last_intensity[m], m < 3 ? m : 3));
      p.last_intensity[m] = intensity;
    }
    storeLe(last + 12, intensity);
    if (changed & 8) last[15] = std::uint8_t(dec_.decodeSymbol(lazy256(p.m_class[last[15]], true)));
    if (changed & 4) {
      const std::uint32_t v = dec_.decodeSymbol(p.m_scan_angle[(last[14] >> 6) & 1]);
      last[16] = fold8(std::int32_t(v) + last[16]);
    }
    if (changed & 2) last[17] = std::uint8_t(dec_.decodeSymbol(lazy256(p.m_user[last[17]], true)));
    if (changed & 1)
      storeLe(last + 18, std::uint16_t(p.ic_psid.decompress(dec_, loadLe<std::uint16_t>(last + 18))));
  }
  std::int32_t diff = p.ic_dx.decompress(dec_, p.median_x[m].get(), n == 1);
  storeLe(last, std::int32_t(std::uint32_t(loadLe<std::int32_t>(last)) + std::uint32_t(diff)));
  p.median_x[m].add(diff);
  unsigned k = p.ic_dx.k();
  diff = p.ic_dy.decompress(dec_, p.median_y[m].get(), (n == 1) + (k < 20 ? (k & ~1u) : 20));
  storeLe(last + 4, std::int32_t(std::uint32_t(loadLe<std::int32_t>(last + 4)) + std::uint32_t(diff)));
  p.median_y[m].add(diff);
  k = (p.ic_dx.k() + p.ic_dy.k()) / 2;
  const std::int32_t z = p.ic_z.decompress(dec_, p.last_height[l], (n == 1) + (k < 18 ? (k & ~1u) : 18));
  storeLe(last + 8, z);
  p.last_height[l] = z;
  std::memcpy(rec, last, 20);
}

void PointwiseDecoder::readGps(std::uint8_t* rec) {
  GpsState& s = gps_.s;
  constexpr std::int32_t unchanged = kGpsMulti - kGpsMultiMinus + 1, code_full = unchanged + 1;
  for (int attempt = 0; attempt < 4; ++attempt) {
    if (s.last_diff[s.last] == 0) {
      const std::uint32_t multi = dec_.decodeSymbol(gps_.m_0diff);
      if (multi == 1) {
        s.last_diff[s.last] = gps_.ic.decompress(dec_, 0, 0);
        s.last_gps[s.last] = wrapAdd(s.last_gps[s.last], s.last_diff[s.last]);
        s.extreme[s.last] = 0;
      } else if (multi == 2) {
        decodeGpsFull(dec_, gps_.ic, s);
      } else if (multi > 2) {
        s.last = (s.last + multi - 2) & 3;
        continue;
      }
    } else {
      const std::int32_t multi = std::int32_t(dec_.decodeSymbol(gps_.m_multi));
      if (multi == 1) {
        s.last_gps[s.last] = wrapAdd(s.last_gps[s.last], gps_.ic.decompress(dec_, s.last_diff[s.last], 1));
        s.extreme[s.last] = 0;
      } else if (multi < unchanged) {
        decodeGpsMulti(dec_, gps_.ic, s, multi);
      } else if (multi == code_full) {
        decodeGpsFull(dec_, gps_.ic, s);
      } else if (multi > code_full) {
        s.last = (s.last + std::uint32_t(multi - code_full)) & 3;
        continue;
      }
    }
    storeLe(rec, s.last_gps[s.last]);
    return;
  }
  dec_.markCorrupt();
  storeLe(rec, s.last_gps[s.last]);
}

class PointwiseEncoder final : public ChunkEncoder {
 public:
  PointwiseEncoder(const std::vector<Item>& items, unsigned record_length)
      : L_(layoutOf(items, record_length)), record_length_(record_length) {}

  void encode(const std::uint8_t* records, std::size_t count, std::vector<std::uint8_t>& out) override {
    if (count == 0) return;
    out.insert(out.end(), records, records + record_length_);
    p10_.start(records, false);
    if (L_.gps) gps_.start(loadLe<std::int64_t>(records + L_.gps_at), false);
    if (L_.rgb) {
      for (int k = 0; k < 3; ++k) last_rgb_[k] = loadLe<std::uint16_t>(records + L_.rgb_at + 2 * k);
      if (!rgb_created_) rgb_.create(false);
      rgb_created_ = true;
      rgb_.init();
    }
    if (m_bytes_.size() != L_.extra) {
      m_bytes_.assign(L_.extra, SymbolModel());
      for (auto& m : m_bytes_) m.create(256, false);
    } else {
      for (auto& m : m_bytes_) m.init();
    }
    last_bytes_.assign(records + L_.extra_at, records + L_.extra_at + L_.extra);
    if (count == 1) return;
    enc_.init();
    for (std::size_t i = 1; i < count; ++i) {
      const std::uint8_t* rec = records + i * record_length_;
      writePoint10(rec);
      if (L_.gps) writeGps(loadLe<std::int64_t>(rec + L_.gps_at));
      if (L_.rgb) {
        std::uint16_t v[3];
        for (int k = 0; k < 3; ++k) v[k] = loadLe<std::uint16_t>(rec + L_.rgb_at + 2 * k);
        encodeRgb(enc_, rgb_, last_rgb_, v);
        std::memcpy(last_rgb_, v, sizeof v);
      }
      for (unsigned b = 0; b < L_.extra; ++b) {
        const std::uint8_t v = rec[L_.extra_at + b];
        enc_.encodeSymbol(m_bytes_[b], fold8(std::int32_t(v) - std::int32_t(last_bytes_[b])));
        last_bytes_[b] = v;
      }
    }
    enc_.done();
    out.insert(out.end(), enc_.bytes().begin(), enc_.bytes().end());
  }

 private:
  void writePoint10(const std::uint8_t* item);
  void writeGps(std::int64_t t);

  Layout10 L_;
  unsigned record_length_;
  ArithmeticEncoder enc_;
  Point10Models p10_;
  GpsModels gps_;
  RgbModels rgb_;
  bool rgb_created_ = false;
  std::uint16_t last_rgb_[3] = {0, 0, 0};
  std::vector<SymbolModel> m_bytes_;
  std::vector<std::uint8_t> last_bytes_;
};

void PointwiseEncoder::writePoint10(const std::uint8_t* item) {
  Point10Models& p = p10_;
  std::uint8_t* last = p.last;
  const unsigned r = item[14] & 7, n = (item[14] >> 3) & 7;
  const unsigned m = kReturnMap[n][r], l = returnLevel(n, r);
  // A decoder keeps the last point's intensity when nothing changed, and takes last_intensity[m]
  // when something else did: code the intensity whenever either would be wrong.
  const std::uint16_t intensity = loadLe<std::uint16_t>(item + 12),
                      last_intensity = loadLe<std::uint16_t>(last + 12);
  const std::uint16_t psid = loadLe<std::uint16_t>(item + 18), last_psid = loadLe<std::uint16_t>(last + 18);
  const std::uint32_t changed =
      (std::uint32_t(last[14] != item[14]) << 5) |
      (std::uint32_t(p.last_intensity[m] != intensity || last_intensity != intensity) << 4) |
      (std::uint32_t(last[15] != item[15]) << 3) | (std::uint32_t(last[16] != item[16]) << 2) |
      (std::uint32_t(last[17] != item[17]) << 1) | std::uint32_t(last_psid != psid);
  enc_.encodeSymbol(p.m_changed, changed);
  if (changed & 32) enc_.encodeSymbol(lazy256(p.m_bit_byte[last[14]], false), item[14]);
  if (changed & 16) {
    p.ic_intensity.compress(enc_, p.last_intensity[m], intensity, m < 3 ? m : 3);
    p.last_intensity[m] = intensity;
  }
  if (changed & 8) enc_.encodeSymbol(lazy256(p.m_class[last[15]], false), item[15]);
  if (changed & 4)
    enc_.encodeSymbol(p.m_scan_angle[(item[14] >> 6) & 1], fold8(std::int32_t(item[16]) - last[16]));
  if (changed & 2) enc_.encodeSymbol(lazy256(p.m_user[last[17]], false), item[17]);
  if (changed & 1) p.ic_psid.compress(enc_, last_psid, psid);
  std::int32_t diff =
      std::int32_t(std::uint32_t(loadLe<std::int32_t>(item)) - std::uint32_t(loadLe<std::int32_t>(last)));
  p.ic_dx.compress(enc_, p.median_x[m].get(), diff, n == 1);
  p.median_x[m].add(diff);
  unsigned k = p.ic_dx.k();
  diff = std::int32_t(std::uint32_t(loadLe<std::int32_t>(item + 4)) -
                      std::uint32_t(loadLe<std::int32_t>(last + 4)));
  p.ic_dy.compress(enc_, p.median_y[m].get(), diff, (n == 1) + (k < 20 ? (k & ~1u) : 20));
  p.median_y[m].add(diff);
  k = (p.ic_dx.k() + p.ic_dy.k()) / 2;
  const std::int32_t z = loadLe<std::int32_t>(item + 8);
  p.ic_z.compress(enc_, p.last_height[l], z, (n == 1) + (k < 18 ? (k & ~1u) : 18));
  p.last_height[l] = z;
  std::memcpy(last, item, 20);
}

void PointwiseEncoder::writeGps(std::int64_t t) {
  GpsState& s = gps_.s;
  constexpr std::int32_t unchanged = kGpsMulti - kGpsMultiMinus + 1, code_full = unchanged + 1;
  const bool zero_diff = s.last_diff[s.last] == 0;
  if (t == s.last_gps[s.last]) {
    enc_.encodeSymbol(zero_diff ? gps_.m_0diff : gps_.m_multi, zero_diff ? 0u : std::uint32_t(unchanged));
    return;
  }
  std::int32_t diff;
  if (fits32(t, s.last_gps[s.last], diff)) {
    if (zero_diff) {
      enc_.encodeSymbol(gps_.m_0diff, 1);
      gps_.ic.compress(enc_, 0, diff, 0);
      s.last_diff[s.last] = diff;
      s.extreme[s.last] = 0;
    } else {
      encodeGpsMulti(enc_, gps_.m_multi, gps_.ic, s, diff);
    }
    s.last_gps[s.last] = t;
    return;
  }
  for (std::uint32_t i = 1; i < 4; ++i) {
    std::int32_t other;
    if (!fits32(t, s.last_gps[(s.last + i) & 3], other)) continue;
    enc_.encodeSymbol(zero_diff ? gps_.m_0diff : gps_.m_multi,
                      zero_diff ? i + 2 : std::uint32_t(code_full) + i);
    s.last = (s.last + i) & 3;
    writeGps(t);
    return;
  }
  enc_.encodeSymbol(zero_diff ? gps_.m_0diff : gps_.m_multi, zero_diff ? 2u : std::uint32_t(code_full));
  encodeGpsFull(enc_, gps_.ic, s, t);
  s.last_gps[s.last] = t;
}

}  // namespace

std::unique_ptr<ChunkDecoder> makePointwiseDecoder(const std::vector<Item>& items, unsigned record_length) {
  return std::make_unique<PointwiseDecoder>(items, record_length);
}
std::unique_ptr<ChunkEncoder> makePointwiseEncoder(const std::vector<Item>& items, unsigned record_length) {
  return std::make_unique<PointwiseEncoder>(items, record_length);
}

}  // namespace laz
}  // namespace las
}  // namespace dw
