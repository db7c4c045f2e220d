#pragma once
// Internal (not installed): sine and cosine of many angles in a loop the compiler vectorises,
// for the batch georeferencing of scanner angles. A pulse's laser vector needs one sin and one
// cos; libm's are one call per angle and dominate the batch (issue 13's profile: 29 %).
//
// Method (the textbook one, e.g. Muller, "Elementary Functions", ch. 11):
//   q = nearest integer to θ·2/π,  r = θ − q·π/2 ∈ [−π/4, π/4]   (Cody–Waite: π/2 in three
//   parts, the first with 33 significant bits so that q·P1 is exact for |q| < 2²⁰),
//   sin r, cos r by their Taylor series to r¹⁵ and r¹⁶ (remainders (π/4)¹⁷/17! ≈ 5e-17 and
//   (π/4)¹⁸/18! ≈ 2e-18), then the quadrant q mod 4 picks (±sin r, ±cos r).
// Every step is branch-free arithmetic and selects on doubles, so the loop vectorises with SSE2
// and wider. Agrees with std::sin / std::cos within 4e-16 (test Georeference.SinCosBatch...).
// Angles beyond ±kMaxFastAngle_rad, or not finite, take std::sin / std::cos.

#include <cmath>
#include <cstddef>

namespace mountcal::detail {

inline constexpr double kMaxFastAngle_rad = 1.0e5;

/// s[k] = sin(θ[k]), c[k] = cos(θ[k]) for k < n. s, c and θ must not overlap.
inline void sinCosBatch(const double* __restrict theta, double* __restrict s, double* __restrict c, std::size_t n) {
  constexpr double kTwoOverPi = 6.36619772367581382433e-01;
  constexpr double kP1 = 1.57079632673412561417e+00;  // π/2: first 33 bits
  constexpr double kP2 = 6.07710050650619224932e-11;  // the next 33 bits
  constexpr double kP3 = 2.02226624879595063154e-21;  // the rest
  constexpr double kRound = 6755399441055744.0;       // 1.5·2⁵²: x + kRound − kRound rounds x to an integer
  bool all_fast = true;
  for (std::size_t k = 0; k < n; ++k) all_fast &= (std::fabs(theta[k]) <= kMaxFastAngle_rad);
  if (!all_fast) {
    for (std::size_t k = 0; k < n; ++k) {
      s[k] = std::sin(theta[k]);
      c[k] = std::cos(theta[k]);
    }
    return;
  }
  for (std::size_t k = 0; k < n; ++k) {
    const double x = theta[k];
    const double q = (x * kTwoOverPi + kRound) - kRound;
    const double r = ((x - q * kP1) - q * kP2) - q * kP3;
    const double r2 = r * r;
    // Taylor series, Horner in r²: sin r = r(1 − r²/3! + r⁴/5! − … − r¹⁴/15!)
    const double sp =
        1.0 +
        r2 * (-1.0 / 6 +
              r2 * (1.0 / 120 + r2 * (-1.0 / 5040 + r2 * (1.0 / 362880 + r2 * (-1.0 / 39916800 +
                                                                               r2 * (1.0 / 6227020800 + r2 * (-1.0 / 1307674368000)))))));
    // cos r = 1 − r²/2! + r⁴/4! − … + r¹⁶/16!
    const double cp =
        1.0 +
        r2 * (-0.5 + r2 * (1.0 / 24 +
                           r2 * (-1.0 / 720 + r2 * (1.0 / 40320 +
                                                    r2 * (-1.0 / 3628800 + r2 * (1.0 / 479001600 + r2 * (-1.0 / 87178291200 +
                                                                                                         r2 * (1.0 / 20922789888000))))))));
    const double sr = r * sp;
    // the quadrant: qm = q − 4·round(q/4) ∈ {−2, −1, 0, 1, 2}; −1 ≡ 3 and ±2 ≡ 2 (mod 4)
    const double qm = q - 4.0 * ((q * 0.25 + kRound) - kRound);
    const bool odd = (qm == 1.0) | (qm == -1.0);         // quadrants 1, 3: sin θ = ±cos r
    const bool sin_negative = (qm < 0.0) | (qm > 1.5);   // quadrants 2, 3
    const bool cos_negative = (qm > 0.5) | (qm < -1.5);  // quadrants 1, 2
    const double sa = odd ? cp : sr;
    const double ca = odd ? sr : cp;
    s[k] = sin_negative ? -sa : sa;
    c[k] = cos_negative ? -ca : ca;
  }
}

}  // namespace mountcal::detail
