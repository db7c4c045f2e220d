// The LAZ item codecs: what each field is predicted from and with which model. Written from the
// LAZ specification and the behaviour of LASzip (the reference decoder), whose output every
// test compares with; quirks of the reference that a compatible decoder must share are noted.
#include "laz_items.hpp"

#include "io/bytes.hpp"

#include <algorithm>
#include <cstring>

namespace mountcal::io::laz {

namespace {

using bytes::get;
using bytes::put;
std::int32_t wrapAdd(std::int32_t a, std::int32_t b) {
  return static_cast<std::int32_t>(static_cast<std::uint32_t>(a) + static_cast<std::uint32_t>(b));
}
std::int32_t wrapSub(std::int32_t a, std::int32_t b) {
  return static_cast<std::int32_t>(static_cast<std::uint32_t>(a) - static_cast<std::uint32_t>(b));
}
std::int32_t wrapMul(std::int32_t a, std::int32_t b) {
  return static_cast<std::int32_t>(static_cast<std::uint32_t>(a) * static_cast<std::uint32_t>(b));
}
std::uint8_t fold(int v) { return static_cast<std::uint8_t>(v & 0xFF); }  // U8_FOLD
int clamp8(int v) { return std::clamp(v, 0, 255); }                       // U8_CLAMP
std::uint32_t evenBelow(std::uint32_t k, std::uint32_t cap) { return k < cap ? (k & ~1u) : cap; }

using ModelPtr = std::unique_ptr<SymbolModel>;
template <std::size_t N>
SymbolModel& lazyModel(std::array<ModelPtr, N>& models, std::size_t index, std::uint32_t symbols, bool decoder) {
  if (!models[index]) models[index] = std::make_unique<SymbolModel>(symbols, decoder);
  return *models[index];
}

// Return-number contexts of POINT10 (r = return number, n = number of returns; "completed" for
// files that number from 0 or swap r and n).
constexpr std::uint8_t kReturnMap[8][8] = {{15, 14, 13, 12, 11, 10, 9, 8},  {14, 0, 1, 3, 6, 10, 10, 9},   {13, 1, 2, 4, 7, 11, 11, 10},
                                           {12, 3, 4, 5, 8, 12, 12, 11},    {11, 6, 7, 8, 9, 13, 13, 12},  {10, 10, 11, 12, 13, 14, 14, 13},
                                           {9, 10, 11, 12, 13, 14, 15, 14}, {8, 9, 10, 11, 12, 13, 14, 15}};
std::uint32_t returnLevel(std::uint32_t n, std::uint32_t r) { return n > r ? n - r : r - n; }

// The LAS 1.4 tables: 6 return-map contexts and levels |n − r| capped at 7.
constexpr std::uint8_t kReturnMap6[16][16] = {
    {0, 1, 2, 3, 4, 5, 3, 4, 4, 5, 5, 5, 5, 5, 5, 5}, {1, 0, 1, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3},
    {2, 1, 2, 4, 4, 4, 4, 4, 4, 4, 4, 3, 3, 3, 3, 3}, {3, 3, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4},
    {4, 3, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4}, {5, 3, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4},
    {3, 3, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 4}, {4, 3, 4, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4},
    {4, 3, 4, 4, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4}, {5, 3, 4, 4, 4, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4},
    {5, 3, 4, 4, 4, 4, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4}, {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 4, 4, 4},
    {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 5, 4, 4}, {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 5, 4},
    {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 5}, {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5}};
std::uint32_t returnLevel8(std::uint32_t n, std::uint32_t r) { return std::min<std::uint32_t>(returnLevel(n, r), 7); }

// GPS time multipliers (item versions 2 and 3).
constexpr int kMulti = 500, kMultiMinus = -10;
constexpr int kMultiUnchangedV2 = kMulti - kMultiMinus + 1;  // 511 (version 2 only)
constexpr int kMultiCodeFullV2 = kMulti - kMultiMinus + 2;   // 512
constexpr int kMultiTotalV2 = kMulti - kMultiMinus + 6;      // 516
constexpr int kMultiCodeFullV3 = kMulti - kMultiMinus + 1;   // 511
constexpr int kMultiTotalV3 = kMulti - kMultiMinus + 5;      // 515

/// The multiplier between this and the last time difference, as the reference quantises it
/// (float division, rounded half away from zero), kept in range.
int timeMultiplier(std::int32_t diff, std::int32_t last_diff) {
  const float f = static_cast<float>(diff) / static_cast<float>(last_diff);
  if (!(f < 1e6f)) return kMulti;
  if (!(f > -1e6f)) return kMultiMinus;
  return f >= 0 ? static_cast<int>(f + 0.5f) : static_cast<int>(f - 0.5f);
}
bool fits32(std::int64_t d) { return d == static_cast<std::int32_t>(d); }

// ============================================================================================
// Version 2 point-wise items (and the shared GPS time state machine).
// ============================================================================================

/// GPS time as up to four interleaved sequences, each predicted from its last difference.
struct GpsTimeState {
  std::uint32_t last = 0, next = 0;
  std::uint64_t time[4] = {0, 0, 0, 0};
  std::int32_t diff[4] = {0, 0, 0, 0};
  std::int32_t extreme[4] = {0, 0, 0, 0};
  void reset(std::uint64_t first) {
    last = next = 0;
    for (int i = 0; i < 4; ++i) time[i] = diff[i] = extreme[i] = 0;
    time[0] = first;
  }
  void add(std::int32_t d) { time[last] += static_cast<std::uint64_t>(static_cast<std::int64_t>(d)); }
  void extremeStep(std::int32_t d) {
    if (++extreme[last] > 3) {
      diff[last] = d;
      extreme[last] = 0;
    }
  }
};

/// Decodes a time with the multiplier model of version 2 (`v3` = false) or 3.
void readGpsTime(GpsTimeState& s, Decoder& dec, SymbolModel& m_multi, SymbolModel& m_0diff, IntegerCodec& ic, bool v3) {
  const int code_full = v3 ? kMultiCodeFullV3 : kMultiCodeFullV2;
  for (int depth = 0;; ++depth) {
    if (depth > 4) throw Corrupt{"GPS time switches sequences without end"};
    if (s.diff[s.last] == 0) {
      const int multi = static_cast<int>(dec.decodeSymbol(m_0diff));
      const int small = v3 ? 0 : 1, huge = v3 ? 1 : 2;
      if (multi == small) {  // a difference of 32 bits
        s.diff[s.last] = ic.decompress(dec, 0, 0);
        s.add(s.diff[s.last]);
        s.extreme[s.last] = 0;
      } else if (multi == huge) {  // a new sequence: the high 32 bits predicted, the low raw
        s.next = (s.next + 1) & 3;
        const std::uint32_t high = static_cast<std::uint32_t>(ic.decompress(dec, static_cast<std::int32_t>(s.time[s.last] >> 32), 8));
        s.time[s.next] = (std::uint64_t{high} << 32) | dec.readInt();
        s.last = s.next;
        s.diff[s.last] = 0;
        s.extreme[s.last] = 0;
      } else if (multi > huge) {  // another of the four sequences
        s.last = (s.last + static_cast<std::uint32_t>(multi - huge)) & 3;
        continue;
      }  // version 2, symbol 0: unchanged
    } else {
      const int multi = static_cast<int>(dec.decodeSymbol(m_multi));
      if (multi == 1) {
        s.add(ic.decompress(dec, s.diff[s.last], 1));
        s.extreme[s.last] = 0;
      } else if (multi < (v3 ? code_full : kMultiUnchangedV2)) {
        std::int32_t d;
        if (multi == 0) {
          d = ic.decompress(dec, 0, 7);
          s.extremeStep(d);
        } else if (multi < kMulti) {
          d = ic.decompress(dec, wrapMul(multi, s.diff[s.last]), multi < 10 ? 2 : 3);
        } else if (multi == kMulti) {
          d = ic.decompress(dec, wrapMul(kMulti, s.diff[s.last]), 4);
          s.extremeStep(d);
        } else {
          const int negative = kMulti - multi;
          if (negative > kMultiMinus) {
            d = ic.decompress(dec, wrapMul(negative, s.diff[s.last]), 5);
          } else {
            d = ic.decompress(dec, wrapMul(kMultiMinus, s.diff[s.last]), 6);
            s.extremeStep(d);
          }
        }
        s.add(d);
      } else if (multi == code_full) {
        s.next = (s.next + 1) & 3;
        const std::uint32_t high = static_cast<std::uint32_t>(ic.decompress(dec, static_cast<std::int32_t>(s.time[s.last] >> 32), 8));
        s.time[s.next] = (std::uint64_t{high} << 32) | dec.readInt();
        s.last = s.next;
        s.diff[s.last] = 0;
        s.extreme[s.last] = 0;
      } else if (multi > code_full) {
        s.last = (s.last + static_cast<std::uint32_t>(multi - code_full)) & 3;
        continue;
      }  // version 2, kMultiUnchangedV2: unchanged
    }
    return;
  }
}

/// Encodes a time (the mirror of readGpsTime); version 3 callers only call it on a change.
void writeGpsTime(GpsTimeState& s, Encoder& enc, SymbolModel& m_multi, SymbolModel& m_0diff, IntegerCodec& ic, bool v3, std::uint64_t t) {
  const int code_full = v3 ? kMultiCodeFullV3 : kMultiCodeFullV2;
  for (int depth = 0; depth < 2; ++depth) {
    const std::int64_t d64 = static_cast<std::int64_t>(t - s.time[s.last]);
    if (s.diff[s.last] == 0) {
      if (!v3 && t == s.time[s.last]) {
        enc.encodeSymbol(m_0diff, 0);
        return;
      }
      if (fits32(d64)) {
        enc.encodeSymbol(m_0diff, v3 ? 0 : 1);
        ic.compress(enc, 0, static_cast<std::int32_t>(d64), 0);
        s.diff[s.last] = static_cast<std::int32_t>(d64);
        s.extreme[s.last] = 0;
      } else {
        bool switched = false;
        for (std::uint32_t i = 1; i < 4 && !switched; ++i) {
          if (fits32(static_cast<std::int64_t>(t - s.time[(s.last + i) & 3]))) {
            enc.encodeSymbol(m_0diff, (v3 ? 1 : 2) + i);
            s.last = (s.last + i) & 3;
            switched = true;
          }
        }
        if (switched) continue;
        enc.encodeSymbol(m_0diff, v3 ? 1 : 2);
        ic.compress(enc, static_cast<std::int32_t>(s.time[s.last] >> 32), static_cast<std::int32_t>(t >> 32), 8);
        enc.writeInt(static_cast<std::uint32_t>(t));
        s.next = (s.next + 1) & 3;
        s.last = s.next;
        s.diff[s.last] = 0;
        s.extreme[s.last] = 0;
      }
      s.time[s.last] = t;
      return;
    }
    if (!v3 && t == s.time[s.last]) {
      enc.encodeSymbol(m_multi, kMultiUnchangedV2);
      return;
    }
    if (fits32(d64)) {
      const std::int32_t d = static_cast<std::int32_t>(d64);
      const int multi = timeMultiplier(d, s.diff[s.last]);
      if (multi == 1) {
        enc.encodeSymbol(m_multi, 1);
        ic.compress(enc, s.diff[s.last], d, 1);
        s.extreme[s.last] = 0;
      } else if (multi > 0) {
        if (multi < kMulti) {
          enc.encodeSymbol(m_multi, static_cast<std::uint32_t>(multi));
          ic.compress(enc, wrapMul(multi, s.diff[s.last]), d, multi < 10 ? 2 : 3);
        } else {
          enc.encodeSymbol(m_multi, kMulti);
          ic.compress(enc, wrapMul(kMulti, s.diff[s.last]), d, 4);
          s.extremeStep(d);
        }
      } else if (multi < 0) {
        if (multi > kMultiMinus) {
          enc.encodeSymbol(m_multi, static_cast<std::uint32_t>(kMulti - multi));
          ic.compress(enc, wrapMul(multi, s.diff[s.last]), d, 5);
        } else {
          enc.encodeSymbol(m_multi, static_cast<std::uint32_t>(kMulti - kMultiMinus));
          ic.compress(enc, wrapMul(kMultiMinus, s.diff[s.last]), d, 6);
          s.extremeStep(d);
        }
      } else {
        enc.encodeSymbol(m_multi, 0);
        ic.compress(enc, 0, d, 7);
        s.extremeStep(d);
      }
    } else {
      bool switched = false;
      for (std::uint32_t i = 1; i < 4 && !switched; ++i) {
        if (fits32(static_cast<std::int64_t>(t - s.time[(s.last + i) & 3]))) {
          enc.encodeSymbol(m_multi, static_cast<std::uint32_t>(code_full) + i);
          s.last = (s.last + i) & 3;
          switched = true;
        }
      }
      if (switched) continue;
      enc.encodeSymbol(m_multi, static_cast<std::uint32_t>(code_full));
      ic.compress(enc, static_cast<std::int32_t>(s.time[s.last] >> 32), static_cast<std::int32_t>(t >> 32), 8);
      enc.writeInt(static_cast<std::uint32_t>(t));
      s.next = (s.next + 1) & 3;
      s.last = s.next;
      s.diff[s.last] = 0;
      s.extreme[s.last] = 0;
    }
    s.time[s.last] = t;
    return;
  }
}

class Point10V2 final : public PointwiseItem {
 public:
  explicit Point10V2(bool decoder) : decoder_(decoder) {}
  void init(const std::uint8_t* item) override {
    for (int i = 0; i < 16; ++i) {
      last_x_diff_[i] = Median5{};
      last_y_diff_[i] = Median5{};
      last_intensity_[i] = 0;
      last_height_[i / 2] = 0;
    }
    changed_values_ = std::make_unique<SymbolModel>(64, decoder_);
    scan_angle_[0] = std::make_unique<SymbolModel>(256, decoder_);
    scan_angle_[1] = std::make_unique<SymbolModel>(256, decoder_);
    for (auto* a : {&bit_byte_, &classification_, &user_data_})
      for (auto& m : *a) m.reset();
    for (IntegerCodec* ic : {&ic_intensity_, &ic_source_, &ic_dx_, &ic_dy_, &ic_z_}) ic->init(decoder_);
    std::memcpy(last_, item, 20);
    last_[12] = last_[13] = 0;  // the intensity is predicted from 0 at a chunk's start
  }

