#pragma once
// "|error| < 3σ" cannot fail when σ is overstated: a test that checks it over seeds also bounds
// the scatter from below. With honest σ, Σ (error/σ)² over n independent values is χ²(n); an
// RMS of error/σ below 0.3 then has probability P(χ²(n) < 0.09 n): 2e-3 for n = 6, 2e-7 for
// n = 18 (correlated parameters count as fewer values: 2e-4 for n = 9). A σ overstated three
// times gives an RMS near 0.33.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

namespace mountcal_tests {

class ScatterOfErrors {
 public:
  void add(double error, double sigma) {
    if (std::isfinite(sigma) && sigma > 0) z_.push_back(error / sigma);
  }
  std::size_t size() const { return z_.size(); }
  double rms() const {
    double s = 0;
    for (double z : z_) s += z * z;
    return z_.empty() ? 0.0 : std::sqrt(s / static_cast<double>(z_.size()));
  }
  /// The upper bound (RMS of error/σ below 1.6): with honest σ, P(χ²(18) > 2.56 · 18) = 2e-4
  /// (P(χ²(6) > 2.56 · 6) = 0.013); σ understated by 1.6 or more fail it about half the time.
  void expectNotUnderstated(const std::string& what) const {
    ASSERT_GE(z_.size(), 6u) << what << ": too few values to bound the scatter";
    EXPECT_LT(rms(), 1.6) << what << ": the RMS of error/σ over " << z_.size() << " values is " << rms() << " — σ understated";
  }
  /// The lower bound (RMS of error/σ above 0.3), with `what` in the message.
  void expectNotOverstated(const std::string& what) const {
    ASSERT_GE(z_.size(), 6u) << what << ": too few values to bound the scatter";
    EXPECT_GT(rms(), 0.3) << what << ": the RMS of error/σ over " << z_.size() << " values is " << rms()
                          << " — σ overstated (an |error| < 3σ bound alone cannot see it)";
  }

 private:
  std::vector<double> z_;
};

}  // namespace mountcal_tests
