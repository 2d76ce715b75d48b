/// \file laz_layered.cpp
/// \brief LASzip's layered chunk codec of LAS 1.4 (point formats 6-8): POINT14, RGB14, RGBNIR14 and
/// BYTE14 (versions 3 and 4, which code alike). A chunk is the first record raw, its point count, the
/// byte size of every layer, then the layers: one arithmetic stream per attribute group, so a layer
/// whose values never change within the chunk is empty. Each of the four scanner channels has its own
/// context (models and last point); a channel's context starts as a copy of the one the point
/// switched from.
#include <stdexcept>
#include <string>

#include "core/las/laz_codec.h"
#include "core/las/laz_items.h"

namespace dw {
namespace las {
namespace laz {
namespace {

// The return-map and return-level tables of LASzip's v3 items (laszip_common_v3): n = number of
// returns, r = return number, both 0..15.
const std::uint8_t kReturnMap6[16][16] = {
    {0, 1, 2, 3, 4, 5, 3, 4, 4, 5, 5, 5, 5, 5, 5, 5}, {1, 0, 1, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3},
    {2, 1, 2, 4, 4, 4, 4, 4, 4, 4, 4, 3, 3, 3, 3, 3}, {3, 3, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4},
    {4, 3, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4}, {5, 3, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4},
    {3, 3, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 4}, {4, 3, 4, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4},
    {4, 3, 4, 4, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4}, {5, 3, 4, 4, 4, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4},
    {5, 3, 4, 4, 4, 4, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4}, {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 4, 4, 4},
    {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 5, 4, 4}, {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 5, 4},
    {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 5}, {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5}};

/// min(|n - r|, 7): the penetration level that selects the Z prediction.
inline unsigned returnLevel8(unsigned n, unsigned r) {
  const unsigned d = n > r ? n - r : r - n;
  return d < 7 ? d : 7;
}

constexpr unsigned kPoint14Size = 30;

/// The fields of a format-6 record that the POINT14 model predicts.
struct Point14 {
  std::int32_t X, Y, Z;
  std::uint16_t intensity;
  std::uint8_t r, n, class_flags, channel, scan_dir, edge, classification, user_data;
  std::int16_t scan_angle;
  std::uint16_t psid;
  std::int64_t gps;  ///< the double's bits
  bool gps_change;
  std::uint32_t flags() const {
    return (std::uint32_t(edge) << 5) | (std::uint32_t(scan_dir) << 4) | class_flags;
  }
};

void loadPoint14(const std::uint8_t* p, Point14& q) {
  q.X = loadLe<std::int32_t>(p);
  q.Y = loadLe<std::int32_t>(p + 4);
  q.Z = loadLe<std::int32_t>(p + 8);
  q.intensity = loadLe<std::uint16_t>(p + 12);
  q.r = p[14] & 15;
  q.n = p[14] >> 4;
  q.class_flags = p[15] & 15;
  q.channel = (p[15] >> 4) & 3;
  q.scan_dir = (p[15] >> 6) & 1;
  q.edge = p[15] >> 7;
  q.classification = p[16];
  q.user_data = p[17];
  q.scan_angle = loadLe<std::int16_t>(p + 18);
  q.psid = loadLe<std::uint16_t>(p + 20);
  q.gps = loadLe<std::int64_t>(p + 22);
  q.gps_change = false;
}

void storePoint14(const Point14& q, std::uint8_t* p) {
  storeLe(p, q.X);
  storeLe(p + 4, q.Y);
  storeLe(p + 8, q.Z);
  storeLe(p + 12, q.intensity);
  p[14] = std::uint8_t(q.r | (q.n << 4));
  p[15] = std::uint8_t(q.class_flags | (q.channel << 4) | (q.scan_dir << 6) | (q.edge << 7));
  p[16] = q.classification;
  p[17] = q.user_data;
  storeLe(p + 18, q.scan_angle);
  storeLe(p + 20, q.psid);
  storeLe(p + 22, q.gps);
}

/// Models of one scanner channel. Models LASzip creates on first use are created on first use here
/// too; all that exist are reset when a chunk starts (which is the same as creating them then).
struct Context14 {
  bool unused = true, created = false;
  Point14 last{};
  std::uint16_t last_intensity[8];
  StreamingMedian5 median_x[12], median_y[12];
  std::int32_t last_z[8];
  SymbolModel m_changed[8], m_channel, m_n[16], m_r_gps_same, m_r[16];
  IntegerCodec ic_dx, ic_dy, ic_z;
  SymbolModel m_class[64], m_flags[64], m_user[64];
  IntegerCodec ic_intensity, ic_scan_angle, ic_psid;
  GpsState gps;
  SymbolModel m_gps_multi, m_gps_0diff;
  IntegerCodec ic_gps;

