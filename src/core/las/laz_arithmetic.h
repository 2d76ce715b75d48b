/// \file laz_arithmetic.h
/// \brief The entropy coder of LASzip: a 32-bit range coder (Said/Moffat style, as LASzip uses it),
/// adaptive bit and symbol models, and the integer compressor that codes a corrector
/// (value - prediction) as its bit length k followed by the k-bit offset. Every constant and update
/// rule must equal LASzip's, or the streams are a private dialect; the tests check against laz-perf.
///
/// Robustness: the decoder keeps the invariant value < length for any input bytes (it holds for every
/// step once it holds at init, which init() enforces), so corrupt bytes give wrong values, never an
/// out-of-bounds table index or an endless renormalisation. Bytes read past the end of the stream are
/// zeros and are counted, so the caller can tell a stream that ran out.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

namespace dw {
namespace las {
namespace laz {

constexpr std::uint32_t kMinLength = 0x01000000u;
constexpr std::uint32_t kMaxLength = 0xFFFFFFFFu;
constexpr unsigned kBitLengthShift = 13;
constexpr std::uint32_t kBitMaxCount = 1u << kBitLengthShift;
constexpr unsigned kSymLengthShift = 15;
constexpr std::uint32_t kSymMaxCount = 1u << kSymLengthShift;

/// Adaptive binary model (probability of a 0 in 13 bits).
struct BitModel {
  std::uint32_t bit_0_count, bit_count, bit_0_prob, bits_until_update, update_cycle;
  BitModel() { init(); }
  void init() {
    bit_0_count = 1;
    bit_count = 2;
    bit_0_prob = 1u << (kBitLengthShift - 1);
    update_cycle = bits_until_update = 4;
  }
  void update() {
    if ((bit_count += update_cycle) > kBitMaxCount) {
      bit_count = (bit_count + 1) >> 1;
      bit_0_count = (bit_0_count + 1) >> 1;
      if (bit_0_count == bit_count) ++bit_count;
    }
    const std::uint32_t scale = 0x80000000u / bit_count;
    bit_0_prob = (bit_0_count * scale) >> (31 - kBitLengthShift);
    update_cycle = (5 * update_cycle) >> 2;
    if (update_cycle > 64) update_cycle = 64;
    bits_until_update = update_cycle;
  }
};

/// Adaptive model over `symbols` symbols (2..2048). Decoders of more than 16 symbols keep LASzip's
/// lookup table, which only narrows the binary search: the decoded symbol is the same either way.
class SymbolModel {
 public:
  SymbolModel() = default;
  explicit SymbolModel(std::uint32_t symbols, bool decoder) { create(symbols, decoder); }
  void create(std::uint32_t symbols, bool decoder) {
    symbols_ = symbols;
    last_symbol_ = symbols - 1;
    table_size_ = table_shift_ = 0;
    std::size_t n = 2 * std::size_t(symbols);
    if (decoder && symbols > 16) {
      unsigned table_bits = 3;
      while (symbols > (1u << (table_bits + 2))) ++table_bits;
      table_size_ = 1u << table_bits;
      table_shift_ = kSymLengthShift - table_bits;
      n += table_size_ + 2;
    }
    store_.assign(n, 0);
    init();
  }
  bool created() const { return symbols_ != 0; }
  void init() {
    total_count_ = 0;
    update_cycle_ = symbols_;
    std::uint32_t* count = store_.data() + symbols_;
    for (std::uint32_t k = 0; k < symbols_; ++k) count[k] = 1;
    update();
    symbols_until_update_ = update_cycle_ = (symbols_ + 6) >> 1;
  }
  void update() {
    std::uint32_t* dist = store_.data();
    std::uint32_t* count = dist + symbols_;
    if ((total_count_ += update_cycle_) > kSymMaxCount) {
      total_count_ = 0;
      for (std::uint32_t n = 0; n < symbols_; ++n) total_count_ += (count[n] = (count[n] + 1) >> 1);
    }
    const std::uint32_t scale = 0x80000000u / total_count_;
    std::uint32_t sum = 0;
    if (table_size_ == 0) {
      for (std::uint32_t k = 0; k < symbols_; ++k) {
        dist[k] = (scale * sum) >> (31 - kSymLengthShift);
        sum += count[k];
      }
    } else {
      std::uint32_t* table = dist + 2 * symbols_;
      std::uint32_t s = 0;
      for (std::uint32_t k = 0; k < symbols_; ++k) {
        dist[k] = (scale * sum) >> (31 - kSymLengthShift);
        sum += count[k];
        const std::uint32_t w = dist[k] >> table_shift_;
        while (s < w) table[++s] = k - 1;
      }
      table[0] = 0;
      while (s <= table_size_) table[++s] = symbols_ - 1;
    }
    update_cycle_ = (5 * update_cycle_) >> 2;
    const std::uint32_t max_cycle = (symbols_ + 6) << 3;
    if (update_cycle_ > max_cycle) update_cycle_ = max_cycle;
    symbols_until_update_ = update_cycle_;
  }