  void read(Decoder& dec, std::uint8_t* item) override {
    const std::uint32_t changed = dec.decodeSymbol(*changed_values_);
    if (changed & 32) last_[14] = static_cast<std::uint8_t>(dec.decodeSymbol(lazyModel(bit_byte_, last_[14], 256, decoder_)));
    const std::uint32_t r = last_[14] & 7u, n = (last_[14] >> 3) & 7u;
    const std::uint32_t m = kReturnMap[n][r], l = returnLevel(n, r);
    if (changed & 16) {
      const auto v = static_cast<std::uint16_t>(ic_intensity_.decompress(dec, last_intensity_[m], m < 3 ? m : 3));
      last_intensity_[m] = v;
      put<std::uint16_t>(last_, 12, v);
    } else if (changed) {
      put<std::uint16_t>(last_, 12, last_intensity_[m]);
    }
    if (changed & 8) last_[15] = static_cast<std::uint8_t>(dec.decodeSymbol(lazyModel(classification_, last_[15], 256, decoder_)));
    if (changed & 4) {
      const int v = static_cast<int>(dec.decodeSymbol(*scan_angle_[(last_[14] >> 6) & 1u]));
      last_[16] = fold(v + last_[16]);
    }
    if (changed & 2) last_[17] = static_cast<std::uint8_t>(dec.decodeSymbol(lazyModel(user_data_, last_[17], 256, decoder_)));
    if (changed & 1) put<std::uint16_t>(last_, 18, static_cast<std::uint16_t>(ic_source_.decompress(dec, get<std::uint16_t>(last_, 18))));
    // x and y: a difference predicted by the median of the last five of the same return context.
    std::int32_t diff = ic_dx_.decompress(dec, last_x_diff_[m].get(), n == 1);
    put<std::int32_t>(last_, 0, wrapAdd(get<std::int32_t>(last_, 0), diff));
    last_x_diff_[m].add(diff);
    std::uint32_t k = ic_dx_.k();
    diff = ic_dy_.decompress(dec, last_y_diff_[m].get(), (n == 1) + evenBelow(k, 20));
    put<std::int32_t>(last_, 4, wrapAdd(get<std::int32_t>(last_, 4), diff));
    last_y_diff_[m].add(diff);
    // z: from the last z of the same return level.
    k = (ic_dx_.k() + ic_dy_.k()) / 2;
    const std::int32_t z = ic_z_.decompress(dec, last_height_[l], (n == 1) + evenBelow(k, 18));
    put<std::int32_t>(last_, 8, z);
    last_height_[l] = z;
    std::memcpy(item, last_, 20);
  }