  void start(const Point14& from, bool decoder) {
    if (!created) {
      for (auto& m : m_changed) m.create(128, decoder);
      m_channel.create(3, decoder);
      m_r_gps_same.create(13, decoder);
      ic_dx.create(32, 2, decoder);
      ic_dy.create(32, 22, decoder);
      ic_z.create(32, 20, decoder);
      ic_intensity.create(16, 4, decoder);
      ic_scan_angle.create(16, 2, decoder);
      ic_psid.create(16, 1, decoder);
      m_gps_multi.create(kGpsMulti - kGpsMultiMinus + 5, decoder);
      m_gps_0diff.create(5, decoder);
      ic_gps.create(32, 9, decoder);
      created = true;
    } else {
      for (auto& m : m_changed) m.init();
      m_channel.init();
      m_r_gps_same.init();
      ic_dx.init();
      ic_dy.init();
      ic_z.init();
      ic_intensity.init();
      ic_scan_angle.init();
      ic_psid.init();
      m_gps_multi.init();
      m_gps_0diff.init();
      ic_gps.init();
    }
    for (int i = 0; i < 16; ++i) {
      if (m_n[i].created()) m_n[i].init();
      if (m_r[i].created()) m_r[i].init();
    }
    for (int i = 0; i < 64; ++i) {
      if (m_class[i].created()) m_class[i].init();
      if (m_flags[i].created()) m_flags[i].init();
      if (m_user[i].created()) m_user[i].init();
    }
    for (int i = 0; i < 12; ++i) {
      median_x[i].init();
      median_y[i].init();
    }
    for (int i = 0; i < 8; ++i) {
      last_z[i] = from.Z;
      last_intensity[i] = from.intensity;
    }
    gps.init(from.gps);
    last = from;
    last.gps_change = false;
    unused = false;
  }
};

inline SymbolModel& lazyModel(SymbolModel& m, std::uint32_t symbols, bool decoder) {
  if (!m.created()) m.create(symbols, decoder);
  return m;
}

/// RGB/NIR and extra-byte contexts per scanner channel.
struct ContextRgb {
  bool unused = true, created = false;
  std::uint16_t last[4];
  RgbModels rgb;
  NirModels nir;
  void start(const std::uint16_t* from, bool decoder) {
    if (!created) {
      rgb.create(decoder);
      nir.create(decoder);
      created = true;
    } else {
      rgb.init();
      nir.init();
    }
    std::memcpy(last, from, sizeof last);
    unused = false;
  }
};

struct ContextBytes {
  bool unused = true;
  std::vector<std::uint8_t> last;
  std::vector<SymbolModel> models;
  void start(const std::uint8_t* from, std::size_t n, bool decoder) {
    if (models.size() != n) {
      models.assign(n, SymbolModel());
      for (auto& m : models) m.create(256, decoder);
    } else {
      for (auto& m : models) m.init();
    }
    last.assign(from, from + n);
    unused = false;
  }
};

/// The layers of POINT14, in stream order.
enum Layer14 {
  kXY,
  kZ,
  kClass,
  kFlags,
  kIntensity,
  kScanAngle,
  kUserData,
  kPointSource,
  kGpsTime,
  kLayers14
};

struct Layout {
  bool rgb = false, nir = false;
  unsigned extra = 0;
  unsigned layerCount() const { return kLayers14 + (rgb ? 1 : 0) + (nir ? 1 : 0) + extra; }
};

Layout layoutOf(const std::vector<Item>& items, unsigned record_length) {
  Layout L;
  unsigned size = 0;
  for (const Item& it : items) {
    size += it.size;
    if (it.type == kRgb14) L.rgb = true;
    if (it.type == kRgbNir14) L.rgb = L.nir = true;
    if (it.type == kByte14) L.extra = it.size;
  }
  if (size != record_length) throw std::runtime_error("LASzip items do not add up to the record length");
  return L;
}

class LayeredDecoder final : public ChunkDecoder {
 public:
  LayeredDecoder(const std::vector<Item>& items, unsigned record_length)
      : layout_(layoutOf(items, record_length)), record_length_(record_length) {}

