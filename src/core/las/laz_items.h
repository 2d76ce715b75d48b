/// \file laz_items.h
/// \brief Item models shared by the pointwise (v2) and layered (v3/v4) codecs: RGB, NIR and the
/// GPS-time sequence state. The RGB model is the same in RGB12 v2 and RGB14/RGBNIR14 v3: the low and
/// high bytes of each channel are coded apart, green and blue predicted from red's change.
#pragma once

#include <cstdint>
#include <cstring>

#include "core/las/laz_arithmetic.h"

namespace dw {
namespace las {
namespace laz {

template <typename T>
inline T loadLe(const std::uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof v);  // little-endian hosts only, as the LAS reader
  return v;
}
template <typename T>
inline void storeLe(std::uint8_t* p, T v) {
  std::memcpy(p, &v, sizeof v);
}

struct RgbModels {
  SymbolModel used, diff[6];
  void create(bool decoder) {
    used.create(128, decoder);
    for (auto& d : diff) d.create(256, decoder);
  }
  void init() {
    used.init();
    for (auto& d : diff) d.init();
  }
};

inline void decodeRgb(ArithmeticDecoder& dec, RgbModels& m, const std::uint16_t* last, std::uint16_t* item) {
  const std::uint32_t sym = dec.decodeSymbol(m.used);
  std::uint32_t r, g, b;
  r = (sym & 1) ? fold8(std::int32_t(dec.decodeSymbol(m.diff[0])) + (last[0] & 255)) : (last[0] & 0xFF);
  if (sym & 2)
    r |= std::uint32_t(fold8(std::int32_t(dec.decodeSymbol(m.diff[1])) + (last[0] >> 8))) << 8;
  else
    r |= last[0] & 0xFF00;
  if (sym & 64) {
    std::int32_t diff = std::int32_t(r & 0xFF) - (last[0] & 0xFF);
    g = (sym & 4) ? fold8(std::int32_t(dec.decodeSymbol(m.diff[2])) + clamp8(diff + (last[1] & 255)))
                  : (last[1] & 0xFF);
    if (sym & 16) {
      const std::int32_t corr = std::int32_t(dec.decodeSymbol(m.diff[4]));
      diff = (diff + (std::int32_t(g & 0xFF) - (last[1] & 0xFF))) / 2;
      b = fold8(corr + clamp8(diff + (last[2] & 255)));
    } else {
      b = last[2] & 0xFF;
    }
    diff = std::int32_t(r >> 8) - (last[0] >> 8);
    if (sym & 8)
      g |= std::uint32_t(fold8(std::int32_t(dec.decodeSymbol(m.diff[3])) + clamp8(diff + (last[1] >> 8))))
           << 8;
    else
      g |= last[1] & 0xFF00;
    if (sym & 32) {
      const std::int32_t corr = std::int32_t(dec.decodeSymbol(m.diff[5]));
      diff = (diff + (std::int32_t(g >> 8) - (last[1] >> 8))) / 2;
      b |= std::uint32_t(fold8(corr + clamp8(diff + (last[2] >> 8)))) << 8;
    } else {
      b |= last[2] & 0xFF00;
    }
  } else {
    g = b = r;
  }
  item[0] = std::uint16_t(r);
  item[1] = std::uint16_t(g);
  item[2] = std::uint16_t(b);
}

inline void encodeRgb(ArithmeticEncoder& enc, RgbModels& m, const std::uint16_t* last,
                      const std::uint16_t* item) {
  std::uint32_t sym = ((last[0] & 0x00FF) != (item[0] & 0x00FF)) << 0;
  sym |= ((last[0] & 0xFF00) != (item[0] & 0xFF00)) << 1;
  sym |= ((last[1] & 0x00FF) != (item[1] & 0x00FF)) << 2;
  sym |= ((last[1] & 0xFF00) != (item[1] & 0xFF00)) << 3;
  sym |= ((last[2] & 0x00FF) != (item[2] & 0x00FF)) << 4;
  sym |= ((last[2] & 0xFF00) != (item[2] & 0xFF00)) << 5;
  sym |= (((item[0] & 0x00FF) != (item[1] & 0x00FF)) || ((item[0] & 0x00FF) != (item[2] & 0x00FF)) ||
          ((item[0] & 0xFF00) != (item[1] & 0xFF00)) || ((item[0] & 0xFF00) != (item[2] & 0xFF00)))
         << 6;
  enc.encodeSymbol(m.used, sym);
  std::int32_t diff_l = 0, diff_h = 0;
  if (sym & 1) {
    diff_l = std::int32_t(item[0] & 255) - (last[0] & 255);
    enc.encodeSymbol(m.diff[0], fold8(diff_l));
  }
  if (sym & 2) {
    diff_h = std::int32_t(item[0] >> 8) - (last[0] >> 8);
    enc.encodeSymbol(m.diff[1], fold8(diff_h));
  }
  if (!(sym & 64)) return;
  if (sym & 4)
    enc.encodeSymbol(m.diff[2], fold8(std::int32_t(item[1] & 255) - clamp8(diff_l + (last[1] & 255))));
  if (sym & 16) {
    diff_l = (diff_l + std::int32_t(item[1] & 255) - (last[1] & 255)) / 2;
    enc.encodeSymbol(m.diff[4], fold8(std::int32_t(item[2] & 255) - clamp8(diff_l + (last[2] & 255))));
  }
  if (sym & 8)
    enc.encodeSymbol(m.diff[3], fold8(std::int32_t(item[1] >> 8) - clamp8(diff_h + (last[1] >> 8))));
  if (sym & 32) {
    diff_h = (diff_h + std::int32_t(item[1] >> 8) - (last[1] >> 8)) / 2;
    enc.encodeSymbol(m.diff[5], fold8(std::int32_t(item[2] >> 8) - clamp8(diff_h + (last[2] >> 8))));
  }
}

struct NirModels {
  SymbolModel used, diff[2];
  void create(bool decoder) {
    used.create(4, decoder);
    diff[0].create(256, decoder);
    diff[1].create(256, decoder);
  }
  void init() {
    used.init();
    diff[0].init();
    diff[1].init();
  }
};

inline std::uint16_t decodeNir(ArithmeticDecoder& dec, NirModels& m, std::uint16_t last) {
  const std::uint32_t sym = dec.decodeSymbol(m.used);
  std::uint32_t v =
      (sym & 1) ? fold8(std::int32_t(dec.decodeSymbol(m.diff[0])) + (last & 255)) : (last & 0xFF);
  if (sym & 2)
    v |= std::uint32_t(fold8(std::int32_t(dec.decodeSymbol(m.diff[1])) + (last >> 8))) << 8;
  else
    v |= last & 0xFF00;
  return std::uint16_t(v);
}

inline void encodeNir(ArithmeticEncoder& enc, NirModels& m, std::uint16_t last, std::uint16_t item) {
  const std::uint32_t sym =
      ((last & 0x00FF) != (item & 0x00FF)) | (((last & 0xFF00) != (item & 0xFF00)) << 1);
  enc.encodeSymbol(m.used, sym);
  if (sym & 1) enc.encodeSymbol(m.diff[0], fold8(std::int32_t(item & 255) - (last & 255)));
  if (sym & 2) enc.encodeSymbol(m.diff[1], fold8(std::int32_t(item >> 8) - (last >> 8)));
}

/// GPS time as LASzip codes it: the double's bits as a 64-bit integer, in up to four interleaved
/// sequences, each predicted by a multiple of its last difference.
constexpr std::int32_t kGpsMulti = 500;
constexpr std::int32_t kGpsMultiMinus = -10;

struct GpsState {
  std::uint32_t last = 0, next = 0;
  std::int64_t last_gps[4] = {0, 0, 0, 0};
  std::int32_t last_diff[4] = {0, 0, 0, 0};
  std::int32_t extreme[4] = {0, 0, 0, 0};
  void init(std::int64_t first) {
    last = next = 0;
    for (int i = 0; i < 4; ++i) last_gps[i] = last_diff[i] = extreme[i] = 0;
    last_gps[0] = first;
  }
};

inline std::int32_t wrapMul(std::int32_t a, std::int32_t b) {
  return std::int32_t(std::uint32_t(a) * std::uint32_t(b));
}
inline std::int64_t wrapAdd(std::int64_t a, std::int64_t b) {
  return std::int64_t(std::uint64_t(a) + std::uint64_t(b));
}

/// Whether the 64-bit difference fits 32 bits; `out` receives it.
inline bool fits32(std::int64_t a, std::int64_t b, std::int32_t& out) {
  const std::int64_t d = std::int64_t(std::uint64_t(a) - std::uint64_t(b));
  out = std::int32_t(d);
  return d == std::int64_t(out);
}

/// The multiplier symbol for a 32-bit difference `diff` with last difference `last` (nonzero), and
/// the codec context; updates `last`/`extreme` as LASzip does.
struct GpsMultiChoice {
  std::int32_t symbol, pred;
  unsigned context;
  bool extreme;
};
inline GpsMultiChoice chooseGpsMulti(std::int32_t diff, std::int32_t last) {
  const float f = float(diff) / float(last);
  std::int32_t multi;
  if (!(f < 1e9f && f > -1e9f))
    multi = f > 0 ? kGpsMulti : kGpsMultiMinus;
  else
    multi = f >= 0 ? std::int32_t(f + 0.5f) : std::int32_t(f - 0.5f);
  if (multi == 1) return {1, last, 1, false};
  if (multi > 0) {
    if (multi < kGpsMulti) return {multi, wrapMul(multi, last), multi < 10 ? 2u : 3u, false};
    return {kGpsMulti, wrapMul(kGpsMulti, last), 4, true};
  }
  if (multi < 0) {
    if (multi > kGpsMultiMinus) return {kGpsMulti - multi, wrapMul(multi, last), 5, false};
    return {kGpsMulti - kGpsMultiMinus, wrapMul(kGpsMultiMinus, last), 6, true};
  }
  return {0, 0, 7, true};
}

/// Decodes the residual for multiplier symbol `multi` (< code_full, != 1) of sequence s.last and
/// applies it.
inline void decodeGpsMulti(ArithmeticDecoder& dec, IntegerCodec& ic, GpsState& s, std::int32_t multi) {
  const std::uint32_t L = s.last;
  std::int32_t diff;
  bool extreme = false;
  if (multi == 0) {
    diff = ic.decompress(dec, 0, 7);
    extreme = true;
  } else if (multi < kGpsMulti) {
    diff = ic.decompress(dec, wrapMul(multi, s.last_diff[L]), multi < 10 ? 2 : 3);
  } else if (multi == kGpsMulti) {
    diff = ic.decompress(dec, wrapMul(kGpsMulti, s.last_diff[L]), 4);
    extreme = true;
  } else {
    multi = kGpsMulti - multi;
    if (multi > kGpsMultiMinus) {
      diff = ic.decompress(dec, wrapMul(multi, s.last_diff[L]), 5);
    } else {
      diff = ic.decompress(dec, wrapMul(kGpsMultiMinus, s.last_diff[L]), 6);
      extreme = true;
    }
  }
  if (extreme && ++s.extreme[L] > 3) {
    s.last_diff[L] = diff;
    s.extreme[L] = 0;
  }
  s.last_gps[L] = wrapAdd(s.last_gps[L], diff);
}

/// A new sequence: the high 32 bits predicted from the current sequence's, the low 32 raw.
inline void decodeGpsFull(ArithmeticDecoder& dec, IntegerCodec& ic, GpsState& s) {
  s.next = (s.next + 1) & 3;
  const std::int32_t high = ic.decompress(dec, std::int32_t(std::uint64_t(s.last_gps[s.last]) >> 32), 8);
  const std::uint64_t v = (std::uint64_t(std::uint32_t(high)) << 32) | dec.readInt();
  s.last_gps[s.next] = std::int64_t(v);
  s.last = s.next;
  s.last_diff[s.last] = 0;
  s.extreme[s.last] = 0;
}
inline void encodeGpsFull(ArithmeticEncoder& enc, IntegerCodec& ic, GpsState& s, std::int64_t t) {
  ic.compress(enc, std::int32_t(std::uint64_t(s.last_gps[s.last]) >> 32),
              std::int32_t(std::uint64_t(t) >> 32), 8);
  enc.writeInt(std::uint32_t(std::uint64_t(t)));
  s.next = (s.next + 1) & 3;
  s.last = s.next;
  s.last_diff[s.last] = 0;
  s.extreme[s.last] = 0;
}

/// Encodes 32-bit difference `diff` of sequence s.last given its nonzero last difference.
inline void encodeGpsMulti(ArithmeticEncoder& enc, SymbolModel& m_multi, IntegerCodec& ic, GpsState& s,
                           std::int32_t diff) {
  const std::uint32_t L = s.last;
  const GpsMultiChoice c = chooseGpsMulti(diff, s.last_diff[L]);
  enc.encodeSymbol(m_multi, std::uint32_t(c.symbol));
  ic.compress(enc, c.pred, diff, c.context);
  if (c.symbol == 1) {
    s.extreme[L] = 0;
  } else if (c.extreme && ++s.extreme[L] > 3) {
    s.last_diff[L] = diff;
    s.extreme[L] = 0;
  }
}

}  // namespace laz
}  // namespace las
}  // namespace dw