  void write(Encoder& enc, const std::uint8_t* item) override {
    const std::uint32_t r = item[14] & 7u, n = (item[14] >> 3) & 7u;
    const std::uint32_t m = kReturnMap[n][r], l = returnLevel(n, r);
    const std::uint16_t intensity = get<std::uint16_t>(item, 12);
    const std::uint32_t changed = ((last_[14] != item[14]) << 5) | ((last_intensity_[m] != intensity) << 4) |
                                  ((last_[15] != item[15]) << 3) | ((last_[16] != item[16]) << 2) | ((last_[17] != item[17]) << 1) |
                                  (get<std::uint16_t>(last_, 18) != get<std::uint16_t>(item, 18));
    enc.encodeSymbol(*changed_values_, changed);
    if (changed & 32) enc.encodeSymbol(lazyModel(bit_byte_, last_[14], 256, decoder_), item[14]);
    if (changed & 16) {
      ic_intensity_.compress(enc, last_intensity_[m], intensity, m < 3 ? m : 3);
      last_intensity_[m] = intensity;
    }
    if (changed & 8) enc.encodeSymbol(lazyModel(classification_, last_[15], 256, decoder_), item[15]);
    if (changed & 4) enc.encodeSymbol(*scan_angle_[(item[14] >> 6) & 1u], fold(item[16] - last_[16]));
    if (changed & 2) enc.encodeSymbol(lazyModel(user_data_, last_[17], 256, decoder_), item[17]);
    if (changed & 1) ic_source_.compress(enc, get<std::uint16_t>(last_, 18), get<std::uint16_t>(item, 18));
    std::int32_t diff = wrapSub(get<std::int32_t>(item, 0), get<std::int32_t>(last_, 0));
    ic_dx_.compress(enc, last_x_diff_[m].get(), diff, n == 1);
    last_x_diff_[m].add(diff);
    std::uint32_t k = ic_dx_.k();
    diff = wrapSub(get<std::int32_t>(item, 4), get<std::int32_t>(last_, 4));
    ic_dy_.compress(enc, last_y_diff_[m].get(), diff, (n == 1) + evenBelow(k, 20));
    last_y_diff_[m].add(diff);
    k = (ic_dx_.k() + ic_dy_.k()) / 2;
    const std::int32_t z = get<std::int32_t>(item, 8);
    ic_z_.compress(enc, last_height_[l], z, (n == 1) + evenBelow(k, 18));
    last_height_[l] = z;
    std::memcpy(last_, item, 20);
  }

 private:
  bool decoder_;
  std::uint8_t last_[20] = {};
  std::uint16_t last_intensity_[16] = {};
  Median5 last_x_diff_[16], last_y_diff_[16];
  std::int32_t last_height_[8] = {};
  ModelPtr changed_values_, scan_angle_[2];
  std::array<ModelPtr, 256> bit_byte_, classification_, user_data_;
  IntegerCodec ic_intensity_{16, 4}, ic_source_{16, 1}, ic_dx_{32, 2}, ic_dy_{32, 22}, ic_z_{32, 20};
};

class GpsTime11V2 final : public PointwiseItem {
 public:
  explicit GpsTime11V2(bool decoder) : decoder_(decoder) {}
  void init(const std::uint8_t* item) override {
    m_multi_ = std::make_unique<SymbolModel>(kMultiTotalV2, decoder_);
    m_0diff_ = std::make_unique<SymbolModel>(6, decoder_);
    ic_.init(decoder_);
    state_.reset(get<std::uint64_t>(item, 0));
  }
  void read(Decoder& dec, std::uint8_t* item) override {
    readGpsTime(state_, dec, *m_multi_, *m_0diff_, ic_, false);
    put<std::uint64_t>(item, 0, state_.time[state_.last]);
  }
  void write(Encoder& enc, const std::uint8_t* item) override {
    writeGpsTime(state_, enc, *m_multi_, *m_0diff_, ic_, false, get<std::uint64_t>(item, 0));
  }