  void decode(const std::uint8_t* bytes, std::size_t n, std::uint64_t count, std::uint8_t* out) override {
    if (count == 0) return;
    readHeader(bytes, n, count);
    startContexts(out);
    const unsigned rgb_at = kPoint14Size,
                   extra_at = kPoint14Size + (layout_.rgb ? 6 : 0) + (layout_.nir ? 2 : 0);
    for (std::uint64_t i = 1; i < count; ++i) {
      std::uint8_t* rec = out + i * record_length_;
      readPoint14(rec);
      if (layout_.rgb) readRgb(rec + rgb_at);
      if (layout_.extra) readBytes(rec + extra_at);
    }
    checkStreams();
  }

 private:
  /// The chunk's raw first record, its count and its layer sizes; sets up one decoder per layer.
  void readHeader(const std::uint8_t* bytes, std::size_t n, std::uint64_t count) {
    const unsigned layers = layout_.layerCount();
    const std::size_t head = record_length_ + 4 + 4 * std::size_t(layers);
    if (n < head)
      throw std::runtime_error("chunk of " + std::to_string(n) + " bytes is shorter than its header");
    first_ = bytes;
    const std::uint32_t stored = loadLe<std::uint32_t>(bytes + record_length_);
    if (stored != count)
      throw std::runtime_error("chunk holds " + std::to_string(stored) + " points, the chunk table says " +
                               std::to_string(count));
    std::size_t at = head;
    size_.assign(layers, 0);
    dec_.resize(layers);
    for (unsigned k = 0; k < layers; ++k)
      size_[k] = loadLe<std::uint32_t>(bytes + record_length_ + 4 + 4 * k);
    for (unsigned k = 0; k < layers; ++k) {
      if (size_[k] > n - at)
        throw std::runtime_error("layer " + std::to_string(k) + " of " + std::to_string(size_[k]) +
                                 " bytes runs past the chunk's end");
      if (size_[k] || k == kXY) dec_[k].init(bytes + at, size_[k]);
      at += size_[k];
    }
  }

  void startContexts(std::uint8_t* out) {
    std::memcpy(out, first_, record_length_);
    Point14 p;
    loadPoint14(first_, p);
    for (auto& c : ctx_) c.unused = true;
    for (auto& c : rgb_) c.unused = true;
    for (auto& c : bytes_) c.unused = true;
    cur_ = rgb_cur_ = bytes_cur_ = p.channel;
    ctx_[cur_].start(p, true);
    std::uint16_t rgbn[4] = {0, 0, 0, 0};
    if (layout_.rgb)
      for (int k = 0; k < (layout_.nir ? 4 : 3); ++k)
        rgbn[k] = loadLe<std::uint16_t>(first_ + kPoint14Size + 2 * k);
    rgb_[cur_].start(rgbn, true);
    const unsigned extra_at = kPoint14Size + (layout_.rgb ? 6 : 0) + (layout_.nir ? 2 : 0);
    bytes_[cur_].start(first_ + extra_at, layout_.extra, true);
  }

  void checkStreams() {
    for (unsigned k = 0; k < dec_.size(); ++k) {
      if (!size_[k] && k != kXY) continue;
      if (dec_[k].corrupt()) throw std::runtime_error("layer " + std::to_string(k) + " is corrupt");
      if (dec_[k].overrun() > 4)
        throw std::runtime_error("the arithmetic stream of layer " + std::to_string(k) + " runs out (" +
                                 std::to_string(size_[k]) + " bytes)");
    }
  }

  bool changed(unsigned layer) const { return size_[layer] != 0; }

  /// The channel/returns/XY layer decides the context of everything else (lpr, cpr, gps_change).
  void readPoint14(std::uint8_t* rec);
  void readGps(Context14& c);
  void readRgb(std::uint8_t* rec);
  void readBytes(std::uint8_t* rec);

