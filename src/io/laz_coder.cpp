#include "laz_coder.hpp"

#include <algorithm>

namespace mountcal::io::laz {

// ---- models ----------------------------------------------------------------------------------

SymbolModel::SymbolModel(std::uint32_t symbols, bool decoder) : n_(symbols), last_(symbols - 1) {
  if (symbols < 2 || symbols > 2048) throw Corrupt{"symbol model of " + std::to_string(symbols) + " symbols"};
  if (decoder && n_ > 16) {
    std::uint32_t bits = 3;
    while (n_ > (1u << (bits + 2))) ++bits;
    table_size_ = 1u << bits;
    table_shift_ = kSymShift - bits;
    table_.assign(table_size_ + 2, 0);
  }
  dist_.assign(n_, 0);
  count_.assign(n_, 1);
  init();
}

void SymbolModel::init() {
  std::fill(count_.begin(), count_.end(), 1u);
  total_ = 0;
  cycle_ = n_;
  update();
  until_update_ = cycle_ = (n_ + 6) >> 1;
}

void SymbolModel::update() {
  if ((total_ += cycle_) > kSymMaxCount) {  // halve the counts at the threshold
    total_ = 0;
    for (std::uint32_t k = 0; k < n_; ++k) total_ += (count_[k] = (count_[k] + 1) >> 1);
  }
  const std::uint32_t scale = 0x80000000u / total_;
  std::uint32_t sum = 0;
  if (table_size_ == 0) {
    for (std::uint32_t k = 0; k < n_; ++k) {
      dist_[k] = (scale * sum) >> (31 - kSymShift);
      sum += count_[k];
    }
  } else {
    std::uint32_t s = 0;
    for (std::uint32_t k = 0; k < n_; ++k) {
      dist_[k] = (scale * sum) >> (31 - kSymShift);
      sum += count_[k];
      const std::uint32_t w = dist_[k] >> table_shift_;
      while (s < w) table_[++s] = k - 1;
    }
    table_[0] = 0;
    while (s <= table_size_) table_[++s] = n_ - 1;
  }
  cycle_ = (5 * cycle_) >> 2;
  const std::uint32_t max_cycle = (n_ + 6) << 3;
  if (cycle_ > max_cycle) cycle_ = max_cycle;
  until_update_ = cycle_;
}

void Median5::add(std::int32_t x) {
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

// ---- decoder ---------------------------------------------------------------------------------

void Decoder::init(const std::uint8_t* begin, const std::uint8_t* end) {
  p_ = begin;
  end_ = end;
  overrun_ = 0;
  length_ = kMaxLength;
  value_ = 0;
  for (int i = 0; i < 4; ++i) value_ = (value_ << 8) | byte();
}

std::uint32_t Decoder::decodeBit(BitModel& m) {
  const std::uint32_t x = m.zero_prob * (length_ >> kBitShift);
  std::uint32_t bit;
  if (value_ < x) {
    bit = 0;
    length_ = x;
    ++m.zero_count;
  } else {
    bit = 1;
    value_ -= x;
    length_ -= x;
  }
  if (length_ < kMinLength) renorm();
  if (--m.until_update == 0) m.update();
  return bit;
}

std::uint32_t Decoder::decodeSymbol(SymbolModel& m) {
  std::uint32_t sym, x, y = length_;
  length_ >>= kSymShift;
  if (m.table_size_ != 0) {
    const std::uint32_t dv = value_ / length_;
    const std::uint32_t t = std::min(dv >> m.table_shift_, m.table_size_);  // bounded even on corrupt data
    sym = m.table_[t];
    std::uint32_t n = m.table_[t + 1] + 1;
    while (n > sym + 1) {  // bisection within the table's bracket
      const std::uint32_t k = (sym + n) >> 1;
      if (m.dist_[k] > dv)
        n = k;
      else
        sym = k;
    }
    x = m.dist_[sym] * length_;
    if (sym != m.last_) y = m.dist_[sym + 1] * length_;
  } else {
    x = sym = 0;
    std::uint32_t n = m.n_;
    std::uint32_t k = n >> 1;
    do {
      const std::uint32_t z = length_ * m.dist_[k];
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
  ++m.count_[sym];
  if (--m.until_update_ == 0) m.update();
  return sym;
}

std::uint32_t Decoder::readBits(std::uint32_t bits) {
  if (bits > 19) {
    const std::uint32_t low = readShort();
    const std::uint32_t high = readBits(bits - 16);
    return (high << 16) | low;
  }
  const std::uint32_t sym = value_ / (length_ >>= bits);
  value_ -= length_ * sym;
  if (length_ < kMinLength) renorm();
  if (sym >= (1u << bits)) throw Corrupt{"raw bits out of range"};
  return sym;
}

std::uint32_t Decoder::readShort() {
  const std::uint32_t sym = value_ / (length_ >>= 16);
  value_ -= length_ * sym;
  if (length_ < kMinLength) renorm();
  if (sym >= (1u << 16)) throw Corrupt{"raw short out of range"};
  return sym;
}

std::uint32_t Decoder::readInt() {
  const std::uint32_t low = readShort();
  const std::uint32_t high = readShort();
  return (high << 16) | low;
}

std::uint64_t Decoder::readInt64() {
  const std::uint64_t low = readInt();
  const std::uint64_t high = readInt();
  return (high << 32) | low;
}

// ---- encoder ---------------------------------------------------------------------------------

void Encoder::init(std::vector<std::uint8_t>* out) {
  out_ = out;
  start_ = out->size();
  base_ = 0;
  length_ = kMaxLength;
}

void Encoder::carry() {  // propagate a carry into the bytes already written
  std::size_t i = out_->size();
  while (i > start_) {
    --i;
    if ((*out_)[i] == 0xFF) {
      (*out_)[i] = 0;
    } else {
      ++(*out_)[i];
      return;
    }
  }
}

void Encoder::renorm() {
  do {
    out_->push_back(static_cast<std::uint8_t>(base_ >> 24));
    base_ <<= 8;
  } while ((length_ <<= 8) < kMinLength);
}

void Encoder::encodeBit(BitModel& m, std::uint32_t bit) {
  const std::uint32_t x = m.zero_prob * (length_ >> kBitShift);
  if (bit == 0) {
    length_ = x;
    ++m.zero_count;
  } else {
    const std::uint32_t init_base = base_;
    base_ += x;
    length_ -= x;
    if (init_base > base_) carry();
  }
  if (length_ < kMinLength) renorm();
  if (--m.until_update == 0) m.update();
}

void Encoder::encodeSymbol(SymbolModel& m, std::uint32_t sym) {
  const std::uint32_t init_base = base_;
  if (sym == m.last_) {
    const std::uint32_t x = m.dist_[sym] * (length_ >> kSymShift);
    base_ += x;
    length_ -= x;
  } else {
    const std::uint32_t x = m.dist_[sym] * (length_ >>= kSymShift);
    base_ += x;
    length_ = m.dist_[sym + 1] * length_ - x;
  }
  if (init_base > base_) carry();
  if (length_ < kMinLength) renorm();
  ++m.count_[sym];
  if (--m.until_update_ == 0) m.update();
}

void Encoder::writeBits(std::uint32_t bits, std::uint32_t value) {
  if (bits > 19) {
    writeShort(value & 0xFFFFu);
    value >>= 16;
    bits -= 16;
  }
  const std::uint32_t init_base = base_;
  base_ += value * (length_ >>= bits);
  if (init_base > base_) carry();
  if (length_ < kMinLength) renorm();
}

void Encoder::writeShort(std::uint32_t value) {
  const std::uint32_t init_base = base_;
  base_ += value * (length_ >>= 16);
  if (init_base > base_) carry();
  if (length_ < kMinLength) renorm();
}

void Encoder::writeInt(std::uint32_t value) {
  writeShort(value & 0xFFFFu);
  writeShort(value >> 16);
}

void Encoder::writeInt64(std::uint64_t value) {
  writeInt(static_cast<std::uint32_t>(value));
  writeInt(static_cast<std::uint32_t>(value >> 32));
}

void Encoder::done() {
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
  // Zero bytes so that the decoder's reads end exactly at the end of the stream.
  out_->push_back(0);
  out_->push_back(0);
  if (another_byte) out_->push_back(0);
}

// ---- integer corrector coder -----------------------------------------------------------------

IntegerCodec::IntegerCodec(std::uint32_t bits, std::uint32_t contexts, std::uint32_t bits_high)
    : bits_(bits), contexts_(contexts), bits_high_(bits_high) {
  if (bits_ > 0 && bits_ < 32) {
    corr_bits_ = bits_;
    corr_range_ = std::int64_t{1} << bits_;
    corr_min_ = -(corr_range_ / 2);
    corr_max_ = corr_min_ + corr_range_ - 1;
  } else {
    corr_bits_ = 32;
    corr_range_ = 0;  // corrections wrap modulo 2^32
    corr_min_ = INT32_MIN;
    corr_max_ = INT32_MAX;
  }
}

void IntegerCodec::init(bool decoder) {
  m_bits_.clear();
  for (std::uint32_t i = 0; i < contexts_; ++i) m_bits_.push_back(std::make_unique<SymbolModel>(corr_bits_ + 1, decoder));
  m_corrector0_.init();
  m_corrector_.clear();
  m_corrector_.push_back(nullptr);
  for (std::uint32_t i = 1; i <= corr_bits_; ++i)
    m_corrector_.push_back(std::make_unique<SymbolModel>(i <= bits_high_ ? 1u << i : 1u << bits_high_, decoder));
  k_ = 0;
}

std::int32_t IntegerCodec::decompress(Decoder& dec, std::int32_t pred, std::uint32_t context) {
  // The corrector's interval [-(2^k - 1), 2^k], then its place within it.
  k_ = dec.decodeSymbol(*m_bits_[context]);
  std::int64_t c;
  if (k_ != 0) {
    std::uint64_t v;
    if (k_ <= bits_high_) {
      v = dec.decodeSymbol(*m_corrector_[k_]);
    } else {
      const std::uint32_t k1 = k_ - bits_high_;
      v = dec.decodeSymbol(*m_corrector_[k_]);
      v = (v << k1) | dec.readBits(k1);
    }
    if (v >= (std::uint64_t{1} << (k_ - 1)))
      c = static_cast<std::int64_t>(v) + 1;
    else
      c = static_cast<std::int64_t>(v) - ((std::int64_t{1} << k_) - 1);
  } else {
    c = dec.decodeBit(m_corrector0_);
  }
  if (corr_range_ == 0) return static_cast<std::int32_t>(static_cast<std::uint32_t>(pred) + static_cast<std::uint32_t>(c));
  std::int64_t real = std::int64_t{pred} + c;
  if (real < 0)
    real += corr_range_;
  else if (real >= corr_range_)
    real -= corr_range_;
  return static_cast<std::int32_t>(real);
}

void IntegerCodec::compress(Encoder& enc, std::int32_t pred, std::int32_t real, std::uint32_t context) {
  std::int64_t c;
  if (corr_range_ == 0) {
    c = static_cast<std::int32_t>(static_cast<std::uint32_t>(real) - static_cast<std::uint32_t>(pred));
  } else {
    c = std::int64_t{real} - pred;
    if (c < corr_min_)
      c += corr_range_;
    else if (c > corr_max_)
      c -= corr_range_;
  }
  std::uint64_t c1 = c <= 0 ? static_cast<std::uint64_t>(-c) : static_cast<std::uint64_t>(c - 1);
  k_ = 0;
  while (c1) {
    c1 >>= 1;
    ++k_;
  }
  enc.encodeSymbol(*m_bits_[context], k_);
  if (k_ != 0) {
    const std::uint64_t v = c < 0 ? static_cast<std::uint64_t>(c + ((std::int64_t{1} << k_) - 1)) : static_cast<std::uint64_t>(c - 1);
    if (k_ <= bits_high_) {
      enc.encodeSymbol(*m_corrector_[k_], static_cast<std::uint32_t>(v));
    } else {
      const std::uint32_t k1 = k_ - bits_high_;
      enc.encodeSymbol(*m_corrector_[k_], static_cast<std::uint32_t>(v >> k1));
      enc.writeBits(k1, static_cast<std::uint32_t>(v & ((std::uint64_t{1} << k1) - 1)));
    }
  } else {
    enc.encodeBit(m_corrector0_, static_cast<std::uint32_t>(c));
  }
}

}  // namespace mountcal::io::laz