 private:
  bool decoder_;
  GpsTimeState state_;
  ModelPtr m_multi_, m_0diff_;
  IntegerCodec ic_{32, 9};
};

/// The RGB predictor of versions 2 and 3: the low and high bytes of red coded as differences,
/// green and blue relative to red's change (byte-wise), unless all three are equal.
struct RgbModels {
  ModelPtr used, diff[6];
  void create(bool decoder) {
    used = std::make_unique<SymbolModel>(128, decoder);
    for (auto& d : diff) d = std::make_unique<SymbolModel>(256, decoder);
  }
  void read(Decoder& dec, const std::uint16_t* last, std::uint16_t* out) {
    const std::uint32_t sym = dec.decodeSymbol(*used);
    out[0] = (sym & 1) ? fold(static_cast<int>(dec.decodeSymbol(*diff[0])) + (last[0] & 255)) : (last[0] & 0xFF);
    out[0] |= (sym & 2) ? static_cast<std::uint16_t>(fold(static_cast<int>(dec.decodeSymbol(*diff[1])) + (last[0] >> 8)) << 8)
                        : (last[0] & 0xFF00);
    if (sym & 64) {
      int d = (out[0] & 0xFF) - (last[0] & 0xFF);
      out[1] = (sym & 4) ? fold(static_cast<int>(dec.decodeSymbol(*diff[2])) + clamp8(d + (last[1] & 255))) : (last[1] & 0xFF);
      if (sym & 16) {
        const int corr = static_cast<int>(dec.decodeSymbol(*diff[4]));
        d = (d + ((out[1] & 0xFF) - (last[1] & 0xFF))) / 2;
        out[2] = fold(corr + clamp8(d + (last[2] & 255)));
      } else {
        out[2] = last[2] & 0xFF;
      }
      d = (out[0] >> 8) - (last[0] >> 8);
      out[1] |= (sym & 8) ? static_cast<std::uint16_t>(fold(static_cast<int>(dec.decodeSymbol(*diff[3])) + clamp8(d + (last[1] >> 8))) << 8)
                          : (last[1] & 0xFF00);
      if (sym & 32) {
        const int corr = static_cast<int>(dec.decodeSymbol(*diff[5]));
        d = (d + ((out[1] >> 8) - (last[1] >> 8))) / 2;
        out[2] |= static_cast<std::uint16_t>(fold(corr + clamp8(d + (last[2] >> 8))) << 8);
      } else {
        out[2] |= last[2] & 0xFF00;
      }
    } else {
      out[1] = out[2] = out[0];
    }
  }
  /// Returns the "bytes used" symbol (0: nothing changed).
  std::uint32_t write(Encoder& enc, const std::uint16_t* last, const std::uint16_t* in) {
    std::uint32_t sym = ((last[0] & 0x00FF) != (in[0] & 0x00FF)) << 0;
    sym |= ((last[0] & 0xFF00) != (in[0] & 0xFF00)) << 1;
    sym |= ((last[1] & 0x00FF) != (in[1] & 0x00FF)) << 2;
    sym |= ((last[1] & 0xFF00) != (in[1] & 0xFF00)) << 3;
    sym |= ((last[2] & 0x00FF) != (in[2] & 0x00FF)) << 4;
    sym |= ((last[2] & 0xFF00) != (in[2] & 0xFF00)) << 5;
    sym |= (((in[0] & 0x00FF) != (in[1] & 0x00FF)) || ((in[0] & 0x00FF) != (in[2] & 0x00FF)) || ((in[0] & 0xFF00) != (in[1] & 0xFF00)) ||
            ((in[0] & 0xFF00) != (in[2] & 0xFF00)))
           << 6;
    enc.encodeSymbol(*used, sym);
    int diff_l = 0, diff_h = 0;
    if (sym & 1) {
      diff_l = (in[0] & 255) - (last[0] & 255);
      enc.encodeSymbol(*diff[0], fold(diff_l));
    }
    if (sym & 2) {
      diff_h = (in[0] >> 8) - (last[0] >> 8);
      enc.encodeSymbol(*diff[1], fold(diff_h));
    }
    if (sym & 64) {
      if (sym & 4) enc.encodeSymbol(*diff[2], fold((in[1] & 255) - clamp8(diff_l + (last[1] & 255))));
      if (sym & 16) {
        diff_l = (diff_l + (in[1] & 255) - (last[1] & 255)) / 2;
        enc.encodeSymbol(*diff[4], fold((in[2] & 255) - clamp8(diff_l + (last[2] & 255))));
      }
      if (sym & 8) enc.encodeSymbol(*diff[3], fold((in[1] >> 8) - clamp8(diff_h + (last[1] >> 8))));
      if (sym & 32) {
        diff_h = (diff_h + (in[1] >> 8) - (last[1] >> 8)) / 2;
        enc.encodeSymbol(*diff[5], fold((in[2] >> 8) - clamp8(diff_h + (last[2] >> 8))));
      }
    }
    return sym;
  }
};

void loadU16(const std::uint8_t* p, std::uint16_t* out, int n) { std::memcpy(out, p, 2 * static_cast<std::size_t>(n)); }
void storeU16(std::uint8_t* p, const std::uint16_t* in, int n) { std::memcpy(p, in, 2 * static_cast<std::size_t>(n)); }

class Rgb12V2 final : public PointwiseItem {
 public:
  explicit Rgb12V2(bool decoder) : decoder_(decoder) {}
  void init(const std::uint8_t* item) override {
    models_.create(decoder_);
    loadU16(item, last_, 3);
  }
  void read(Decoder& dec, std::uint8_t* item) override {
    std::uint16_t out[3];
    models_.read(dec, last_, out);
    std::memcpy(last_, out, 6);
    storeU16(item, out, 3);
  }
  void write(Encoder& enc, const std::uint8_t* item) override {
    std::uint16_t in[3];
    loadU16(item, in, 3);
    models_.write(enc, last_, in);
    std::memcpy(last_, in, 6);
  }

 private:
  bool decoder_;
  RgbModels models_;
  std::uint16_t last_[3] = {};
};

class ByteV2 final : public PointwiseItem {
 public:
  ByteV2(std::size_t n, bool decoder) : decoder_(decoder), last_(n) {}
  void init(const std::uint8_t* item) override {
    models_.clear();
    for (std::size_t i = 0; i < last_.size(); ++i) models_.push_back(std::make_unique<SymbolModel>(256, decoder_));
    std::memcpy(last_.data(), item, last_.size());
  }
  void read(Decoder& dec, std::uint8_t* item) override {
    for (std::size_t i = 0; i < last_.size(); ++i) item[i] = last_[i] = fold(last_[i] + static_cast<int>(dec.decodeSymbol(*models_[i])));
  }
  void write(Encoder& enc, const std::uint8_t* item) override {
    for (std::size_t i = 0; i < last_.size(); ++i) {
      enc.encodeSymbol(*models_[i], fold(item[i] - last_[i]));
      last_[i] = item[i];
    }
  }

 private:
  bool decoder_;
  std::vector<std::uint8_t> last_;
  std::vector<ModelPtr> models_;
};

// ============================================================================================
// Version 1 point-wise items (LASzip 1.x; decoding only).
// ============================================================================================

std::int32_t median3(const std::int32_t* d) {
  if (d[0] < d[1]) return d[1] < d[2] ? d[1] : (d[0] < d[2] ? d[2] : d[0]);
  return d[0] < d[2] ? d[0] : (d[1] < d[2] ? d[2] : d[1]);
}

class DecodeOnly : public PointwiseItem {
 public:
  void write(Encoder&, const std::uint8_t*) override { throw Corrupt{"version 1 items are decoded only"}; }
};

class Point10V1 final : public DecodeOnly {
 public:
  void init(const std::uint8_t* item) override {
    for (int i = 0; i < 3; ++i) last_x_diff_[i] = last_y_diff_[i] = 0;
    last_incr_ = 0;
    for (IntegerCodec* ic : {&ic_dx_, &ic_dy_, &ic_z_, &ic_intensity_, &ic_scan_angle_, &ic_source_}) ic->init(true);
    changed_values_ = std::make_unique<SymbolModel>(64, true);
    for (auto* a : {&bit_byte_, &classification_, &user_data_})
      for (auto& m : *a) m.reset();
    std::memcpy(last_, item, 20);
  }
  void read(Decoder& dec, std::uint8_t* item) override {
    std::memcpy(item, last_, 20);
    const std::int32_t x_diff = ic_dx_.decompress(dec, median3(last_x_diff_));
    put<std::int32_t>(item, 0, wrapAdd(get<std::int32_t>(item, 0), x_diff));
    std::uint32_t k = ic_dx_.k();
    const std::int32_t y_diff = ic_dy_.decompress(dec, median3(last_y_diff_), k < 19 ? k : 19);
    put<std::int32_t>(item, 4, wrapAdd(get<std::int32_t>(item, 4), y_diff));
    k = (k + ic_dy_.k()) / 2;
    put<std::int32_t>(item, 8, ic_z_.decompress(dec, get<std::int32_t>(last_, 8), k < 19 ? k : 19));
    const std::uint32_t changed = dec.decodeSymbol(*changed_values_);
    if (changed & 32)
      put<std::uint16_t>(item, 12, static_cast<std::uint16_t>(ic_intensity_.decompress(dec, get<std::uint16_t>(last_, 12))));
    if (changed & 16) item[14] = static_cast<std::uint8_t>(dec.decodeSymbol(lazyModel(bit_byte_, last_[14], 256, true)));
    if (changed & 8) item[15] = static_cast<std::uint8_t>(dec.decodeSymbol(lazyModel(classification_, last_[15], 256, true)));
    if (changed & 4) item[16] = static_cast<std::uint8_t>(ic_scan_angle_.decompress(dec, last_[16], k < 3));
    if (changed & 2) item[17] = static_cast<std::uint8_t>(dec.decodeSymbol(lazyModel(user_data_, last_[17], 256, true)));
    if (changed & 1) put<std::uint16_t>(item, 18, static_cast<std::uint16_t>(ic_source_.decompress(dec, get<std::uint16_t>(last_, 18))));
    last_x_diff_[last_incr_] = x_diff;
    last_y_diff_[last_incr_] = y_diff;
    last_incr_ = (last_incr_ + 1) % 3;
    std::memcpy(last_, item, 20);
  }