  std::vector<std::uint32_t> store_;  // distribution[symbols], count[symbols], table[table_size + 2]
  std::uint32_t symbols_ = 0, last_symbol_ = 0, table_size_ = 0, table_shift_ = 0;
  std::uint32_t total_count_ = 0, update_cycle_ = 0, symbols_until_update_ = 0;
};

class ArithmeticDecoder {
 public:
  /// Starts decoding `n` bytes at `p` (reads the first four).
  void init(const std::uint8_t* p, std::size_t n) {
    p_ = p;
    end_ = p + n;
    overrun_ = 0;
    corrupt_ = false;
    length_ = kMaxLength;
    value_ = std::uint32_t(byte()) << 24;
    value_ |= std::uint32_t(byte()) << 16;
    value_ |= std::uint32_t(byte()) << 8;
    value_ |= std::uint32_t(byte());
    if (value_ >= length_) {  // no encoder emits this; keeps value < length from here on
      corrupt_ = true;
      value_ = length_ - 1;
    }
  }
  /// Bytes asked for beyond the end of the stream (a valid stream needs none).
  std::size_t overrun() const { return overrun_; }
  bool corrupt() const { return corrupt_; }
  void markCorrupt() { corrupt_ = true; }

  std::uint32_t decodeBit(BitModel& m) {
    const std::uint32_t x = m.bit_0_prob * (length_ >> kBitLengthShift);
    const std::uint32_t sym = value_ >= x;
    if (sym == 0) {
      length_ = x;
      ++m.bit_0_count;
    } else {
      value_ -= x;
      length_ -= x;
    }
    if (length_ < kMinLength) renorm();
    if (--m.bits_until_update == 0) m.update();
    return sym;
  }

  std::uint32_t decodeSymbol(SymbolModel& m) {
    const std::uint32_t* dist = m.store_.data();
    std::uint32_t n, sym, x, y = length_;
    if (m.table_size_) {
      const std::uint32_t dv = value_ / (length_ >>= kSymLengthShift);
      const std::uint32_t t = dv >> m.table_shift_;
      const std::uint32_t* table = dist + 2 * m.symbols_;
      sym = table[t];
      n = table[t + 1] + 1;
      while (n > sym + 1) {
        const std::uint32_t k = (sym + n) >> 1;
        if (dist[k] > dv)
          n = k;
        else
          sym = k;
      }
      x = dist[sym] * length_;
      if (sym != m.last_symbol_) y = dist[sym + 1] * length_;
    } else {
      x = sym = 0;
      length_ >>= kSymLengthShift;
      std::uint32_t k = (n = m.symbols_) >> 1;
      do {
        const std::uint32_t z = length_ * dist[k];
        if (z > value_) {
          n = k;
          y = z;
        } else {
          sym = k;
          x = z;
        }
      } while ((k = (sym + n) >> 1) != sym);
    }
    value_ -= x;
    length_ = y - x;
    if (length_ < kMinLength) renorm();
    ++m.store_[m.symbols_ + sym];
    if (--m.symbols_until_update_ == 0) m.update();
    return sym;
  }

