#pragma once
// Internal (not installed): the dense matching of CorrespondenceOptions::dense and its exact
// point-to-plane residual with analytic derivatives.

#include <ceres/ceres.h>

#include <array>
#include <memory>
#include <vector>

#include "mountcal/data.hpp"
#include "mountcal/core/sensor_model.hpp"
#include "geometry/column_grid.hpp"
#include "methods/common/laser_intrinsics.hpp"
#include "mountcal/methods/correspondence/correspondences.hpp"

namespace mountcal::detail {

/// A correspondence found by DenseMatcher and the index of its strip pair's statistics.
struct DenseCandidate {
  Correspondence c;
  std::size_t pair;
};

/// Matches every strip pair in both directions at the current estimate.
class DenseMatcher {
 public:
  /// Throws InvalidInput for strips without per-point poses or a trajectory, inconsistent
  /// lengths, or laser ids on some strips only.
  DenseMatcher(const CalibrationData& data, const CorrespondenceOptions& options);

  /// The positions of every point at mounting m (MountingIndex order) and laser offsets dl,
  /// moved by the last solve's strip offsets, corrections and time offset.
  void place(const std::array<double, 6>& m, const LaserCorrections& lasers, const PointShifts& shifts);
  const Vec3& x(int s, std::size_t i) const { return x_[static_cast<std::size_t>(s)][i]; }
  const Mat3& R_mb(int s, std::size_t i) const { return R_mb_[static_cast<std::size_t>(s)][i]; }
  const Vec3& p_m(int s, std::size_t i) const { return p_m_[static_cast<std::size_t>(s)][i]; }
  int laser(int s, std::size_t i) const {
    const auto& l = data_.strips[static_cast<std::size_t>(s)].laser;
    return l.empty() ? -1 : static_cast<int>(l[i]);
  }
  int laserCount() const { return lasers_; }

  /// One matching at the positions of the last place(): coarse or fine stage, with the fine
  /// stage's current distance gate [m].
  CorrespondenceSet match(bool coarse, double fine_gate_m);

 private:
  void buildGrids(std::size_t k, CorrespondenceSet* out);
  void keepConsistent(bool coarse, std::size_t k, std::vector<DenseCandidate>* candidates, CorrespondenceSet* out) const;

  const CalibrationData& data_;
  CorrespondenceOptions o_;
  int lasers_ = 0;
  std::vector<std::vector<Vec3>> x_, p_m_;
  std::vector<std::vector<Mat3>> R_mb_;
  Vec3 origin_ = Vec3::Zero();
  double spacing_ = 0.0;                        // the strips' largest plan spacing at the mounting used [m]
  std::vector<ColumnGrid> grid_;                // each strip's kept points at this round's positions − origin_
  std::vector<std::vector<std::size_t>> keep_;  // each strip's points after thinning
};

/// r = n · [(x_A + o_A) − mean_j (x_Bj + o_B)] / σ with x = p_m + R_mb (R_zyx(b) R_nom r'(θ_l) + a),
/// r' the laser vector corrected by its laser's intrinsics θ_l (LaserCorrector), exact, with
/// analytic derivatives. Parameter blocks: mounting (6), o_A (3), o_B (3), and the per-laser
/// intrinsics (LaserLayout) when estimated.
class DenseResidual final : public ceres::CostFunction {
 public:
  struct Point {
    Vec3 p_m, r_s;
    Mat3 R_mb;
    int laser = -1;
    double weight = 1.0;  // 1 for A, −1/k for each of B's k points
  };
  DenseResidual(const std::vector<Point>& points, const Vec3& normal, const Mat3& R_nom, double sigma_m, const LaserLayout& layout);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  // Σ w n·x = c + h·a + Σ_l [cos δ_l tr(G_lᵀ R_b) + sin δ_l tr(U_lᵀ R_b)], exactly, with
  // c = Σ w n·p_m, h = Σ w R_mbᵀ n, and per laser l (δ = 0 for points without one)
  // G_l = Σ_{q∈l} w (R_mbᵀ n)(R_nom r)ᵀ, U_l = Σ_{q∈l} w (R_mbᵀ n)(R_nom u)ᵀ (u: elevationTangent)
  // — with elevation offsets alone (or none). With other groups each point is corrected in turn:
  // Σ_q (w R_mbᵀ n)ᵀ R_b R_nom r'_q(θ_l).
  struct LaserTerm {
    int laser = -1;
    Mat3 G = Mat3::Zero(), U = Mat3::Zero();
  };
  struct RayTerm {
    int laser = -1;
    Vec3 nR = Vec3::Zero();  // w R_mbᵀ n
    LaserRay ray{Vec3::Zero()};
  };
  bool evaluateRays(const double* intrinsics, const Mat3& Rb, const std::array<Mat3, 3>& dR, double* v, double* jm, double* jl) const;
  double c_ = 0.0;
  Vec3 h_ = Vec3::Zero();
  std::vector<LaserTerm> terms_;
  std::vector<RayTerm> rays_;
  Vec3 n_;
  Mat3 R_nom_;
  double inv_sigma_;
  LaserLayout layout_;
};

}  // namespace mountcal::detail
