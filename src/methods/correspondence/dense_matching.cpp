#include "dense_matching.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <unordered_set>

#include "../common/strip_geometry.hpp"
#include "mountcal/core/error.hpp"
#include "mountcal/core/rotation.hpp"

namespace mountcal::detail {

namespace {

// Single precision in the grids: coordinates relative to one origin within a few hundred
// metres resolve to micrometres; planes and distances use the double positions.

/// ∂R_zyx(b)/∂b_k (R = Rz(κ)·Ry(φ)·Rx(ω); d/dθ exp(θ[e]×) = [e]× exp(θ[e]×)).
std::array<Mat3, 3> dRzyx(const Vec3& b) {
  auto hat = [](const Vec3& e) {
    Mat3 h;
    h << 0, -e.z(), e.y(), e.z(), 0, -e.x(), -e.y(), e.x(), 0;
    return h;
  };
  const Mat3 X = Rx(b.x()), Y = Ry(b.y()), Z = Rz(b.z());
  return {Z * Y * X * hat(Vec3::UnitX()), Z * Y * hat(Vec3::UnitY()) * X, hat(Vec3::UnitZ()) * Z * Y * X};
}

}  // namespace

DenseMatcher::DenseMatcher(const CalibrationData& data, const CorrespondenceOptions& options) : data_(data), o_(options) {
  data.requirePoses();
  const std::size_t n = data.strips.size();
  x_.resize(n);
  p_m_.resize(n);
  R_mb_.resize(n);
  bool any_laser = false, all_laser = true;
  for (std::size_t s = 0; s < n; ++s) {
    const StripData& st = data.strips[s];
    if (st.r_s.size() != st.time_s.size()) throw InvalidInput("strip '" + st.id + "': time and r_s must have the same length");
    if (!st.laser.empty() && st.laser.size() != st.r_s.size())
      throw InvalidInput("strip '" + st.id + "': laser ids and points differ in number");
    any_laser |= !st.laser.empty();
    all_laser &= !st.laser.empty();
    for (std::uint16_t l : st.laser) lasers_ = std::max(lasers_, static_cast<int>(l) + 1);
    p_m_[s].resize(st.r_s.size());
    R_mb_[s].resize(st.r_s.size());
    std::size_t cursor = 0;
    for (std::size_t i = 0; i < st.r_s.size(); ++i) {
      const Pose pose = data.pose(st, i, &cursor);
      p_m_[s][i] = pose.p_m;
      R_mb_[s][i] = pose.R_mb;
    }
  }
  if (options.estimatesLaserIntrinsics() && !all_laser) {
    throw InvalidInput(any_laser ? "per-laser intrinsics: some strips have laser ids and some do not"
                                 : "per-laser intrinsics need each point's laser id (job key sensor.laser_field)");
  }
  if (n && !p_m_[0].empty()) origin_ = p_m_[0][0];
  // A strip denser than thin_cell_m is thinned to one point per cubic cell of that size (the
  // first in file order): its neighbourhoods then span the same few centimetres in every
  // strip, and the grids stay small. Residuals use the kept points only.
  keep_.resize(n);
  for (std::size_t s = 0; s < n; ++s) {
    const std::vector<Vec3> x0 = referencePoints(data, data.strips[s], data.mounting_used);
    spacing_ = std::max(spacing_, planSpacing(x0));
    std::unordered_set<std::int64_t> cells;
    const double cell = options.thin_cell_m;
    for (std::size_t i = 0; i < x0.size(); ++i) {
      if (cell > 0) {
        const Vec3 q = (x0[i] - origin_) / cell;
        const std::int64_t key = ((static_cast<std::int64_t>(std::floor(q.x())) & 0x1fffff) << 42) |
                                 ((static_cast<std::int64_t>(std::floor(q.y())) & 0x1fffff) << 21) |
                                 (static_cast<std::int64_t>(std::floor(q.z())) & 0x1fffff);
        if (!cells.insert(key).second) continue;
      }
      keep_[s].push_back(i);
    }
  }
}

void DenseMatcher::place(const std::array<double, 6>& m, const LaserCorrections& lasers, const PointShifts& shifts) {
  const MountingParameters& used = data_.mounting_used;
  const Mat3 R_bs = R_zyx(Vec3(m[3], m[4], m[5])) * used.R_nom;
  const Vec3 a(m[0], m[1], m[2]);
  const std::vector<LaserCorrector> correct = laserCorrectors(lasers);
  for (std::size_t s = 0; s < x_.size(); ++s) {
    const StripData& st = data_.strips[s];
    x_[s].resize(st.r_s.size());
    const bool turn = !lasers.empty() && !st.laser.empty();
    const PointShifts::Strip shift = shifts.strip(st.id);
    const bool shifted = !shifts.empty();
    for (std::size_t i : keep_[s]) {
      const Vec3 r = turn ? correct[st.laser[i]](st.r_s[i]) : st.r_s[i];
      const Vec3 u = R_mb_[s][i] * (R_bs * r + a);
      x_[s][i] = p_m_[s][i] + u;  // SPEC §2 eq. (1)
      if (shifted) x_[s][i] += shift.at(st.time_s[i], u);
    }
  }
}

/// The column grids of every strip's kept points where they are now (none for a strip of fewer
/// than k): each round moves every point and searches a few hundred places, which a grid's
/// linear-time build serves where a k-d tree's build cost most of the matching.
void DenseMatcher::buildGrids(std::size_t k, CorrespondenceSet* out) {
  const std::size_t n = x_.size();
  grid_.clear();
  grid_.resize(n);
  for (std::size_t s = 0; s < n; ++s) {
    out->points_searched += x_[s].size();
    const std::vector<std::size_t>& kept = keep_[s];
    if (kept.size() < k) continue;
    std::vector<float> coords(3 * kept.size());
    for (std::size_t j = 0; j < kept.size(); ++j) Eigen::Map<Eigen::Vector3f>{&coords[3 * j]} = (x_[s][kept[j]] - origin_).cast<float>();
    grid_[s] = ColumnGrid(std::move(coords), static_cast<double>(k) / 4.0);  // columns of about k/4
  }
}

/// The σ of a distance, then (fine stage) the candidates beyond mad_factor × σ_MAD of the
/// distances rejected; the rest into `out`.
void DenseMatcher::keepConsistent(bool coarse, std::size_t k, std::vector<DenseCandidate>* candidates, CorrespondenceSet* out) const {
  std::vector<DenseCandidate>& cand = *candidates;
  // σ of a distance: from the planes' roughness (as the sparse matching), at least 2 mm.
  std::vector<double> v;
  for (const auto& c : cand) v.push_back(c.c.roughness_m);
  double sigma = o_.sigma_m;
  if (!(sigma > 0)) {
    sigma = 0.002;
    if (!v.empty()) {
      std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
      const double kk = static_cast<double>(k);
      sigma = std::max(0.002, v[v.size() / 2] * std::sqrt(kk / (kk - 3.0)) * std::sqrt(1.0 + 1.0 / kk));
    }
  }
  out->sigma_m = sigma;
  // Fine stage: beyond mad_factor × σ_MAD of the distances (never tighter than 3 σ) rejected.
  if (!coarse && !cand.empty()) {
    v.clear();
    for (const auto& c : cand) v.push_back(c.c.distance_m);
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    const double med = v[v.size() / 2];
    for (double& x : v) x = std::abs(x - med);
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    const double limit = std::max(o_.mad_factor * 1.4826 * v[v.size() / 2], 3.0 * sigma);
    std::vector<DenseCandidate> kept;
    for (auto& c : cand) {
      if (std::abs(c.c.distance_m - med) > limit)
        ++out->pairs[c.pair].rejected_mad;
      else
        kept.push_back(std::move(c));
    }
    cand.swap(kept);
  }
  for (auto& c : cand) {
    ++out->pairs[c.pair].kept;
    out->correspondences.push_back(std::move(c.c));
  }
}

CorrespondenceSet DenseMatcher::match(bool coarse, double fine_gate_m) {
  const auto t0 = std::chrono::steady_clock::now();
  CorrespondenceSet out;
  const std::size_t n = x_.size();
  // Coordinates relative to one origin in the grids: no kilometre-size values.
  const std::size_t k_fine = static_cast<std::size_t>(o_.max_neighbours), k = coarse ? std::max<std::size_t>(30, k_fine) : k_fine;
  buildGrids(k, &out);
  const auto& grid = grid_;
  const double spacing = spacing_;
  const double r_fine = o_.radius_m > 0 ? o_.radius_m : std::max(0.25, 2.5 * spacing);
  const double R = coarse ? std::max(o_.coarse_radius_m, r_fine) : r_fine;
  const double gate = coarse ? std::max(2.0 * o_.apriori_misalignment_m, o_.max_distance_factor * R) : fine_gate_m;
  const double max_angle = coarse ? std::min(2 * o_.max_normal_angle_deg, 60.0) : o_.max_normal_angle_deg;
  // The coarse stage's planes span a metre of a curved object: only the relative bound there.
  const double max_sigma = o_.maxPlaneSigma(R, !coarse);
  out.radius_m = R;
  out.spacing_m = spacing;
  out.max_distance_m = gate;
  std::vector<std::size_t> idx(k), ia(k);
  std::vector<float> dist(k);
  // The k nearest points of strip s around p, unless its nearest is farther than max_nearest.
  auto knn = [&](std::size_t s, const Vec3& p, std::vector<std::size_t>* I, double max_nearest) {
    const Eigen::Vector3f q = (p - origin_).cast<float>();
    if (grid[s].nearest(q.data(), k, max_nearest, I->data(), dist.data()) == 0) return false;
    for (std::size_t& j : *I) j = keep_[s][j];  // grid index → strip index
    return true;
  };
  std::vector<DenseCandidate> cand;
  // The fine stage's normal of B's plane from the normal_neighbours nearest (when more than k):
  // the k nearest's normal kept when the wider neighbourhood is not a plane (rough, or B has fewer points).
  const std::size_t k_normal = coarse ? 0 : static_cast<std::size_t>(std::max(0, o_.normal_neighbours));
  std::vector<std::size_t> idx_normal(std::max<std::size_t>(k_normal, 1));
  std::vector<float> dist_normal(idx_normal.size());
  auto widerNormal = [&](std::size_t s, const Vec3& p, const Vec3& normal) {
    const Eigen::Vector3f q = (p - origin_).cast<float>();
    if (grid[s].nearest(q.data(), k_normal, std::numeric_limits<double>::infinity(), idx_normal.data(), dist_normal.data()) != k_normal)
      return normal;
    const PlaneFit fw = fitPlane(k_normal, [&](std::size_t j) { return x_[s][keep_[s][idx_normal[j]]]; });
    if (!(fw.sigma_m <= max_sigma)) return normal;
    return fw.normal.dot(normal) < 0 ? Vec3(-fw.normal) : fw.normal;
  };
  for (std::size_t a = 0; a < n; ++a) {
    for (std::size_t b = 0; b < n; ++b) {
      if (a == b) continue;
      CorrespondencePairStats st;
      st.strip_a = data_.strips[a].id;
      st.strip_b = data_.strips[b].id;
      if (grid[a].empty() || grid[b].empty()) {
        out.pairs.push_back(st);
        continue;
      }
      const std::size_t budget = static_cast<std::size_t>(coarse ? std::max(1, o_.budget / 4) : o_.budget);
      const std::vector<std::size_t>& pool = keep_[a];
      const std::size_t stride = std::max<std::size_t>(1, (pool.size() + budget - 1) / budget);
      bool any = false;
      for (std::size_t pi = 0; pi < pool.size(); pi += stride) {
        const std::size_t q = pool[pi];
        const Vec3& p = x_[a][q];
        if (!knn(b, p, &idx, gate)) {
          ++st.rejected_far;
          continue;
        }
        any = true;
        ++st.samples;
        PlaneFit fb = fitPlane(k, [&](std::size_t j) { return x_[b][idx[j]]; });
        if (fb.sigma_m > max_sigma || fb.extent_m > R || fb.spread_ratio < o_.min_spread_ratio) {
          ++st.rejected_rough;
          continue;
        }
        if (k_normal > k) fb.normal = widerNormal(b, p, fb.normal);
        const double d = fb.normal.dot(p - fb.centroid);
        if (std::abs(d) > gate) {
          ++st.rejected_far;
          continue;
        }
        knn(a, p, &ia, std::numeric_limits<double>::infinity());
        const PlaneFit fa = fitPlane(k, [&](std::size_t j) { return x_[a][ia[j]]; });
        if (fa.extent_m > R || fa.spread_ratio < o_.min_spread_ratio) {
          ++st.rejected_rough;
          continue;
        }
        if (angleDeg(fa.normal, fb.normal) > max_angle) {
          ++st.rejected_normal;
          continue;
        }
        DenseCandidate c;
        c.pair = out.pairs.size();
        c.c.strip_a = static_cast<int>(a);
        c.c.strip_b = static_cast<int>(b);
        c.c.point_a = q;
        c.c.points_b.assign(idx.begin(), idx.end());
        c.c.normal = fb.normal;
        c.c.distance_m = d;
        c.c.roughness_m = fb.sigma_m;
        cand.push_back(std::move(c));
      }
      if (!any) st.samples = 0;
      out.pairs.push_back(st);
    }
  }
  keepConsistent(coarse, k, &cand, &out);
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

DenseResidual::DenseResidual(const std::vector<Point>& points, const Vec3& normal, const Mat3& R_nom, double sigma_m,
                             const LaserLayout& layout)
    : n_(normal), R_nom_(R_nom), inv_sigma_(1.0 / sigma_m), layout_(layout) {
  const bool rays = !layout_.empty() && !layout_.elevationOnly();
  for (const Point& q : points) {
    const Vec3 nR = q.R_mb.transpose() * n_;
    c_ += q.weight * n_.dot(q.p_m);
    h_ += q.weight * nR;
    const int l = layout_.empty() ? -1 : q.laser;
    if (rays && l >= 0) {  // corrected point by point (the general per-laser model)
      rays_.push_back(RayTerm{l, q.weight * nR, LaserRay(q.r_s)});
      continue;
    }
    auto it = std::find_if(terms_.begin(), terms_.end(), [l](const LaserTerm& t) { return t.laser == l; });
    if (it == terms_.end()) it = terms_.insert(terms_.end(), LaserTerm{l, Mat3::Zero(), Mat3::Zero()});
    it->G += q.weight * nR * (R_nom_ * q.r_s).transpose();
    if (l >= 0) it->U += q.weight * nR * (R_nom_ * elevationTangent(q.r_s)).transpose();
  }
  set_num_residuals(1);
  mutable_parameter_block_sizes()->push_back(6);
  mutable_parameter_block_sizes()->push_back(3);
  mutable_parameter_block_sizes()->push_back(3);
  if (!layout_.empty()) mutable_parameter_block_sizes()->push_back(layout_.size);
}

// Σ_q (w R_mbᵀ n)ᵀ R_b R_nom r'_q added to *v, its derivatives to jm (boresight part, 6) and
// jl (the intrinsics block, divided by σ; may be null).
bool DenseResidual::evaluateRays(const double* intrinsics, const Mat3& Rb, const std::array<Mat3, 3>& dR, double* v, double* jm,
                                 double* jl) const {
  Eigen::Matrix<double, 3, 5> J;
  int last = -1;
  LaserCorrector correct;
  static constexpr int kGroups = 5;
  for (const RayTerm& t : rays_) {
    if (t.laser != last) correct = LaserCorrector(layout_.correction(intrinsics, t.laser)), last = t.laser;
    const Vec3 z = R_nom_ * correct.apply(t.ray, (jm || jl) ? &J : nullptr);
    const Vec3 y = Rb.transpose() * t.nR;  // so that nRᵀ R_b R_nom r' = yᵀ R_nom r'
    *v += y.dot(z);
    if (jm)
      for (int k = 0; k < 3; ++k) jm[3 + k] += t.nR.dot(dR[static_cast<std::size_t>(k)] * z);
    if (!jl) continue;
    const Eigen::Matrix<double, 1, 5> yJ = (R_nom_.transpose() * y).transpose() * J;
    for (int g = 0; g < kGroups; ++g)
      if (layout_.offset[static_cast<std::size_t>(g)] >= 0) jl[layout_.offset[static_cast<std::size_t>(g)] + t.laser] += yJ(g) * inv_sigma_;
  }
  return true;
}

bool DenseResidual::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const double* m = parameters[0];
  const Vec3 b(m[3], m[4], m[5]), a(m[0], m[1], m[2]);
  // Every residual of one evaluation shares the boresight: R_zyx(b) and its derivatives once.
  thread_local Vec3 cached_b = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  thread_local Mat3 Rb;
  thread_local std::array<Mat3, 3> dR;
  if (!(b == cached_b)) {
    Rb = R_zyx(b);
    dR = dRzyx(b);
    cached_b = b;
  }
  const double* dl = layout_.empty() ? nullptr : parameters[3];
  const bool jac = jacobians != nullptr;
  double* jl = (jac && dl) ? jacobians[3] : nullptr;
  double v = c_ + h_.dot(a);
  Eigen::Matrix<double, 1, 6> jm = Eigen::Matrix<double, 1, 6>::Zero();
  if (jac) jm.head<3>() = h_.transpose();
  if (jl) std::fill(jl, jl + layout_.size, 0.0);
  for (const LaserTerm& t : terms_) {  // elevation offsets alone, or points without a laser
    const double d = (dl && t.laser >= 0) ? dl[t.laser] : 0.0;
    const double cd = std::cos(d), sd = std::sin(d);
    const double g = t.G.cwiseProduct(Rb).sum(), u = t.U.cwiseProduct(Rb).sum();
    v += cd * g + sd * u;
    if (!jac) continue;
    for (int k = 0; k < 3; ++k) {
      const Mat3& D = dR[static_cast<std::size_t>(k)];
      jm(3 + k) += cd * t.G.cwiseProduct(D).sum() + sd * t.U.cwiseProduct(D).sum();
    }
    if (dl && t.laser >= 0 && jl) jl[t.laser] += (-sd * g + cd * u) * inv_sigma_;
  }
  if (!rays_.empty()) evaluateRays(dl, Rb, dR, &v, jac ? jm.data() : nullptr, jl);
  // Strip offsets: + n·o_A − n·o_B (the B points' weights sum to −1).
  const double* oa = parameters[1];
  const double* ob = parameters[2];
  v += n_.x() * (oa[0] - ob[0]) + n_.y() * (oa[1] - ob[1]) + n_.z() * (oa[2] - ob[2]);
  residuals[0] = v * inv_sigma_;
  if (jac) {
    if (jacobians[0])
      for (int j = 0; j < 6; ++j) jacobians[0][j] = jm(j) * inv_sigma_;
    for (int j = 0; j < 3; ++j) {
      if (jacobians[1]) jacobians[1][j] = n_[j] * inv_sigma_;
      if (jacobians[2]) jacobians[2][j] = -n_[j] * inv_sigma_;
    }
  }
  return true;
}

}  // namespace mountcal::detail
