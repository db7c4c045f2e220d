#pragma once
// Internal (not installed): normal deviates drawn in batches, for the simulator's pulse loop,
// which takes two per return (range and scan-angle noise). Rng::normal() — Marsaglia's polar
// method with a libm logarithm — was 15 % of the simulator's time (issue 13's profile).
//
// A batch draws its (u, v) pairs exactly as Rng::normal() does (two uniforms, rejected unless
// 0 < q = u² + v² < 1) and hands the deviates out in the same order (u·f, then v·f), so the
// stream is Rng::normal()'s; only f = √(−2 ln q / q) is computed for the whole batch in one
// loop the compiler vectorises, with the logarithm below instead of libm's (within 2 units in
// the last place of it: tests/test_simulator.cpp, Simulator.BatchedNormalsFollowTheRngStream).

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "core/random.hpp"

namespace mountcal::detail {

/// ln x for n positive, finite, normal doubles (no zeros, subnormals, infinities or NaNs).
/// x = 2^e · m with m ∈ [√½, √2), ln m = 2 atanh z = 2(z + z³/3 + … + z²³/23), z = (m − 1)/(m + 1),
/// |z| ≤ 0.1716: the series' remainder is below 1e-19 (e.g. Muller, "Elementary Functions").
inline void logBatch(const double* __restrict x, double* __restrict out, std::size_t n) {
  constexpr double kLn2Hi = 6.93147180369123816490e-01;  // ln 2 in two parts (fdlibm's split)
  constexpr double kLn2Lo = 1.90821492927058770002e-10;
  // Integer arithmetic on the bits only (no comparisons: they would keep the loop scalar):
  // u = bits(x) + (bits(1) − bits(√½)) carries into the exponent field exactly when m ≥ √2, so
  // the exponent field of u is e + 1023 and bits(x) − ((e) << 52) is m ∈ [√½, √2).
  constexpr std::uint64_t kOne = 0x3ff0000000000000ull, kSqrtHalf = 0x3fe6a09e667f3bcdull;
  constexpr std::uint64_t kExponent = 0xfff0000000000000ull;
  constexpr std::uint64_t kMagic = 0x4330000000000000ull;  // 2⁵²: (2⁵² + E) − 2⁵² = E exactly
  for (std::size_t k = 0; k < n; ++k) {
    std::uint64_t bits;
    std::memcpy(&bits, &x[k], 8);
    const std::uint64_t u = bits + (kOne - kSqrtHalf);
    const std::uint64_t mbits = bits - ((u & kExponent) - kOne);
    const std::uint64_t ebits = (u >> 52) | kMagic;
    double m, eb;
    std::memcpy(&m, &mbits, 8);
    std::memcpy(&eb, &ebits, 8);
    const double e = (eb - 4503599627370496.0) - 1023.0;
    const double z = (m - 1.0) / (m + 1.0);  // m − 1 is exact (Sterbenz)
    const double w = z * z;
    const double p =
        w * (1.0 / 3 +
             w * (1.0 / 5 +
                  w * (1.0 / 7 +
                       w * (1.0 / 9 +
                            w * (1.0 / 11 +
                                 w * (1.0 / 13 + w * (1.0 / 15 + w * (1.0 / 17 + w * (1.0 / 19 + w * (1.0 / 21 + w * (1.0 / 23)))))))))));
    const double two_z = 2.0 * z;
    out[k] = e * kLn2Hi + (e * kLn2Lo + (two_z + two_z * p));
  }
}

/// Rng::normal()'s stream, drawn kPairs pairs at a time. Take every deviate of the Rng through
/// one BufferedNormals (it draws ahead).
class BufferedNormals {
 public:
  explicit BufferedNormals(Rng* rng) : rng_(rng) {}
  double next() {
    if (pos_ == 2 * kPairs) refill();
    return out_[pos_++];
  }

 private:
  static constexpr std::size_t kPairs = 256;
  void refill() {
    // Rng::normal()'s draws in order; a rejected pair is overwritten by the next one (no branch
    // on the acceptance, which a fifth of the pairs fail at random).
    for (std::size_t j = 0; j < kPairs;) {
      const double u = 2.0 * rng_->uniform() - 1.0;
      const double v = 2.0 * rng_->uniform() - 1.0;
      const double q = u * u + v * v;
      u_[j] = u;
      v_[j] = v;
      q_[j] = q;
      j += static_cast<std::size_t>((q < 1.0) & (q != 0.0));
    }
    logBatch(q_, log_, kPairs);
    for (std::size_t j = 0; j < kPairs; ++j) {
      const double f = std::sqrt(-2.0 * log_[j] / q_[j]);
      out_[2 * j] = u_[j] * f;
      out_[2 * j + 1] = v_[j] * f;
    }
    pos_ = 0;
  }
  Rng* rng_;
  std::size_t pos_ = 2 * kPairs;
  double u_[kPairs], v_[kPairs], q_[kPairs], log_[kPairs], out_[2 * kPairs];
};

}  // namespace mountcal::detail