  /// `bits` raw bits (1..32), LASzip's readBits.
  std::uint32_t readBits(unsigned bits) {
    if (bits > 19) {
      const std::uint32_t low = readShort();
      return (readBits(bits - 16) << 16) | low;
    }
    const std::uint32_t sym = value_ / (length_ >>= bits);
    value_ -= length_ * sym;
    if (length_ < kMinLength) renorm();
    return sym;
  }
  std::uint32_t readShort() {
    const std::uint32_t sym = value_ / (length_ >>= 16);
    value_ -= length_ * sym;
    if (length_ < kMinLength) renorm();
    return sym & 0xFFFFu;
  }
  std::uint32_t readInt() {
    const std::uint32_t low = readShort();
    return (readShort() << 16) | low;
  }

 private:
  std::uint8_t byte() {
    if (p_ < end_) return *p_++;
    ++overrun_;
    return 0;
  }
  void renorm() {
    do {
      value_ = (value_ << 8) | byte();
    } while ((length_ <<= 8) < kMinLength);
  }
  const std::uint8_t* p_ = nullptr;
  const std::uint8_t* end_ = nullptr;
  std::uint32_t value_ = 0, length_ = kMaxLength;
  std::size_t overrun_ = 0;
  bool corrupt_ = false;
};

/// Encoder into a growable byte buffer; done() flushes it as LASzip does (2 or 3 trailing bytes so
/// the decoder's look-ahead stays inside the stream).
class ArithmeticEncoder {
 public:
  void init() {
    out_.clear();
    base_ = 0;
    length_ = kMaxLength;
  }
  const std::vector<std::uint8_t>& bytes() const { return out_; }

  void encodeBit(BitModel& m, std::uint32_t sym) {
    const std::uint32_t x = m.bit_0_prob * (length_ >> kBitLengthShift);
    if (sym == 0) {
      length_ = x;
      ++m.bit_0_count;
    } else {
      const std::uint32_t init_base = base_;
      base_ += x;
      length_ -= x;
      if (init_base > base_) carry();
    }
    if (length_ < kMinLength) renorm();
    if (--m.bits_until_update == 0) m.update();
  }

  void encodeSymbol(SymbolModel& m, std::uint32_t sym) {
    const std::uint32_t* dist = m.store_.data();
    const std::uint32_t init_base = base_;
    if (sym == m.last_symbol_) {
      const std::uint32_t x = dist[sym] * (length_ >> kSymLengthShift);
      base_ += x;
      length_ -= x;
    } else {
      const std::uint32_t x = dist[sym] * (length_ >>= kSymLengthShift);
      base_ += x;
      length_ = dist[sym + 1] * length_ - x;
    }
    if (init_base > base_) carry();
    if (length_ < kMinLength) renorm();
    ++m.store_[m.symbols_ + sym];
    if (--m.symbols_until_update_ == 0) m.update();
  }

  void writeBits(unsigned bits, std::uint32_t sym) {
    if (bits > 19) {
      writeShort(sym & 0xFFFFu);
      sym >>= 16;
      bits -= 16;
    }
    const std::uint32_t init_base = base_;
    base_ += sym * (length_ >>= bits);
    if (init_base > base_) carry();
    if (length_ < kMinLength) renorm();
  }
  void writeShort(std::uint32_t sym) {
    const std::uint32_t init_base = base_;
    base_ += sym * (length_ >>= 16);
    if (init_base > base_) carry();
    if (length_ < kMinLength) renorm();
  }
  void writeInt(std::uint32_t v) {
    writeShort(v & 0xFFFFu);
    writeShort(v >> 16);
  }