 private:
  std::uint8_t last_[20] = {};
  std::int32_t last_x_diff_[3] = {}, last_y_diff_[3] = {};
  int last_incr_ = 0;
  IntegerCodec ic_dx_{32, 1}, ic_dy_{32, 20}, ic_z_{32, 20}, ic_intensity_{16, 1}, ic_scan_angle_{8, 2}, ic_source_{16, 1};
  ModelPtr changed_values_;
  std::array<ModelPtr, 256> bit_byte_, classification_, user_data_;
};

class GpsTime11V1 final : public DecodeOnly {
 public:
  void init(const std::uint8_t* item) override {
    m_multi_ = std::make_unique<SymbolModel>(kMultiMax, true);
    m_0diff_ = std::make_unique<SymbolModel>(3, true);
    ic_.init(true);
    last_diff_ = 0;
    extreme_ = 0;
    last_ = get<std::uint64_t>(item, 0);
  }
  void read(Decoder& dec, std::uint8_t* item) override {
    if (last_diff_ == 0) {
      const std::uint32_t multi = dec.decodeSymbol(*m_0diff_);
      if (multi == 1) {
        last_diff_ = ic_.decompress(dec, 0, 0);
        last_ += static_cast<std::uint64_t>(static_cast<std::int64_t>(last_diff_));
      } else if (multi == 2) {
        last_ = dec.readInt64();
      }
    } else {
      const int multi = static_cast<int>(dec.decodeSymbol(*m_multi_));
      if (multi < kMultiMax - 2) {
        std::int32_t d;
        if (multi == 1) {
          d = ic_.decompress(dec, last_diff_, 1);
          last_diff_ = d;
          extreme_ = 0;
        } else if (multi == 0) {
          d = ic_.decompress(dec, last_diff_ / 4, 2);
          if (++extreme_ > 3) {
            last_diff_ = d;
            extreme_ = 0;
          }
        } else {
          d = ic_.decompress(dec, wrapMul(multi, last_diff_), multi < 10 ? 3 : multi < 50 ? 4 : 5);
          if (multi == kMultiMax - 3 && ++extreme_ > 3) {
            last_diff_ = d;
            extreme_ = 0;
          }
        }
        last_ += static_cast<std::uint64_t>(static_cast<std::int64_t>(d));
      } else if (multi < kMultiMax - 1) {
        last_ = dec.readInt64();
      }
    }
    put<std::uint64_t>(item, 0, last_);
  }

 private:
  static constexpr int kMultiMax = 512;
  ModelPtr m_multi_, m_0diff_;
  IntegerCodec ic_{32, 6};
  std::int32_t last_diff_ = 0;
  int extreme_ = 0;
  std::uint64_t last_ = 0;
};

class Rgb12V1 final : public DecodeOnly {
 public:
  void init(const std::uint8_t* item) override {
    used_ = std::make_unique<SymbolModel>(64, true);
    ic_.init(true);
    std::memcpy(last_, item, 6);
  }
  void read(Decoder& dec, std::uint8_t* item) override {
    const std::uint32_t sym = dec.decodeSymbol(*used_);
    for (int b = 0; b < 6; ++b) {  // bytes low/high of r, g, b, each from the last value's byte
      item[b] = (sym & (1u << b)) ? static_cast<std::uint8_t>(ic_.decompress(dec, last_[b], static_cast<std::uint32_t>(b))) : last_[b];
    }
    std::memcpy(last_, item, 6);
  }

 private:
  ModelPtr used_;
  IntegerCodec ic_{8, 6};
  std::uint8_t last_[6] = {};
};

class ByteV1 final : public DecodeOnly {
 public:
  explicit ByteV1(std::size_t n) : last_(n), ic_(8, static_cast<std::uint32_t>(n)) {}
  void init(const std::uint8_t* item) override {
    ic_.init(true);
    std::memcpy(last_.data(), item, last_.size());
  }
  void read(Decoder& dec, std::uint8_t* item) override {
    for (std::size_t i = 0; i < last_.size(); ++i)
      item[i] = static_cast<std::uint8_t>(ic_.decompress(dec, last_[i], static_cast<std::uint32_t>(i)));
    std::memcpy(last_.data(), item, last_.size());
  }

 private:
  std::vector<std::uint8_t> last_;
  IntegerCodec ic_;
};

// ============================================================================================
// Version 3 layered items (LAS 1.4 point formats 6–8).
// ============================================================================================

/// The fields of a POINT14 record (30 bytes) the codec predicts.
struct P14 {
  std::int32_t x = 0, y = 0, z = 0;
  std::uint16_t intensity = 0;
  std::uint32_t return_number = 0, returns = 0, class_flags = 0, channel = 0, scan_dir = 0, edge = 0;
  std::uint32_t classification = 0, user_data = 0;
  std::int16_t scan_angle = 0;
  std::uint16_t source = 0;
  std::uint64_t gps = 0;
  bool gps_change = false;

  static P14 unpack(const std::uint8_t* b) {
    P14 p;
    p.x = get<std::int32_t>(b, 0);
    p.y = get<std::int32_t>(b, 4);
    p.z = get<std::int32_t>(b, 8);
    p.intensity = get<std::uint16_t>(b, 12);
    p.return_number = b[14] & 15u;
    p.returns = b[14] >> 4;
    p.class_flags = b[15] & 15u;
    p.channel = (b[15] >> 4) & 3u;
    p.scan_dir = (b[15] >> 6) & 1u;
    p.edge = b[15] >> 7;
    p.classification = b[16];
    p.user_data = b[17];
    p.scan_angle = get<std::int16_t>(b, 18);
    p.source = get<std::uint16_t>(b, 20);
    p.gps = get<std::uint64_t>(b, 22);
    return p;
  }
  void pack(std::uint8_t* b) const {
    put<std::int32_t>(b, 0, x);
    put<std::int32_t>(b, 4, y);
    put<std::int32_t>(b, 8, z);
    put<std::uint16_t>(b, 12, intensity);
    b[14] = static_cast<std::uint8_t>((return_number & 15u) | (returns << 4));
    b[15] = static_cast<std::uint8_t>((class_flags & 15u) | ((channel & 3u) << 4) | ((scan_dir & 1u) << 6) | ((edge & 1u) << 7));
    b[16] = static_cast<std::uint8_t>(classification);
    b[17] = static_cast<std::uint8_t>(user_data);
    put<std::int16_t>(b, 18, scan_angle);
    put<std::uint16_t>(b, 20, source);
    put<std::uint64_t>(b, 22, gps);
  }
};

/// The layers of one layered item: a decoder or an encoder per layer, and whether the layer
/// changes within the chunk (a layer stored empty repeats the chunk's first value).
struct LayerStreams {
  explicit LayerStreams(std::size_t n) : dec(n), enc(n), out(n), changed(n, 0) {}
  void startDecode(const std::uint8_t* const* data, const std::uint32_t* size) {
    for (std::size_t i = 0; i < dec.size(); ++i) {
      dec[i].init(data[i], data[i] + size[i]);
      changed[i] = size[i] > 0;
    }
  }
  void startEncode() {
    for (std::size_t i = 0; i < enc.size(); ++i) {
      out[i].clear();
      enc[i].init(&out[i]);  // `out` never grows: the pointer stays valid
      changed[i] = 0;
    }
  }
  bool overrun() const {
    for (std::size_t i = 0; i < dec.size(); ++i)
      if (changed[i] && dec[i].overrun() > 0) return true;
    return false;
  }
  /// One byte vector per layer, empty for a layer that never changed.
  std::vector<std::vector<std::uint8_t>> finish() {
    std::vector<std::vector<std::uint8_t>> layers(enc.size());
    for (std::size_t i = 0; i < enc.size(); ++i) {
      if (!changed[i]) continue;
      enc[i].done();
      layers[i] = std::move(out[i]);
    }
    return layers;
  }
  std::vector<Decoder> dec;
  std::vector<Encoder> enc;
  std::vector<std::vector<std::uint8_t>> out;
  std::vector<char> changed;
};

class Point14V3 final : public LayeredItem {
 public:
  static constexpr std::size_t kLayers = 9;  // XY+returns, Z, classification, flags, intensity, scan angle, user data, source, GPS time
  std::size_t layers() const override { return kLayers; }

