#pragma once
// Internal: the adaptive arithmetic (range) coder and the integer corrector coder of LAZ.
//
// The LAZ format codes every field with the range coder of A. Said ("Comparative analysis of
// arithmetic coding computational complexity", HP Labs 2004) with adaptive bit and symbol
// models, and integers as a prediction plus a corrector: the corrector's bit length k is coded
// with a symbol model, then its value within [-(2^k - 1), 2^k] with a per-k model (the high
// bits) and raw bits (the low bits). The constants below are part of the format: a decoder
// must reproduce the models' adaptation exactly. Written from the LAZ specification and the
// behaviour of LASzip; a decoder never reads outside the buffer it was given.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace mountcal::io::laz {

/// Thrown by the coders on impossible data; the chunk decoder turns it into a FileError.
struct Corrupt {
  std::string what;
};

constexpr std::uint32_t kMinLength = 0x01000000u;  // renormalise below 2^24
constexpr std::uint32_t kMaxLength = 0xFFFFFFFFu;
constexpr std::uint32_t kBitShift = 13;  // bit model probabilities in 2^-13
constexpr std::uint32_t kBitMaxCount = 1u << kBitShift;
constexpr std::uint32_t kSymShift = 15;  // symbol model distributions in 2^-15
constexpr std::uint32_t kSymMaxCount = 1u << kSymShift;

/// Adaptive binary model.
struct BitModel {
  BitModel() { init(); }
  void init() {
    zero_count = 1;
    count = 2;
    zero_prob = 1u << (kBitShift - 1);
    cycle = until_update = 4;
  }
  void update() {
    if ((count += cycle) > kBitMaxCount) {  // halve the counts at the threshold
      count = (count + 1) >> 1;
      zero_count = (zero_count + 1) >> 1;
      if (zero_count == count) ++count;
    }
    const std::uint32_t scale = 0x80000000u / count;
    zero_prob = (zero_count * scale) >> (31 - kBitShift);
    cycle = (5 * cycle) >> 2;
    if (cycle > 64) cycle = 64;
    until_update = cycle;
  }
  std::uint32_t zero_count, count, zero_prob, cycle, until_update;
};

/// Adaptive model over `symbols` symbols (2 ≤ symbols ≤ 2048); a decoder's model keeps a lookup
/// table when it has more than 16 symbols.
class SymbolModel {
 public:
  SymbolModel(std::uint32_t symbols, bool decoder);
  void init();
  void update();
  std::uint32_t symbols() const { return n_; }

  std::uint32_t n_, last_;
  std::uint32_t table_size_ = 0, table_shift_ = 0;
  std::uint32_t total_ = 0, cycle_ = 0, until_update_ = 0;
  std::vector<std::uint32_t> dist_, count_, table_;
};

/// Range decoder over a byte span; bytes past the end read as 0 and are counted (overrun()).
class Decoder {
 public:
  void init(const std::uint8_t* begin, const std::uint8_t* end);
  std::uint32_t decodeBit(BitModel& m);
  std::uint32_t decodeSymbol(SymbolModel& m);
  std::uint32_t readBits(std::uint32_t bits);
  std::uint32_t readShort();
  std::uint32_t readInt();
  std::uint64_t readInt64();
  std::size_t overrun() const { return overrun_; }

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
};

/// Range encoder appending to a byte vector.
class Encoder {
 public:
  void init(std::vector<std::uint8_t>* out);
  void encodeBit(BitModel& m, std::uint32_t bit);
  void encodeSymbol(SymbolModel& m, std::uint32_t sym);
  void writeBits(std::uint32_t bits, std::uint32_t value);
  void writeShort(std::uint32_t value);
  void writeInt(std::uint32_t value);
  void writeInt64(std::uint64_t value);
  /// Flushes the state; the decoder then reads exactly the bytes written.
  void done();

 private:
  void carry();
  void renorm();
  std::vector<std::uint8_t>* out_ = nullptr;
  std::size_t start_ = 0;
  std::uint32_t base_ = 0, length_ = kMaxLength;
};

/// Prediction-corrector coder of integers of `bits` bits with `contexts` contexts.
class IntegerCodec {
 public:
  explicit IntegerCodec(std::uint32_t bits = 16, std::uint32_t contexts = 1, std::uint32_t bits_high = 8);
  void init(bool decoder);  ///< (re)creates the models
  std::int32_t decompress(Decoder& dec, std::int32_t pred, std::uint32_t context = 0);
  void compress(Encoder& enc, std::int32_t pred, std::int32_t real, std::uint32_t context = 0);
  /// Bit length of the last corrector (a context for the next field).
  std::uint32_t k() const { return k_; }

 private:
  std::uint32_t bits_, contexts_, bits_high_;
  std::uint32_t corr_bits_;
  std::int64_t corr_range_, corr_min_, corr_max_;
  std::uint32_t k_ = 0;
  std::vector<std::unique_ptr<SymbolModel>> m_bits_;
  BitModel m_corrector0_;
  std::vector<std::unique_ptr<SymbolModel>> m_corrector_;  // index 1..corr_bits
};

/// Running median of the last five values (the x/y difference predictor).
struct Median5 {
  std::int32_t v[5] = {0, 0, 0, 0, 0};
  bool high = true;
  std::int32_t get() const { return v[2]; }
  void add(std::int32_t x);
};

}  // namespace mountcal::io::laz