  Layout layout_;
  unsigned record_length_;
  const std::uint8_t* first_ = nullptr;
  std::vector<std::uint32_t> size_;
  std::vector<ArithmeticDecoder> dec_;
  Context14 ctx_[4];
  ContextRgb rgb_[4];
  ContextBytes bytes_[4];
  unsigned cur_ = 0, rgb_cur_ = 0, bytes_cur_ = 0;
};

void LayeredDecoder::readPoint14(std::uint8_t* rec) {
  ArithmeticDecoder& dxy = dec_[kXY];
  Context14* c = &ctx_[cur_];
  Point14* last = &c->last;
  const unsigned lpr =
      (last->r == 1 ? 1u : 0u) + (last->r >= last->n ? 2u : 0u) + (last->gps_change ? 4u : 0u);
  const std::uint32_t changed_values = dxy.decodeSymbol(c->m_changed[lpr]);
  if (changed_values & (1u << 6)) {
    const unsigned channel = (cur_ + dxy.decodeSymbol(c->m_channel) + 1) % 4;
    if (ctx_[channel].unused) ctx_[channel].start(*last, true);
    cur_ = channel;
    c = &ctx_[cur_];
    last = &c->last;
    last->channel = std::uint8_t(channel);
  }
  const bool psid_change = changed_values & (1u << 5);
  const bool gps_change = changed_values & (1u << 4);
  const bool scan_change = changed_values & (1u << 3);
  const unsigned last_n = last->n, last_r = last->r;
  unsigned n = last_n, r = last_r;
  if (changed_values & (1u << 2))
    n = last->n = std::uint8_t(dxy.decodeSymbol(lazyModel(c->m_n[last_n], 16, true)));
  switch (changed_values & 3) {
    case 0: break;
    case 1: r = (last_r + 1) % 16; break;
    case 2: r = (last_r + 15) % 16; break;
    default:
      if (gps_change)
        r = dxy.decodeSymbol(lazyModel(c->m_r[last_r], 16, true));
      else
        r = (last_r + dxy.decodeSymbol(c->m_r_gps_same) + 2) % 16;
  }
  last->r = std::uint8_t(r);
  const unsigned m = kReturnMap6[n][r], l = returnLevel8(n, r);
  const unsigned cpr = (r == 1 ? 2u : 0u) + (r >= n ? 1u : 0u);
  const unsigned slot = (m << 1) | (gps_change ? 1u : 0u);

  std::int32_t diff = c->ic_dx.decompress(dxy, c->median_x[slot].get(), n == 1);
  last->X = std::int32_t(std::uint32_t(last->X) + std::uint32_t(diff));
  c->median_x[slot].add(diff);
  unsigned k = c->ic_dx.k();
  diff = c->ic_dy.decompress(dxy, c->median_y[slot].get(), (n == 1) + (k < 20 ? (k & ~1u) : 20));
  last->Y = std::int32_t(std::uint32_t(last->Y) + std::uint32_t(diff));
  c->median_y[slot].add(diff);

  if (changed(kZ)) {
    k = (c->ic_dx.k() + c->ic_dy.k()) / 2;
    last->Z = c->ic_z.decompress(dec_[kZ], c->last_z[l], (n == 1) + (k < 18 ? (k & ~1u) : 18));
    c->last_z[l] = last->Z;
  }
  if (changed(kClass)) {
    const unsigned ccc = ((last->classification & 0x1Fu) << 1) + (cpr == 3 ? 1u : 0u);
    last->classification = std::uint8_t(dec_[kClass].decodeSymbol(lazyModel(c->m_class[ccc], 256, true)));
  }
  if (changed(kFlags)) {
    const std::uint32_t f = dec_[kFlags].decodeSymbol(lazyModel(c->m_flags[last->flags()], 64, true));
    last->edge = (f >> 5) & 1;
    last->scan_dir = (f >> 4) & 1;
    last->class_flags = f & 15;
  }
  if (changed(kIntensity)) {
    const unsigned s = (cpr << 1) | (gps_change ? 1u : 0u);
    const std::uint16_t v =
        std::uint16_t(c->ic_intensity.decompress(dec_[kIntensity], c->last_intensity[s], cpr));
    c->last_intensity[s] = v;
    last->intensity = v;
  }
  if (changed(kScanAngle) && scan_change)
    last->scan_angle =
        std::int16_t(c->ic_scan_angle.decompress(dec_[kScanAngle], last->scan_angle, gps_change));
  if (changed(kUserData))
    last->user_data =
        std::uint8_t(dec_[kUserData].decodeSymbol(lazyModel(c->m_user[last->user_data / 4], 256, true)));
  if (changed(kPointSource) && psid_change)
    last->psid = std::uint16_t(c->ic_psid.decompress(dec_[kPointSource], last->psid));
  if (changed(kGpsTime) && gps_change) {
    readGps(*c);
    last->gps = c->gps.last_gps[c->gps.last];
  }
  storePoint14(*last, rec);
  last->gps_change = gps_change;
}

void LayeredDecoder::readGps(Context14& c) {
  ArithmeticDecoder& dec = dec_[kGpsTime];
  GpsState& s = c.gps;
  constexpr std::int32_t code_full = kGpsMulti - kGpsMultiMinus + 1;
  // The encoder switches sequence at most once per point; more is a corrupt stream.
  for (int attempt = 0; attempt < 4; ++attempt) {
    if (s.last_diff[s.last] == 0) {
      const std::uint32_t multi = dec.decodeSymbol(c.m_gps_0diff);
      if (multi == 0) {
        s.last_diff[s.last] = c.ic_gps.decompress(dec, 0, 0);
        s.last_gps[s.last] = wrapAdd(s.last_gps[s.last], s.last_diff[s.last]);
        s.extreme[s.last] = 0;
        return;
      }
      if (multi == 1) {
        decodeGpsFull(dec, c.ic_gps, s);
        return;
      }
      s.last = (s.last + multi - 1) & 3;
      continue;
    }
    const std::int32_t multi = std::int32_t(dec.decodeSymbol(c.m_gps_multi));
    if (multi == 1) {
      s.last_gps[s.last] = wrapAdd(s.last_gps[s.last], c.ic_gps.decompress(dec, s.last_diff[s.last], 1));
      s.extreme[s.last] = 0;
      return;
    }
    if (multi < code_full) {
      decodeGpsMulti(dec, c.ic_gps, s, multi);
      return;
    }
    if (multi == code_full) {
      decodeGpsFull(dec, c.ic_gps, s);
      return;
    }
    s.last = (s.last + std::uint32_t(multi - code_full)) & 3;
  }
  dec.markCorrupt();
}

void LayeredDecoder::readRgb(std::uint8_t* rec) {
  if (rgb_cur_ != cur_) {
    const std::uint16_t* prev = rgb_[rgb_cur_].last;
    rgb_cur_ = cur_;
    if (rgb_[rgb_cur_].unused) rgb_[rgb_cur_].start(prev, true);
  }
  ContextRgb& c = rgb_[rgb_cur_];
  const unsigned rgb_layer = kLayers14, nir_layer = kLayers14 + 1;
  if (changed(rgb_layer)) {
    std::uint16_t v[3];
    decodeRgb(dec_[rgb_layer], c.rgb, c.last, v);
    std::memcpy(c.last, v, sizeof v);
  }
  if (layout_.nir && changed(nir_layer)) c.last[3] = decodeNir(dec_[nir_layer], c.nir, c.last[3]);
  for (int k = 0; k < (layout_.nir ? 4 : 3); ++k) storeLe(rec + 2 * k, c.last[k]);
}

void LayeredDecoder::readBytes(std::uint8_t* rec) {
  if (bytes_cur_ != cur_) {
    const unsigned prev = bytes_cur_;
    bytes_cur_ = cur_;
    if (bytes_[bytes_cur_].unused) bytes_[bytes_cur_].start(bytes_[prev].last.data(), layout_.extra, true);
  }
  ContextBytes& c = bytes_[bytes_cur_];
  const unsigned first = kLayers14 + (layout_.rgb ? 1 : 0) + (layout_.nir ? 1 : 0);
  for (unsigned i = 0; i < layout_.extra; ++i) {
    if (changed(first + i))
      c.last[i] = fold8(std::int32_t(c.last[i]) + std::int32_t(dec_[first + i].decodeSymbol(c.models[i])));
    rec[i] = c.last[i];
  }
}

// ------------------------------------------------------------------------------------------------
// Encoder: the mirror of the decoder. Every layer is coded; a layer whose values never differ from
// the context's last point is dropped at the chunk's end (size 0), which the decoder reads as
// "unchanged", since nothing else depends on that layer's stream.

class LayeredEncoder final : public ChunkEncoder {
 public:
  LayeredEncoder(const std::vector<Item>& items, unsigned record_length)
      : layout_(layoutOf(items, record_length)), record_length_(record_length) {}