  void initDecode(const std::uint8_t* item, std::uint32_t& context, const std::uint8_t* const* data, const std::uint32_t* size) override {
    decoder_ = true;
    io_.startDecode(data, size);
    io_.changed[0] = 1;  // the XY layer always decodes (an empty one is read past its end)
    start(item, context);
  }
  void initEncode(const std::uint8_t* item, std::uint32_t& context) override {
    decoder_ = false;
    io_.startEncode();
    io_.changed[0] = io_.changed[1] = 1;  // the XY and Z layers are always written
    start(item, context);
  }
  bool overrun() const override { return io_.overrun(); }

  void read(std::uint8_t* item, std::uint32_t& context) override {
    Ctx* c = &ctx_[current_];
    P14* last = &c->last;
    Decoder& xy = io_.dec[0];
    const std::uint32_t changed = xy.decodeSymbol(*c->changed_values[lastReturnContext(*last)]);
    if (changed & 64) {  // another scanner channel: its own models and last point
      const std::uint32_t channel = (current_ + xy.decodeSymbol(*c->scanner_channel) + 1) % 4;
      if (ctx_[channel].unused) createContext(channel, ctx_[current_].last);
      current_ = channel;
      context = channel;
      c = &ctx_[channel];
      last = &c->last;
      last->channel = channel;
    }
    const bool source_change = changed & 32, gps_change = changed & 16, angle_change = changed & 8;
    const std::uint32_t last_n = last->returns, last_r = last->return_number;
    std::uint32_t n = last_n;
    if (changed & 4) last->returns = n = xy.decodeSymbol(lazyModel(c->number_of_returns, last_n, 16, true));
    std::uint32_t r = last_r;
    switch (changed & 3) {
      case 1:
        r = (last_r + 1) % 16;
        break;
      case 2:
        r = (last_r + 15) % 16;
        break;
      case 3:
        if (gps_change)
          r = xy.decodeSymbol(lazyModel(c->return_number, last_r, 16, true));
        else
          r = (last_r + xy.decodeSymbol(*c->return_number_gps_same) + 2) % 16;
        break;
      default:
        break;
    }
    last->return_number = r;
    const std::uint32_t m = kReturnMap6[n][r], l = returnLevel8(n, r);
    const std::uint32_t cpr = (r == 1 ? 1u : 0u) + (r >= n ? 2u : 0u);  // first, last, single
    const std::uint32_t mi = (m << 1) | gps_change;
    std::int32_t diff = c->dx.decompress(xy, c->last_x_diff[mi].get(), n == 1);
    last->x = wrapAdd(last->x, diff);
    c->last_x_diff[mi].add(diff);
    std::uint32_t k = c->dx.k();
    diff = c->dy.decompress(xy, c->last_y_diff[mi].get(), (n == 1) + evenBelow(k, 20));
    last->y = wrapAdd(last->y, diff);
    c->last_y_diff[mi].add(diff);
    if (io_.changed[1]) {
      k = (c->dx.k() + c->dy.k()) / 2;
      last->z = c->z.decompress(io_.dec[1], c->last_z[l], (n == 1) + evenBelow(k, 18));
      c->last_z[l] = last->z;
    }
    if (io_.changed[2]) {
      const std::uint32_t ccc = ((last->classification & 0x1F) << 1) + (cpr == 3 ? 1 : 0);
      last->classification = io_.dec[2].decodeSymbol(lazyModel(c->classification, ccc, 256, true));
    }
    if (io_.changed[3]) {
      const std::uint32_t last_flags = (last->edge << 5) | (last->scan_dir << 4) | last->class_flags;
      const std::uint32_t flags = io_.dec[3].decodeSymbol(lazyModel(c->flags, last_flags, 64, true));
      last->edge = (flags >> 5) & 1u;
      last->scan_dir = (flags >> 4) & 1u;
      last->class_flags = flags & 15u;
    }
    if (io_.changed[4]) {
      const std::uint32_t ii = (cpr << 1) | gps_change;
      last->intensity = static_cast<std::uint16_t>(c->intensity.decompress(io_.dec[4], c->last_intensity[ii], cpr));
      c->last_intensity[ii] = last->intensity;
    }
    if (io_.changed[5] && angle_change)
      last->scan_angle =
          static_cast<std::int16_t>(static_cast<std::uint16_t>(c->scan_angle.decompress(io_.dec[5], last->scan_angle, gps_change)));
    if (io_.changed[6]) last->user_data = io_.dec[6].decodeSymbol(lazyModel(c->user_data, last->user_data / 4, 256, true));
    if (io_.changed[7] && source_change) last->source = static_cast<std::uint16_t>(c->source.decompress(io_.dec[7], last->source));
    if (io_.changed[8] && gps_change) {
      readGpsTime(c->gps, io_.dec[8], *c->gps_multi, *c->gps_0diff, c->gpstime, true);
      last->gps = c->gps.time[c->gps.last];
    }
    last->pack(item);
    last->gps_change = gps_change;
  }