  void done() {
    const std::uint32_t init_base = base_;
    bool another_byte = true;
    if (length_ > 2 * kMinLength) {
      base_ += kMinLength;
      length_ = kMinLength >> 1;
    } else {
      base_ += kMinLength >> 1;
      length_ = kMinLength >> 9;
      another_byte = false;
    }
    if (init_base > base_) carry();
    renorm();
    out_.push_back(0);
    out_.push_back(0);
    if (another_byte) out_.push_back(0);
  }

 private:
  void carry() {
    std::size_t i = out_.size();
    while (i > 0 && out_[i - 1] == 0xFF) out_[--i] = 0;
    if (i > 0) ++out_[i - 1];
  }
  void renorm() {
    do {
      out_.push_back(std::uint8_t(base_ >> 24));
      base_ <<= 8;
    } while ((length_ <<= 8) < kMinLength);
  }
  std::vector<std::uint8_t> out_;
  std::uint32_t base_ = 0, length_ = kMaxLength;
};

/// LASzip's integer compressor: corrector c = real - pred folded into [corr_min, corr_max], coded as
/// k (its bit length, one model per context) then, for k <= bits_high, one symbol of k bits, else
/// the high bits_high bits as a symbol and the rest raw. k() is the last k, which the point models
/// use as context for the next coordinate.
class IntegerCodec {
 public:
  IntegerCodec() = default;
  IntegerCodec(unsigned bits, unsigned contexts, bool decoder, unsigned bits_high = 8,
               std::uint32_t range = 0) {
    create(bits, contexts, decoder, bits_high, range);
  }
  void create(unsigned bits, unsigned contexts, bool decoder, unsigned bits_high = 8,
              std::uint32_t range = 0) {
    bits_high_ = bits_high;
    if (range) {
      corr_bits_ = 0;
      corr_range_ = range;
      while (range) {
        range >>= 1;
        ++corr_bits_;
      }
      if (corr_range_ == (1u << (corr_bits_ - 1))) --corr_bits_;
      corr_min_ = -std::int32_t(corr_range_ / 2);
    } else if (bits && bits < 32) {
      corr_bits_ = bits;
      corr_range_ = 1u << bits;
      corr_min_ = -std::int32_t(corr_range_ / 2);
    } else {
      corr_bits_ = 32;
      corr_range_ = 0;
      corr_min_ = INT32_MIN;
    }
    corr_max_ = std::int32_t(std::uint32_t(corr_min_) + corr_range_ - 1);
    m_bits_.assign(contexts, SymbolModel());
    for (auto& m : m_bits_) m.create(corr_bits_ + 1, decoder);
    m_corrector_.assign(corr_bits_ + 1, SymbolModel());
    for (unsigned i = 1; i <= corr_bits_ && i < 32; ++i)
      m_corrector_[i].create(i <= bits_high_ ? (1u << i) : (1u << bits_high_), decoder);
    init();
  }
  void init() {
    for (auto& m : m_bits_) m.init();
    m_corrector0_.init();
    for (unsigned i = 1; i <= corr_bits_ && i < 32; ++i) m_corrector_[i].init();
    k_ = 0;
  }
  unsigned k() const { return k_; }

  std::int32_t decompress(ArithmeticDecoder& dec, std::int32_t pred, unsigned context = 0) {
    std::uint32_t real = std::uint32_t(pred) + std::uint32_t(readCorrector(dec, m_bits_[context]));
    if (std::int32_t(real) < 0)
      real += corr_range_;
    else if (real >= corr_range_)
      real -= corr_range_;
    return std::int32_t(real);
  }
  void compress(ArithmeticEncoder& enc, std::int32_t pred, std::int32_t real, unsigned context = 0) {
    std::int32_t corr = std::int32_t(std::uint32_t(real) - std::uint32_t(pred));
    if (corr < corr_min_)
      corr = std::int32_t(std::uint32_t(corr) + corr_range_);
    else if (corr > corr_max_)
      corr = std::int32_t(std::uint32_t(corr) - corr_range_);
    writeCorrector(enc, corr, m_bits_[context]);
  }

