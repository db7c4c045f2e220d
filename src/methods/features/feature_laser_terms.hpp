#pragma once
// Internal (not installed): the per-laser intrinsics' share of a features view's centre
// (FeatureObservations::View::LaserTerm::K_all), linear in vec(R_bs) and exact for every group.

#include <vector>

#include "mountcal/core/sensor_model.hpp"

namespace mountcal::detail {

/// One laser's 16 matrices of View::LaserTerm::K_all, each 3×9 and linear in vec(R_bs).
using FeatureLaserTerms = std::vector<Eigen::Matrix<double, 3, 9>>;

/// Adds one point's share (its weight times R_mb, `WR`) to `K` (16 matrices, created zero when
/// empty): the vectors f ∈ {r, u, r/ρ, u/ρ, p} of `ray`, each plain (at 3 f), projected by
/// P = diag(1, 1, 0) (3 f + 1) and turned by Z (3 f + 2) — LaserCorrector's R_z(δα) = I +
/// (cos δα − 1) P + sin δα Z —, then e_z (15).
void addFeatureLaserTerms(const Mat3& WR, const LaserRay& ray, FeatureLaserTerms* K);

/// The matrix M with Σ_j W_j R_mb,j R_bs (r'_j − r_j) = M vec(R_bs) over the points whose shares
/// `K` holds, r'_j = LaserCorrector(c)(r_j) (exactly: r' = R_z(δα) [(1 + δρ/ρ)(cos δω r +
/// sin δω u) + δH p] + δV e_z).
Eigen::Matrix<double, 3, 9> featureLaserTermMatrix(const FeatureLaserTerms& K, const LaserCorrection& c);

}  // namespace mountcal::detail