  void write(const std::uint8_t* item, std::uint32_t& context) override {
    const P14 p = P14::unpack(item);
    Ctx* c = &ctx_[current_];
    P14* last = &c->last;
    const std::uint32_t lpr = lastReturnContext(*last);
    const bool channel_change = p.channel != current_;
    if (channel_change && !ctx_[p.channel].unused) last = &ctx_[p.channel].last;
    const bool source_change = p.source != last->source, gps_change = p.gps != last->gps, angle_change = p.scan_angle != last->scan_angle;
    const std::uint32_t last_n = last->returns, last_r = last->return_number, n = p.returns, r = p.return_number;
    std::uint32_t changed = (channel_change << 6) | (source_change << 5) | (gps_change << 4) | (angle_change << 3) | ((n != last_n) << 2);
    if (r != last_r) changed |= r == (last_r + 1) % 16 ? 1u : r == (last_r + 15) % 16 ? 2u : 3u;
    Encoder& xy = io_.enc[0];
    xy.encodeSymbol(*c->changed_values[lpr], changed);
    if (channel_change) {
      xy.encodeSymbol(*c->scanner_channel, (p.channel + 4 - current_) % 4 - 1);
      if (ctx_[p.channel].unused) {
        createContext(p.channel, ctx_[current_].last);
        last = &ctx_[p.channel].last;
      }
      current_ = p.channel;
      context = p.channel;
      c = &ctx_[current_];
    }
    if (changed & 4) xy.encodeSymbol(lazyModel(c->number_of_returns, last_n, 16, false), n);
    if ((changed & 3) == 3) {
      if (gps_change)
        xy.encodeSymbol(lazyModel(c->return_number, last_r, 16, false), r);
      else
        xy.encodeSymbol(*c->return_number_gps_same, (r + 16 - last_r) % 16 - 2);
    }
    const std::uint32_t m = kReturnMap6[n][r], l = returnLevel8(n, r);
    const std::uint32_t cpr = (r == 1 ? 1u : 0u) + (r >= n ? 2u : 0u);
    const std::uint32_t mi = (m << 1) | gps_change;
    std::int32_t diff = wrapSub(p.x, last->x);
    c->dx.compress(xy, c->last_x_diff[mi].get(), diff, n == 1);
    c->last_x_diff[mi].add(diff);
    std::uint32_t k = c->dx.k();
    diff = wrapSub(p.y, last->y);
    c->dy.compress(xy, c->last_y_diff[mi].get(), diff, (n == 1) + evenBelow(k, 20));
    c->last_y_diff[mi].add(diff);
    k = (c->dx.k() + c->dy.k()) / 2;
    c->z.compress(io_.enc[1], c->last_z[l], p.z, (n == 1) + evenBelow(k, 18));
    c->last_z[l] = p.z;
    if (p.classification != last->classification) io_.changed[2] = true;
    io_.enc[2].encodeSymbol(lazyModel(c->classification, ((last->classification & 0x1F) << 1) + (cpr == 3 ? 1 : 0), 256, false),
                            p.classification);
    const std::uint32_t last_flags = (last->edge << 5) | (last->scan_dir << 4) | last->class_flags;
    const std::uint32_t flags = (p.edge << 5) | (p.scan_dir << 4) | p.class_flags;
    if (flags != last_flags) io_.changed[3] = true;
    io_.enc[3].encodeSymbol(lazyModel(c->flags, last_flags, 64, false), flags);
    if (p.intensity != last->intensity) io_.changed[4] = true;
    const std::uint32_t ii = (cpr << 1) | gps_change;
    c->intensity.compress(io_.enc[4], c->last_intensity[ii], p.intensity, cpr);
    c->last_intensity[ii] = p.intensity;
    if (angle_change) {
      io_.changed[5] = true;
      c->scan_angle.compress(io_.enc[5], last->scan_angle, p.scan_angle, gps_change);
    }
    if (p.user_data != last->user_data) io_.changed[6] = true;
    io_.enc[6].encodeSymbol(lazyModel(c->user_data, last->user_data / 4, 256, false), p.user_data);
    if (source_change) {
      io_.changed[7] = true;
      c->source.compress(io_.enc[7], last->source, p.source);
    }
    if (gps_change) {
      io_.changed[8] = true;
      writeGpsTime(c->gps, io_.enc[8], *c->gps_multi, *c->gps_0diff, c->gpstime, true, p.gps);
    }
    *last = p;
    last->gps_change = gps_change;
  }

  std::vector<std::vector<std::uint8_t>> finish() override { return io_.finish(); }

 private:
  struct Ctx {
    bool unused = true;
    P14 last;
    std::uint16_t last_intensity[8] = {};
    Median5 last_x_diff[12], last_y_diff[12];
    std::int32_t last_z[8] = {};
    ModelPtr changed_values[8], scanner_channel, return_number_gps_same, gps_multi, gps_0diff;
    std::array<ModelPtr, 16> number_of_returns, return_number;
    std::array<ModelPtr, 64> classification, flags, user_data;
    IntegerCodec dx{32, 2}, dy{32, 22}, z{32, 20}, intensity{16, 4}, scan_angle{16, 2}, source{16, 1}, gpstime{32, 9};
    GpsTimeState gps;
  };

  static std::uint32_t lastReturnContext(const P14& last) {
    return (last.return_number == 1 ? 1u : 0u) + (last.return_number >= last.returns ? 2u : 0u) + (last.gps_change ? 4u : 0u);
  }

  void start(const std::uint8_t* item, std::uint32_t& context) {
    for (Ctx& c : ctx_) c.unused = true;
    const P14 p = P14::unpack(item);
    current_ = p.channel;
    context = current_;
    createContext(current_, p);
  }

  void createContext(std::uint32_t channel, const P14& from) {
    Ctx& c = ctx_[channel];
    for (auto& m : c.changed_values) m = std::make_unique<SymbolModel>(128, decoder_);
    c.scanner_channel = std::make_unique<SymbolModel>(3, decoder_);
    c.return_number_gps_same = std::make_unique<SymbolModel>(13, decoder_);
    c.gps_multi = std::make_unique<SymbolModel>(kMultiTotalV3, decoder_);
    c.gps_0diff = std::make_unique<SymbolModel>(5, decoder_);
    for (auto* a : {&c.number_of_returns, &c.return_number})
      for (auto& m : *a) m.reset();
    for (auto* a : {&c.classification, &c.flags, &c.user_data})
      for (auto& m : *a) m.reset();
    for (IntegerCodec* ic : {&c.dx, &c.dy, &c.z, &c.intensity, &c.scan_angle, &c.source, &c.gpstime}) ic->init(decoder_);
    for (int i = 0; i < 12; ++i) c.last_x_diff[i] = c.last_y_diff[i] = Median5{};
    for (int i = 0; i < 8; ++i) {
      c.last_z[i] = from.z;
      c.last_intensity[i] = from.intensity;
    }
    c.gps.reset(from.gps);
    c.last = from;
    c.last.gps_change = false;
    c.unused = false;
  }

  bool decoder_ = true;
  Ctx ctx_[4];
  std::uint32_t current_ = 0;
  LayerStreams io_{kLayers};
};

/// RGB14 and RGBNIR14 (layer RGB, and NIR for the latter). As in the reference, switching to a
/// scanner channel seen before keeps predicting from the previous channel's last colour.
class Rgb14V3 final : public LayeredItem {
 public:
  explicit Rgb14V3(bool nir) : nir_(nir), io_(nir ? 2 : 1) {}
  std::size_t layers() const override { return nir_ ? 2 : 1; }
  void initDecode(const std::uint8_t* item, std::uint32_t& context, const std::uint8_t* const* data, const std::uint32_t* size) override {
    decoder_ = true;
    io_.startDecode(data, size);
    start(item, context);
  }
  void initEncode(const std::uint8_t* item, std::uint32_t& context) override {
    decoder_ = false;
    io_.startEncode();
    start(item, context);
  }
  bool overrun() const override { return io_.overrun(); }
  void read(std::uint8_t* item, std::uint32_t& context) override {
    std::uint16_t* last = switchContext(context);
    Ctx& c = ctx_[current_];
    std::uint16_t v[4];
    if (io_.changed[0]) {
      c.rgb.read(io_.dec[0], last, v);
      std::memcpy(last, v, 6);
    } else {
      std::memcpy(v, last, 6);
    }
    if (nir_) {
      if (io_.changed[1]) {
        const std::uint32_t sym = io_.dec[1].decodeSymbol(*c.nir_used);
        v[3] = (sym & 1) ? fold(static_cast<int>(io_.dec[1].decodeSymbol(*c.nir_diff[0])) + (last[3] & 255)) : (last[3] & 0xFF);
        v[3] |= (sym & 2)
                    ? static_cast<std::uint16_t>(fold(static_cast<int>(io_.dec[1].decodeSymbol(*c.nir_diff[1])) + (last[3] >> 8)) << 8)
                    : (last[3] & 0xFF00);
        last[3] = v[3];
      } else {
        v[3] = last[3];
      }
    }
    storeU16(item, v, nir_ ? 4 : 3);
  }
  void write(const std::uint8_t* item, std::uint32_t& context) override {
    std::uint16_t* last = switchContext(context);
    Ctx& c = ctx_[current_];
    std::uint16_t v[4] = {};
    loadU16(item, v, nir_ ? 4 : 3);
    if (c.rgb.write(io_.enc[0], last, v) != 0) io_.changed[0] = true;
    if (nir_) {
      const std::uint32_t sym = ((last[3] & 0x00FF) != (v[3] & 0x00FF)) | (((last[3] & 0xFF00) != (v[3] & 0xFF00)) << 1);
      io_.enc[1].encodeSymbol(*c.nir_used, sym);
      if (sym & 1) io_.enc[1].encodeSymbol(*c.nir_diff[0], fold((v[3] & 255) - (last[3] & 255)));
      if (sym & 2) io_.enc[1].encodeSymbol(*c.nir_diff[1], fold((v[3] >> 8) - (last[3] >> 8)));
      if (sym) io_.changed[1] = true;
    }
    std::memcpy(last, v, nir_ ? 8 : 6);
  }
  std::vector<std::vector<std::uint8_t>> finish() override { return io_.finish(); }