  void encode(const std::uint8_t* records, std::size_t count, std::vector<std::uint8_t>& out) override {
    if (count == 0) return;
    const unsigned layers = layout_.layerCount();
    enc_.resize(layers);
    changed_.assign(layers, false);
    for (auto& e : enc_) e.init();
    startContexts(records);
    const unsigned extra_at = kPoint14Size + (layout_.rgb ? 6 : 0) + (layout_.nir ? 2 : 0);
    for (std::size_t i = 1; i < count; ++i) {
      const std::uint8_t* rec = records + i * record_length_;
      writePoint14(rec);
      if (layout_.rgb) writeRgb(rec + kPoint14Size);
      if (layout_.extra) writeBytes(rec + extra_at);
    }
    out.insert(out.end(), records, records + record_length_);
    const std::uint32_t n32 = std::uint32_t(count);
    const std::size_t at = out.size();
    out.resize(at + 4 + 4 * std::size_t(layers));
    storeLe(out.data() + at, n32);
    changed_[kXY] = true;
    changed_[kZ] = true;  // LASzip always keeps the Z layer
    for (unsigned k = 0; k < layers; ++k) {
      std::uint32_t size = 0;
      if (changed_[k]) {
        enc_[k].done();
        size = std::uint32_t(enc_[k].bytes().size());
      }
      storeLe(out.data() + at + 4 + 4 * k, size);
    }
    for (unsigned k = 0; k < layers; ++k)
      if (changed_[k]) out.insert(out.end(), enc_[k].bytes().begin(), enc_[k].bytes().end());
  }