 private:
  std::int32_t readCorrector(ArithmeticDecoder& dec, SymbolModel& mbits) {
    k_ = dec.decodeSymbol(mbits);
    if (k_ == 0) return std::int32_t(dec.decodeBit(m_corrector0_));
    if (k_ >= 32) return corr_min_;
    std::uint32_t c;
    if (k_ <= bits_high_) {
      c = dec.decodeSymbol(m_corrector_[k_]);
    } else {
      const unsigned k1 = k_ - bits_high_;
      c = dec.decodeSymbol(m_corrector_[k_]);
      c = (c << k1) | dec.readBits(k1);
    }
    // back from [0, 2^k - 1] to [-(2^k - 1), -2^(k-1)] u [2^(k-1) + 1, 2^k]
    if (c >= (1u << (k_ - 1)))
      c += 1;
    else
      c -= (1u << k_) - 1;
    return std::int32_t(c);
  }
  void writeCorrector(ArithmeticEncoder& enc, std::int32_t c, SymbolModel& mbits) {
    std::uint32_t c1 = c <= 0 ? 0u - std::uint32_t(c) : std::uint32_t(c) - 1;
    k_ = 0;
    while (c1) {
      c1 >>= 1;
      ++k_;
    }
    enc.encodeSymbol(mbits, k_);
    if (k_ == 0) {
      enc.encodeBit(m_corrector0_, std::uint32_t(c));
      return;
    }
    if (k_ >= 32) return;
    std::uint32_t u = std::uint32_t(c);
    if (c < 0)
      u += (1u << k_) - 1;
    else
      u -= 1;
    if (k_ <= bits_high_) {
      enc.encodeSymbol(m_corrector_[k_], u);
    } else {
      const unsigned k1 = k_ - bits_high_;
      enc.encodeSymbol(m_corrector_[k_], u >> k1);
      enc.writeBits(k1, u & ((1u << k1) - 1));
    }
  }

  unsigned corr_bits_ = 0, bits_high_ = 8, k_ = 0;
  std::uint32_t corr_range_ = 0;
  std::int32_t corr_min_ = 0, corr_max_ = 0;
  std::vector<SymbolModel> m_bits_;
  BitModel m_corrector0_;
  std::vector<SymbolModel> m_corrector_;
};

/// LASzip's streaming median of the last five values (the prediction of x/y differences).
struct StreamingMedian5 {
  std::int32_t v[5];
  bool high;
  void init() {
    v[0] = v[1] = v[2] = v[3] = v[4] = 0;
    high = true;
  }
  std::int32_t get() const { return v[2]; }
  void add(std::int32_t x) {
    if (high) {
      if (x < v[2]) {
        v[4] = v[3];
        v[3] = v[2];
        if (x < v[0]) {
          v[2] = v[1];
          v[1] = v[0];
          v[0] = x;
        } else if (x < v[1]) {
          v[2] = v[1];
          v[1] = x;
        } else {
          v[2] = x;
        }
      } else {
        if (x < v[3]) {
          v[4] = v[3];
          v[3] = x;
        } else {
          v[4] = x;
        }
        high = false;
      }
    } else {
      if (v[2] < x) {
        v[0] = v[1];
        v[1] = v[2];
        if (v[4] < x) {
          v[2] = v[3];
          v[3] = v[4];
          v[4] = x;
        } else if (v[3] < x) {
          v[2] = v[3];
          v[3] = x;
        } else {
          v[2] = x;
        }
      } else {
        if (v[1] < x) {
          v[0] = v[1];
          v[1] = x;
        } else {
          v[0] = x;
        }
        high = true;
      }
    }
  }
};

/// x mod 256 for the byte-wise models (LASzip's U8_FOLD).
inline std::uint8_t fold8(std::int32_t x) {
  return std::uint8_t(x & 0xFF);
}
inline std::int32_t clamp8(std::int32_t x) {
  return x < 0 ? 0 : (x > 255 ? 255 : x);
}

}  // namespace laz
}  // namespace las
}  // namespace dw