 private:
  struct Ctx {
    bool unused = true;
    std::uint16_t last[4] = {};
    RgbModels rgb;
    ModelPtr nir_used, nir_diff[2];
  };
  void start(const std::uint8_t* item, std::uint32_t context) {
    for (Ctx& c : ctx_) c.unused = true;
    current_ = context & 3u;
    std::uint16_t v[4] = {};
    loadU16(item, v, nir_ ? 4 : 3);
    createContext(current_, v);
  }
  void createContext(std::uint32_t channel, const std::uint16_t* from) {
    Ctx& c = ctx_[channel];
    c.rgb.create(decoder_);
    c.nir_used = std::make_unique<SymbolModel>(4, decoder_);
    c.nir_diff[0] = std::make_unique<SymbolModel>(256, decoder_);
    c.nir_diff[1] = std::make_unique<SymbolModel>(256, decoder_);
    std::memmove(c.last, from, 8);
    c.unused = false;
  }
  std::uint16_t* switchContext(std::uint32_t context) {
    std::uint16_t* last = ctx_[current_].last;
    if (current_ != context) {
      current_ = context & 3u;
      if (ctx_[current_].unused) {
        createContext(current_, last);
        last = ctx_[current_].last;
      }
    }
    return last;
  }

  bool nir_;
  bool decoder_ = true;
  Ctx ctx_[4];
  std::uint32_t current_ = 0;
  LayerStreams io_;
};

/// BYTE14: one layer per extra byte, each a difference to the last value of its context (with
/// the reference's channel-switch behaviour, as for RGB14).
class Byte14V3 final : public LayeredItem {
 public:
  explicit Byte14V3(std::size_t n) : n_(n), io_(n) {}
  std::size_t layers() const override { return n_; }
  void initDecode(const std::uint8_t* item, std::uint32_t& context, const std::uint8_t* const* data, const std::uint32_t* size) override {
    decoder_ = true;
    io_.startDecode(data, size);
    start(item, context);
  }
  void initEncode(const std::uint8_t* item, std::uint32_t& context) override {
    decoder_ = false;
    io_.startEncode();
    start(item, context);
  }
  bool overrun() const override { return io_.overrun(); }
  void read(std::uint8_t* item, std::uint32_t& context) override {
    std::uint8_t* last = switchContext(context);
    Ctx& c = ctx_[current_];
    for (std::size_t i = 0; i < n_; ++i) {
      if (io_.changed[i]) last[i] = fold(last[i] + static_cast<int>(io_.dec[i].decodeSymbol(*c.models[i])));
      item[i] = last[i];
    }
  }
  void write(const std::uint8_t* item, std::uint32_t& context) override {
    std::uint8_t* last = switchContext(context);
    Ctx& c = ctx_[current_];
    for (std::size_t i = 0; i < n_; ++i) {
      if (item[i] != last[i]) io_.changed[i] = true;
      io_.enc[i].encodeSymbol(*c.models[i], fold(item[i] - last[i]));
      last[i] = item[i];
    }
  }
  std::vector<std::vector<std::uint8_t>> finish() override { return io_.finish(); }

 private:
  struct Ctx {
    bool unused = true;
    std::vector<std::uint8_t> last;
    std::vector<ModelPtr> models;
  };
  void start(const std::uint8_t* item, std::uint32_t context) {
    for (Ctx& c : ctx_) c.unused = true;
    current_ = context & 3u;
    createContext(current_, item);
  }
  void createContext(std::uint32_t channel, const std::uint8_t* from) {
    Ctx& c = ctx_[channel];
    c.models.clear();
    for (std::size_t i = 0; i < n_; ++i) c.models.push_back(std::make_unique<SymbolModel>(256, decoder_));
    std::vector<std::uint8_t> copy(from, from + n_);  // `from` may be another context's buffer
    c.last = std::move(copy);
    c.unused = false;
  }
  std::uint8_t* switchContext(std::uint32_t context) {
    std::uint8_t* last = ctx_[current_].last.data();
    if (current_ != context) {
      current_ = context & 3u;
      if (ctx_[current_].unused) {
        createContext(current_, last);
        last = ctx_[current_].last.data();
      }
    }
    return last;
  }

  std::size_t n_;
  bool decoder_ = true;
  Ctx ctx_[4];
  std::uint32_t current_ = 0;
  LayerStreams io_;
};

}  // namespace

std::unique_ptr<PointwiseItem> makePointwiseItem(const LazItem& item, bool decoder) {
  const bool v1 = item.version == 1;
  if (v1 && !decoder) throw Corrupt{"version 1 items cannot be written"};
  switch (item.type) {
    case LazItem::kPoint10:
      return v1 ? std::unique_ptr<PointwiseItem>(new Point10V1) : std::make_unique<Point10V2>(decoder);
    case LazItem::kGpsTime11:
      return v1 ? std::unique_ptr<PointwiseItem>(new GpsTime11V1) : std::make_unique<GpsTime11V2>(decoder);
    case LazItem::kRgb12:
      return v1 ? std::unique_ptr<PointwiseItem>(new Rgb12V1) : std::make_unique<Rgb12V2>(decoder);
    case LazItem::kByte:
      return v1 ? std::unique_ptr<PointwiseItem>(new ByteV1(item.size)) : std::make_unique<ByteV2>(item.size, decoder);
    default:
      throw Corrupt{"item " + lazItemName(item.type) + " is not a point-wise item"};
  }
}

std::unique_ptr<LayeredItem> makeLayeredItem(const LazItem& item) {
  switch (item.type) {
    case LazItem::kPoint14:
      return std::make_unique<Point14V3>();
    case LazItem::kRgb14:
      return std::make_unique<Rgb14V3>(false);
    case LazItem::kRgbNir14:
      return std::make_unique<Rgb14V3>(true);
    case LazItem::kByte14:
      return std::make_unique<Byte14V3>(item.size);
    default:
      throw Corrupt{"item " + lazItemName(item.type) + " is not a layered item"};
  }
}

}  // namespace mountcal::io::laz