 private:
  void startContexts(const std::uint8_t* first) {
    Point14 p;
    loadPoint14(first, p);
    for (auto& c : ctx_) c.unused = true;
    for (auto& c : rgb_) c.unused = true;
    for (auto& c : bytes_) c.unused = true;
    cur_ = rgb_cur_ = bytes_cur_ = p.channel;
    ctx_[cur_].start(p, false);
    std::uint16_t rgbn[4] = {0, 0, 0, 0};
    if (layout_.rgb)
      for (int k = 0; k < (layout_.nir ? 4 : 3); ++k)
        rgbn[k] = loadLe<std::uint16_t>(first + kPoint14Size + 2 * k);
    rgb_[cur_].start(rgbn, false);
    const unsigned extra_at = kPoint14Size + (layout_.rgb ? 6 : 0) + (layout_.nir ? 2 : 0);
    bytes_[cur_].start(first + extra_at, layout_.extra, false);
  }
  void writePoint14(const std::uint8_t* rec);
  void writeGps(Context14& c, std::int64_t t);
  void writeRgb(const std::uint8_t* rec);
  void writeBytes(const std::uint8_t* rec);

  Layout layout_;
  unsigned record_length_;
  std::vector<ArithmeticEncoder> enc_;
  std::vector<bool> changed_;
  Context14 ctx_[4];
  ContextRgb rgb_[4];
  ContextBytes bytes_[4];
  unsigned cur_ = 0, rgb_cur_ = 0, bytes_cur_ = 0;
};

void LayeredEncoder::writePoint14(const std::uint8_t* rec) {
  Point14 item;
  loadPoint14(rec, item);
  ArithmeticEncoder& exy = enc_[kXY];
  Context14* c = &ctx_[cur_];
  const Point14* last = &c->last;
  const unsigned lpr =
      (last->r == 1 ? 1u : 0u) + (last->r >= last->n ? 2u : 0u) + (last->gps_change ? 4u : 0u);
  const unsigned channel = item.channel;
  if (channel != cur_ && !ctx_[channel].unused) last = &ctx_[channel].last;
  const bool psid_change = item.psid != last->psid;
  const bool gps_change = item.gps != last->gps;
  const bool scan_change = item.scan_angle != last->scan_angle;
  const unsigned last_n = last->n, last_r = last->r, n = item.n, r = item.r;
  std::uint32_t changed_values = (std::uint32_t(channel != cur_) << 6) | (std::uint32_t(psid_change) << 5) |
                                 (std::uint32_t(gps_change) << 4) | (std::uint32_t(scan_change) << 3) |
                                 (std::uint32_t(n != last_n) << 2);
  if (r != last_r) {
    if (r == (last_r + 1) % 16)
      changed_values |= 1;
    else if (r == (last_r + 15) % 16)
      changed_values |= 2;
    else
      changed_values |= 3;
  }
  exy.encodeSymbol(c->m_changed[lpr], changed_values);
  if (changed_values & (1u << 6)) {
    const int diff = int(channel) - int(cur_);
    exy.encodeSymbol(c->m_channel, std::uint32_t(diff > 0 ? diff - 1 : diff - 1 + 4));
    if (ctx_[channel].unused) ctx_[channel].start(c->last, false);
    cur_ = channel;
    c = &ctx_[cur_];
  }
  Point14& lastp = c->last;
  if (changed_values & (1u << 2)) exy.encodeSymbol(lazyModel(c->m_n[last_n], 16, false), n);
  if ((changed_values & 3) == 3) {
    if (gps_change)
      exy.encodeSymbol(lazyModel(c->m_r[last_r], 16, false), r);
    else
      exy.encodeSymbol(c->m_r_gps_same, (r + 16 - last_r - 2) % 16);
  }
  const unsigned m = kReturnMap6[n][r], l = returnLevel8(n, r);
  const unsigned cpr = (r == 1 ? 2u : 0u) + (r >= n ? 1u : 0u);
  const unsigned slot = (m << 1) | (gps_change ? 1u : 0u);

  std::int32_t diff = std::int32_t(std::uint32_t(item.X) - std::uint32_t(lastp.X));
  c->ic_dx.compress(exy, c->median_x[slot].get(), diff, n == 1);
  c->median_x[slot].add(diff);
  unsigned k = c->ic_dx.k();
  diff = std::int32_t(std::uint32_t(item.Y) - std::uint32_t(lastp.Y));
  c->ic_dy.compress(exy, c->median_y[slot].get(), diff, (n == 1) + (k < 20 ? (k & ~1u) : 20));
  c->median_y[slot].add(diff);

  k = (c->ic_dx.k() + c->ic_dy.k()) / 2;
  c->ic_z.compress(enc_[kZ], c->last_z[l], item.Z, (n == 1) + (k < 18 ? (k & ~1u) : 18));
  c->last_z[l] = item.Z;
  if (item.Z != lastp.Z) changed_[kZ] = true;

  const unsigned ccc = ((lastp.classification & 0x1Fu) << 1) + (cpr == 3 ? 1u : 0u);
  enc_[kClass].encodeSymbol(lazyModel(c->m_class[ccc], 256, false), item.classification);
  if (item.classification != lastp.classification) changed_[kClass] = true;

  enc_[kFlags].encodeSymbol(lazyModel(c->m_flags[lastp.flags()], 64, false), item.flags());
  if (item.flags() != lastp.flags()) changed_[kFlags] = true;

  const unsigned s = (cpr << 1) | (gps_change ? 1u : 0u);
  c->ic_intensity.compress(enc_[kIntensity], c->last_intensity[s], item.intensity, cpr);
  c->last_intensity[s] = item.intensity;
  if (item.intensity != lastp.intensity) changed_[kIntensity] = true;

  if (scan_change) {
    c->ic_scan_angle.compress(enc_[kScanAngle], lastp.scan_angle, item.scan_angle, gps_change);
    changed_[kScanAngle] = true;
  }
  enc_[kUserData].encodeSymbol(lazyModel(c->m_user[lastp.user_data / 4], 256, false), item.user_data);
  if (item.user_data != lastp.user_data) changed_[kUserData] = true;
  if (psid_change) {
    c->ic_psid.compress(enc_[kPointSource], lastp.psid, item.psid);
    changed_[kPointSource] = true;
  }
  if (gps_change) {
    writeGps(*c, item.gps);
    changed_[kGpsTime] = true;
  }
  lastp = item;
  lastp.gps_change = gps_change;
}

void LayeredEncoder::writeGps(Context14& c, std::int64_t t) {
  ArithmeticEncoder& enc = enc_[kGpsTime];
  GpsState& s = c.gps;
  constexpr std::int32_t code_full = kGpsMulti - kGpsMultiMinus + 1;
  const bool zero_diff = s.last_diff[s.last] == 0;
  std::int32_t diff;
  if (fits32(t, s.last_gps[s.last], diff)) {
    if (zero_diff) {
      enc.encodeSymbol(c.m_gps_0diff, 0);
      c.ic_gps.compress(enc, 0, diff, 0);
      s.last_diff[s.last] = diff;
      s.extreme[s.last] = 0;
    } else {
      encodeGpsMulti(enc, c.m_gps_multi, c.ic_gps, s, diff);
    }
    s.last_gps[s.last] = t;
    return;
  }
  for (std::uint32_t i = 1; i < 4; ++i) {
    std::int32_t other;
    if (!fits32(t, s.last_gps[(s.last + i) & 3], other)) continue;
    if (zero_diff)
      enc.encodeSymbol(c.m_gps_0diff, i + 1);
    else
      enc.encodeSymbol(c.m_gps_multi, std::uint32_t(code_full) + i);
    s.last = (s.last + i) & 3;
    writeGps(c, t);
    return;
  }
  if (zero_diff)
    enc.encodeSymbol(c.m_gps_0diff, 1);
  else
    enc.encodeSymbol(c.m_gps_multi, std::uint32_t(code_full));
  encodeGpsFull(enc, c.ic_gps, s, t);
  s.last_gps[s.last] = t;
}

void LayeredEncoder::writeRgb(const std::uint8_t* rec) {
  if (rgb_cur_ != cur_) {
    const std::uint16_t* prev = rgb_[rgb_cur_].last;
    rgb_cur_ = cur_;
    if (rgb_[rgb_cur_].unused) rgb_[rgb_cur_].start(prev, false);
  }
  ContextRgb& c = rgb_[rgb_cur_];
  std::uint16_t v[4] = {0, 0, 0, 0};
  for (int k = 0; k < (layout_.nir ? 4 : 3); ++k) v[k] = loadLe<std::uint16_t>(rec + 2 * k);
  const unsigned rgb_layer = kLayers14, nir_layer = kLayers14 + 1;
  encodeRgb(enc_[rgb_layer], c.rgb, c.last, v);
  if (std::memcmp(v, c.last, 6) != 0) changed_[rgb_layer] = true;
  if (layout_.nir) {
    encodeNir(enc_[nir_layer], c.nir, c.last[3], v[3]);
    if (v[3] != c.last[3]) changed_[nir_layer] = true;
  }
  std::memcpy(c.last, v, sizeof v);
}

void LayeredEncoder::writeBytes(const std::uint8_t* rec) {
  if (bytes_cur_ != cur_) {
    const unsigned prev = bytes_cur_;
    bytes_cur_ = cur_;
    if (bytes_[bytes_cur_].unused) bytes_[bytes_cur_].start(bytes_[prev].last.data(), layout_.extra, false);
  }
  ContextBytes& c = bytes_[bytes_cur_];
  const unsigned first = kLayers14 + (layout_.rgb ? 1 : 0) + (layout_.nir ? 1 : 0);
  for (unsigned i = 0; i < layout_.extra; ++i) {
    enc_[first + i].encodeSymbol(c.models[i], fold8(std::int32_t(rec[i]) - std::int32_t(c.last[i])));
    if (rec[i] != c.last[i]) changed_[first + i] = true;
    c.last[i] = rec[i];
  }
}

}  // namespace

std::unique_ptr<ChunkDecoder> makeLayeredDecoder(const std::vector<Item>& items, unsigned record_length) {
  return std::make_unique<LayeredDecoder>(items, record_length);
}
std::unique_ptr<ChunkEncoder> makeLayeredEncoder(const std::vector<Item>& items, unsigned record_length) {
  return std::make_unique<LayeredEncoder>(items, record_length);
}

}  // namespace laz
}  // namespace las
}  // namespace dw
