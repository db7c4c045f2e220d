#include "mountcal/methods/correspondence/correspondences.hpp"

#include <ceres/ceres.h>
#include <flann/flann.hpp>

#include <algorithm>
#include <functional>
#include <chrono>
#include <cmath>
#include <map>
#include <set>
#include <unordered_set>

#include "../common/strip_geometry.hpp"
#include "dense_matching.hpp"
#include "mountcal/error.hpp"

namespace mountcal {

bool CorrespondenceOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  auto nonneg = [](double v) { return v >= 0 && std::isfinite(v); };
  if (!nonneg(apriori_misalignment_m) || apriori_misalignment_m > 1000) return fail("apriori_misalignment_m must be in [0, 1000]");
  if (!nonneg(radius_m) || radius_m > 1000) return fail("radius_m must be in [0, 1000] (0: from the point spacing)");
  if (!nonneg(sample_spacing_m) || sample_spacing_m > 10000) return fail("sample_spacing_m must be in [0, 10000]");
  if (min_neighbours < 3) return fail("min_neighbours must be at least 3");
  if (max_neighbours < min_neighbours || max_neighbours > 1000) return fail("max_neighbours must be in [min_neighbours, 1000]");
  if (!(max_roughness_relative >= 1) || !std::isfinite(max_roughness_relative)) return fail("max_roughness_relative must be at least 1");
  if (!(max_roughness_factor > 0) || !(max_distance_factor > 0) || !(mad_factor > 0)) return fail("roughness, distance and MAD factors must be positive");
  if (!(max_normal_angle_deg > 0 && max_normal_angle_deg < 90)) return fail("max_normal_angle_deg must be in (0, 90)");
  if (!(min_spread_ratio >= 0 && min_spread_ratio < 1)) return fail("min_spread_ratio must be in [0, 1)");
  if (!(coarse_radius_m > 0 && coarse_radius_m <= 100)) return fail("coarse_radius_m must be in (0, 100]");
  if (!(thin_cell_m >= 0 && thin_cell_m <= 10)) return fail("thin_cell_m must be in [0, 10]");
  if (!(laser_elevation_sigma_deg >= 0 && laser_elevation_sigma_deg <= 10)) return fail("laser_elevation_sigma_deg must be in [0, 10]");
  if (budget < 1 || budget > 10000000) return fail("budget must be in [1, 10000000]");
  if (!nonneg(voxel_size_m) || voxel_size_m > 10000) return fail("voxel_size_m must be in [0, 10000]");
  if (!nonneg(sigma_m)) return fail("sigma_m must be finite and non-negative");
  return true;
}

namespace detail {

/// The matching machinery: reference points, coarse voxel hulls and their overlaps, the
/// samples — computed once — and the k-d trees at the mounting of each round.
class Matcher {
 public:
  Matcher(const CalibrationData& data, const CorrespondenceOptions& o) : data_(data), o_(o) {
    std::string why;
    if (!o.IsValid(&why)) throw InvalidInput("correspondence options: " + why);
    data.requirePoses();
    const std::size_t n_strips = data.strips.size();
    x0_.resize(n_strips);
    std::vector<double> spacing(n_strips, 0.0);
    for (std::size_t s = 0; s < n_strips; ++s) {
      const StripData& st = data.strips[s];
      if (st.r_s.size() != st.time_s.size() || (!st.x_m.empty() && st.x_m.size() != st.time_s.size())) {
        throw InvalidInput("strip '" + st.id + "': time, r_s and x_m must have the same length");
      }
      x0_[s] = referencePoints(data, st, data.mounting_used);
      spacing[s] = planSpacing(x0_[s]);
      spacing_ = std::max(spacing_, spacing[s]);
    }
    // The radius of a pair: from the coarser strip of the two.
    auto radiusOf = [&](std::size_t a, std::size_t b) {
      return o.radius_m > 0 ? o.radius_m : std::max(0.25, 2.5 * std::max(spacing[a], spacing[b]));
    };
    r_ = o.radius_m > 0 ? o.radius_m : std::max(0.25, 2.5 * spacing_);
    const double voxel = o.voxel_size_m > 0 ? o.voxel_size_m : std::max(2.0, 4 * r_);
    // Coarse voxel hulls at the mounting used; a pair overlaps where the hulls meet (dilated by
    // one voxel for the misalignment).
    auto vkey = [voxel](const Vec3& p) {
      const auto q = [voxel](double v) { return static_cast<std::int64_t>(std::floor(v / voxel)) & 0x1fffff; };
      return (q(p.x()) << 42) | (q(p.y()) << 21) | q(p.z());
    };
    // Each strip's occupied voxels, dilated by one voxel: one look-up per point and strip.
    std::vector<std::unordered_set<std::int64_t>> hull(n_strips);
    for (std::size_t s = 0; s < n_strips; ++s) {
      std::unordered_set<std::int64_t> occupied;
      std::vector<Vec3> centres;
      for (const Vec3& p : x0_[s]) {
        if (occupied.insert(vkey(p)).second) {
          centres.push_back(Vec3((std::floor(p.x() / voxel) + 0.5) * voxel, (std::floor(p.y() / voxel) + 0.5) * voxel,
                                 (std::floor(p.z() / voxel) + 0.5) * voxel));
        }
      }
      for (const Vec3& c : centres)
        for (int dx = -1; dx <= 1; ++dx)
          for (int dy = -1; dy <= 1; ++dy)
            for (int dz = -1; dz <= 1; ++dz) hull[s].insert(vkey(c + Vec3(dx, dy, dz) * voxel));
    }
    auto dilated = [&](std::size_t s, const Vec3& p) { return hull[s].count(vkey(p)) > 0; };
    active_.resize(n_strips);
    std::vector<std::vector<char>> in_overlap(n_strips);
    for (std::size_t s = 0; s < n_strips; ++s) in_overlap[s].assign(x0_[s].size(), 0);
    for (std::size_t a = 0; a < n_strips; ++a) {
      for (std::size_t b = a + 1; b < n_strips; ++b) {
        Pair pr;
        pr.a = static_cast<int>(a);
        pr.b = static_cast<int>(b);
        pr.r = radiusOf(a, b);
        const double sample = o.sample_spacing_m > 0 ? o.sample_spacing_m : 2 * pr.r;
        // Samples of A in the overlap: one per sample cell (the point nearest its centre).
        std::map<std::int64_t, std::pair<double, std::size_t>> cells;
        bool any = false;
        for (std::size_t i = 0; i < x0_[a].size(); ++i) {
          const Vec3& p = x0_[a][i];
          if (!dilated(b, p)) continue;
          any = true;
          in_overlap[a][i] = 1;
          const Vec3 q = p / sample;
          const Vec3 f(std::floor(q.x()), std::floor(q.y()), std::floor(q.z()));
          const std::int64_t k = ((static_cast<std::int64_t>(f.x()) & 0x1fffff) << 42) | ((static_cast<std::int64_t>(f.y()) & 0x1fffff) << 21) |
                                 (static_cast<std::int64_t>(f.z()) & 0x1fffff);
          // Nearest the cell's centre in plan: a choice by height would pick the points with
          // the largest upward noise (the cell's centre is rarely at ground level).
          const double d = (q - f - Vec3::Constant(0.5)).head<2>().squaredNorm();
          auto it = cells.find(k);
          if (it == cells.end() || d < it->second.first) cells[k] = {d, i};
        }
        if (!any) continue;
        for (std::size_t i = 0; i < x0_[b].size(); ++i)
          if (!in_overlap[b][i] && dilated(a, x0_[b][i])) in_overlap[b][i] = 1;
        for (const auto& c : cells) pr.samples.push_back(c.second.second);
        std::sort(pr.samples.begin(), pr.samples.end());
        pairs_.push_back(std::move(pr));
      }
    }
    for (std::size_t s = 0; s < n_strips; ++s) {
      for (std::size_t i = 0; i < x0_[s].size(); ++i)
        if (in_overlap[s][i]) active_[s].push_back(i);
      // Poses of the active points, once (the trajectory does not change between rounds).
      R_mb_.emplace_back(active_[s].size());
      std::size_t cursor = 0;
      for (std::size_t k = 0; k < active_[s].size(); ++k) R_mb_[s][k] = data.pose(data.strips[s], active_[s][k], &cursor).R_mb;
      local_.emplace_back();
      for (std::size_t k = 0; k < active_[s].size(); ++k) local_[s][active_[s][k]] = k;
      // The k-d tree of the active points at the mounting used.
      ref_.emplace_back(3 * active_[s].size());
      for (std::size_t k = 0; k < active_[s].size(); ++k)
        for (int c = 0; c < 3; ++c) ref_[s][3 * k + static_cast<std::size_t>(c)] = x0_[s][active_[s][k]][c];
      tree_.emplace_back();
      if (active_[s].size() >= 3) {
        flann::Matrix<double> mat(ref_[s].data(), active_[s].size(), 3);
        tree_[s] = std::make_unique<flann::Index<flann::L2_Simple<double>>>(mat, flann::KDTreeSingleIndexParams(12));
        tree_[s]->buildIndex();
      }
    }
  }
  Vec3 ref_xyz(std::size_t s, std::size_t k) const { return Vec3(ref_[s][3 * k], ref_[s][3 * k + 1], ref_[s][3 * k + 2]); }

  double spacing() const { return spacing_; }
  const std::vector<Vec3>& x0(int s) const { return x0_[static_cast<std::size_t>(s)]; }
  const Mat3& R_mb(int s, std::size_t i) const { return R_mb_[static_cast<std::size_t>(s)][local_[static_cast<std::size_t>(s)].at(i)]; }

  /// One matching at mounting m. The first round of an estimation (at the mounting used)
  /// gates distances at max(3 r, 2 × the a-priori misalignment) and applies no MAD rejection
  /// (the discrepancies are still systematic: the largest are the sloped surfaces that carry
  /// the horizontal information); later rounds gate at 3 r and reject beyond 3 σ_MAD.
  CorrespondenceSet match(const std::array<double, 6>& m, bool first_round) {
    const auto t0 = std::chrono::steady_clock::now();
    CorrespondenceSet out;
    out.radius_m = r_;
    out.spacing_m = spacing_;
    out.max_distance_m = 0;
    const MountingParameters& used = data_.mounting_used;
    const MountingMotion motion(used.R_nom, used.R_bs(), used.a_b, m.data());
    const std::size_t n_strips = x0_.size();
    // Active points at m and their k-d trees (3-D).
    // Active points at m. The k-d trees hold the points at the mounting used (built once): a
    // query at p in strip s is moved back by the displacement of s's point nearest p, so the
    // neighbours found are those at m up to the displacement's variation across a
    // neighbourhood (a rotation of a few 1e-3 rad over a few metres: millimetres); their
    // positions at m are then used as they are.
    std::vector<std::vector<Vec3>> xyz(n_strips);
    for (std::size_t s = 0; s < n_strips; ++s) {
      const auto& act = active_[s];
      xyz[s].resize(act.size());
      for (std::size_t k = 0; k < act.size(); ++k) xyz[s][k] = x0_[s][act[k]] + motion.displacement(R_mb_[s][k], data_.strips[s].r_s[act[k]]);
      out.points_searched += act.size();
    }
    auto point = [&](std::size_t s, std::size_t k) -> const Vec3& { return xyz[s][k]; };
    const auto knn = static_cast<std::size_t>(o_.max_neighbours);
    std::vector<std::size_t> I_buf(knn);
    std::vector<double> D_buf(knn);
    const flann::SearchParams params(flann::FLANN_CHECKS_UNLIMITED);
    auto search = [&](std::size_t s, const Vec3& q_ref, std::size_t k) {
      double q[3] = {q_ref.x(), q_ref.y(), q_ref.z()};
      flann::Matrix<double> query(q, 1, 3);
      flann::Matrix<std::size_t> I(I_buf.data(), 1, k);
      flann::Matrix<double> D(D_buf.data(), 1, k);
      tree_[s]->knnSearch(query, I, D, k, params);
    };
    // k nearest of strip s around p (at m) within `radius`; `p_ref` when p's own position at
    // the mounting used is known (a point of s itself).
    auto neighbours = [&](std::size_t s, const Vec3& p, double radius, std::vector<std::size_t>* idx, const Vec3* p_ref = nullptr) {
      idx->clear();
      if (!tree_[s]) return;
      Vec3 q = p_ref ? *p_ref : p;
      if (!p_ref) {
        search(s, p, 1);
        q = p - (xyz[s][I_buf[0]] - ref_xyz(s, I_buf[0]));
      }
      const std::size_t k = std::min(knn, active_[s].size());
      search(s, q, k);
      for (std::size_t j = 0; j < k; ++j)
        if ((xyz[s][I_buf[j]] - p).squaredNorm() <= radius * radius) idx->push_back(I_buf[j]);
    };
    struct Candidate {
      Correspondence c;
      int pair;
    };
    std::vector<Candidate> cand;
    out.pairs.resize(pairs_.size());
    std::vector<std::size_t> nb, na;
    for (std::size_t pi = 0; pi < pairs_.size(); ++pi) {
      const Pair& pr = pairs_[pi];
      CorrespondencePairStats& st = out.pairs[pi];
      st.strip_a = data_.strips[static_cast<std::size_t>(pr.a)].id;
      st.strip_b = data_.strips[static_cast<std::size_t>(pr.b)].id;
      st.samples = static_cast<int>(pr.samples.size());
      const auto a = static_cast<std::size_t>(pr.a), b = static_cast<std::size_t>(pr.b);
      const double gate_m = first_round ? std::max(o_.max_distance_factor * pr.r, 2.0 * o_.apriori_misalignment_m)
                                        : o_.max_distance_factor * pr.r;
      out.max_distance_m = std::max(out.max_distance_m, gate_m);
      const double search_r = std::max(pr.r, gate_m);
      for (std::size_t ia : pr.samples) {
        const Vec3 p = point(a, local_[a].at(ia));
        neighbours(b, p, search_r, &nb);
        if (static_cast<int>(nb.size()) < o_.min_neighbours) {
          ++st.rejected_sparse;
          continue;
        }
        const PlaneFit fb = fitPlane(nb.size(), [&](std::size_t k) { return point(b, nb[k]); });
        if (fb.sigma_m > o_.max_roughness_factor * pr.r || fb.spread_ratio < o_.min_spread_ratio) {
          ++st.rejected_rough;
          continue;
        }
        const double d = fb.normal.dot(p - fb.centroid);
        if (std::abs(d) > gate_m) {
          ++st.rejected_far;
          continue;
        }
        const Vec3 p_ref = ref_xyz(a, local_[a].at(ia));
        neighbours(a, p, pr.r, &na, &p_ref);
        if (static_cast<int>(na.size()) < o_.min_neighbours) {
          ++st.rejected_sparse;
          continue;
        }
        const PlaneFit fa = fitPlane(na.size(), [&](std::size_t k) { return point(a, na[k]); });
        if (fa.spread_ratio < o_.min_spread_ratio) {
          ++st.rejected_rough;
          continue;
        }
        if (angleDeg(fa.normal, fb.normal) > o_.max_normal_angle_deg) {
          ++st.rejected_normal;
          continue;
        }
        Candidate c;
        c.pair = static_cast<int>(pi);
        c.c.strip_a = pr.a;
        c.c.strip_b = pr.b;
        c.c.point_a = ia;
        for (std::size_t k : nb) c.c.points_b.push_back(active_[b][k]);
        c.c.normal = fb.normal;
        c.c.distance_m = d;
        c.c.roughness_m = fb.sigma_m;
        cand.push_back(std::move(c));
      }
    }
    // Rough relative to the typical plane: neighbourhoods across a ridge, an eave or a wall
    // edge fit a plane with a σ well above the noise (and a distance biased by the edge).
    std::vector<double> rough;
    for (const auto& c : cand) rough.push_back(c.c.roughness_m);
    if (!rough.empty()) {
      std::nth_element(rough.begin(), rough.begin() + static_cast<long>(rough.size() / 2), rough.end());
      const double limit = std::max(o_.max_roughness_relative * rough[rough.size() / 2], 0.005);
      std::vector<Candidate> kept;
      for (auto& c : cand) {
        if (c.c.roughness_m > limit) ++out.pairs[static_cast<std::size_t>(c.pair)].rejected_rough;
        else kept.push_back(std::move(c));
      }
      cand.swap(kept);
      rough.clear();
      for (const auto& c : cand) rough.push_back(c.c.roughness_m);
    }
    // σ of a distance: stated, or from the planes' roughness (median, both sides' noise).
    double sigma = o_.sigma_m;
    if (!(sigma > 0)) {
      sigma = 0.002;
      if (!rough.empty()) {
        std::nth_element(rough.begin(), rough.begin() + static_cast<long>(rough.size() / 2), rough.end());
        // A plane fit of k points leaves k − 3 degrees of freedom: σ_point = σ_fit √(k/(k−3));
        // the distance holds the sample's noise and the centroid's (σ²/k).
        const double k = o_.max_neighbours;
        sigma = std::max(0.002, rough[rough.size() / 2] * std::sqrt(k / (k - 3.0)) * std::sqrt(1.0 + 1.0 / k));
      }
    }
    out.sigma_m = sigma;
    // Beyond mad_factor × σ_MAD of the distances (never tighter than 3σ): rejected — per
    // class of surface (level, sloped, steep), since a sloped surface shows what is left of a
    // horizontal misalignment and level ground does not: gated by the ground's spread, the
    // roofs that still disagree would go, and with them what pulls the mounting back.
    if (!cand.empty() && !first_round) {
      auto tiltClass = [](const Vec3& n) {
        const double tilt = rad2deg(std::acos(std::min(1.0, std::abs(n.z()))));
        return tilt < 10 ? 0 : (tilt < 60 ? 1 : 2);
      };
      auto medianAndLimit = [&](std::vector<double> d, double* med, double* limit) {
        std::nth_element(d.begin(), d.begin() + static_cast<long>(d.size() / 2), d.end());
        *med = d[d.size() / 2];
        for (double& v : d) v = std::abs(v - *med);
        std::nth_element(d.begin(), d.begin() + static_cast<long>(d.size() / 2), d.end());
        *limit = std::max(o_.mad_factor * 1.4826 * d[d.size() / 2], 3.0 * sigma);
      };
      std::vector<double> all;
      std::array<std::vector<double>, 3> per;
      for (const auto& c : cand) {
        all.push_back(c.c.distance_m);
        per[static_cast<std::size_t>(tiltClass(c.c.normal))].push_back(c.c.distance_m);
      }
      double med_all = 0, lim_all = 0;
      medianAndLimit(all, &med_all, &lim_all);
      std::array<double, 3> med{}, lim{};
      for (std::size_t k = 0; k < 3; ++k) {
        if (per[k].size() >= 10) medianAndLimit(per[k], &med[k], &lim[k]);
        else med[k] = med_all, lim[k] = lim_all;
      }
      std::vector<Candidate> kept;
      for (auto& c : cand) {
        const auto k = static_cast<std::size_t>(tiltClass(c.c.normal));
        if (std::abs(c.c.distance_m - med[k]) > lim[k]) ++out.pairs[static_cast<std::size_t>(c.pair)].rejected_mad;
        else kept.push_back(std::move(c));
      }
      cand.swap(kept);
    }
    // Normal-space thinning to the budget: round robin over orientation bins (level, sloped
    // and steep by aspect octant), evenly spread within each bin.
    std::map<int, std::vector<std::size_t>> bins;
    for (std::size_t i = 0; i < cand.size(); ++i) {
      const Vec3& n = cand[i].c.normal;
      const double tilt = rad2deg(std::acos(std::min(1.0, std::abs(n.z()))));
      const int oct = static_cast<int>(std::fmod(rad2deg(std::atan2(n.x(), n.y())) + 360.0, 360.0) / 45.0) % 8;
      bins[tilt < 10 ? 0 : (tilt < 60 ? 1 : 9) + oct].push_back(i);
    }
    std::vector<char> take(cand.size(), 0);
    std::size_t budget = static_cast<std::size_t>(o_.budget);
    if (cand.size() <= budget) {
      std::fill(take.begin(), take.end(), 1);
    } else {
      // Water-filling: each bin gets an equal share, unused shares go to the larger bins.
      std::map<int, std::size_t> quota;
      std::size_t left = budget;
      std::vector<std::pair<std::size_t, int>> sizes;
      for (const auto& [b, list] : bins) sizes.push_back({list.size(), b});
      std::sort(sizes.begin(), sizes.end());
      for (std::size_t k = 0; k < sizes.size(); ++k) {
        const std::size_t share = left / (sizes.size() - k);
        quota[sizes[k].second] = std::min(sizes[k].first, share);
        left -= quota[sizes[k].second];
      }
      for (const auto& [b, list] : bins) {
        const std::size_t q = quota[b];
        for (std::size_t k = 0; k < q; ++k) take[list[k * list.size() / q]] = 1;
      }
    }
    for (std::size_t i = 0; i < cand.size(); ++i) {
      CorrespondencePairStats& st = out.pairs[static_cast<std::size_t>(cand[i].pair)];
      if (take[i]) {
        ++st.kept;
        out.correspondences.push_back(std::move(cand[i].c));
      } else {
        ++st.rejected_budget;
      }
    }
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return out;
  }


 private:
  struct Pair {
    int a = 0, b = 0;
    double r = 0;                      // plane-fit radius of the pair [m]
    std::vector<std::size_t> samples;  // indices into strip a
  };
  const CalibrationData& data_;
  CorrespondenceOptions o_;
  std::vector<std::vector<Vec3>> x0_;
  std::vector<std::vector<std::size_t>> active_;
  std::vector<std::vector<Mat3>> R_mb_;
  std::vector<std::unordered_map<std::size_t, std::size_t>> local_;
  std::vector<std::vector<double>> ref_;  // active points at the mounting used, xyz
  std::vector<std::unique_ptr<flann::Index<flann::L2_Simple<double>>>> tree_;
  std::vector<Pair> pairs_;
  double spacing_ = 0, r_ = 0;
};

}  // namespace detail

CorrespondenceSet findCorrespondences(const CalibrationData& data, const std::array<double, 6>& mounting,
                                      const CorrespondenceOptions& options, bool first_round) {
  detail::Matcher matcher(data, options);
  return matcher.match(mounting, first_round);
}

namespace {

/// A prior on one laser's elevation offset (δ_i/σ), or on their mean (Σδ/(L σ)).
struct LaserPrior {
  int index, count;
  double sigma;
  bool mean;
  template <typename T>
  bool operator()(T const* const* p, T* r) const {
    if (!mean) {
      r[0] = p[0][index] / T(sigma);
      return true;
    }
    T s(0.0);
    for (int i = 0; i < count; ++i) s += p[0][i];
    r[0] = s / T(count * sigma);
    return true;
  }
};

/// One correspondence: r = n·((x_A(M) + o_A) − (x̄_B(M) + o_B))/σ, every point moved from its
/// position at the mounting used by SPEC §2 eq. (1) differenced, R_mb (ΔR_bs r_s + Δa_b). With n
/// held, n·R_mb ΔR_bs r_s = Σ_kl (nᵀR_mb)_k r_l ΔR_kl: the sums over A's point and B's k
/// neighbours are gathered once into g (9 numbers) and h = Σ nᵀR_mb (3), so an evaluation is
/// r = (n·(x_A0 − x̄_B0) + g·vec(ΔR_bs) + h·Δa_b + n·(o_A − o_B))/σ — the same value, exactly
/// (a test compares it with GeoreferenceModel), without a loop over the neighbours.
struct CorrespondenceResidual {
  double c0 = 0;                 // n·(x_A0 − x̄_B0) [m]
  Eigen::Matrix<double, 9, 1> g; // (nᵀR_A)_k r_A,l − mean_j (nᵀR_j)_k r_j,l
  Vec3 h;                        // nᵀR_A − mean_j nᵀR_j
  Vec3 n;
  const MountingParameters* used;
  Mat3 R_bs_used;
  double inv_sigma;
  bool operator()(const double* m, const double* oa, const double* ob, double* r) const {
    const Mat3 dR = detail::cachedMountingMotion(used->R_nom, R_bs_used, used->a_b, m).dR_bs;
    const Vec3 da = Vec3(m[0], m[1], m[2]) - used->a_b;
    double v = c0 + h.dot(da);
    for (int k = 0; k < 3; ++k)
      for (int l = 0; l < 3; ++l) v += g[3 * k + l] * dR(k, l);
    v += n.x() * (oa[0] - ob[0]) + n.y() * (oa[1] - ob[1]) + n.z() * (oa[2] - ob[2]);
    r[0] = v * inv_sigma;
    return true;
  }
};

}  // namespace

CorrespondenceObservations::~CorrespondenceObservations() = default;

CorrespondenceObservations::CorrespondenceObservations(const CalibrationData& data, const CorrespondenceOptions& options)
    : data_(data), options_(options) {
  std::string why;
  if (!options_.IsValid(&why)) throw InvalidInput("correspondence options: " + why);
}

bool CorrespondenceObservations::settled() const { return !options_.dense || !coarse_; }

void CorrespondenceObservations::solved(const AdjustmentProblem& P) {
  (void)P;
  if (laser_block_) std::copy(laser_block_, laser_block_ + static_cast<long>(laser_dl_.size()), laser_dl_.begin());
}

void CorrespondenceObservations::addDenseBlocks(const std::array<double, 6>& mounting, AdjustmentProblem* P) {
  if (!dense_) {
    dense_ = std::make_unique<detail::DenseMatcher>(data_, options_);
    if (options_.laser_elevation_sigma_deg > 0) laser_dl_.assign(static_cast<std::size_t>(dense_->laserCount()), 0.0);
    coarse_ = true;
  }
  // Stage: coarse until the mounting stops moving (or for 15 rounds), then fine.
  if (coarse_ && section_.rounds > 0) {
    double change_m = 0, change_rad = 0;
    for (int j = 0; j < 3; ++j) change_m = std::max(change_m, std::abs(mounting[static_cast<std::size_t>(j)] - last_[static_cast<std::size_t>(j)]));
    for (int j = 3; j < 6; ++j) change_rad = std::max(change_rad, std::abs(mounting[static_cast<std::size_t>(j)] - last_[static_cast<std::size_t>(j)]));
    constexpr int kMaxCoarseMatchings = 6;
    if ((change_m < 1e-3 && change_rad < 1e-4) || section_.rounds >= kMaxCoarseMatchings) {
      coarse_ = false;
      fine_gate_m_ = options_.max_distance_factor * (options_.radius_m > 0 ? options_.radius_m : set_.radius_m);
    }
  }

  last_ = mounting;
  // The fine stage re-matches at most kMaxFineMatchings times, then keeps its last matches:
  // the next solve then reproduces its mounting and the estimation ends (a matching of
  // millimetre-scale noise would otherwise flip forever between near-equal sets).
  constexpr int kMaxFineMatchings = 6;
  if (!coarse_) ++fine_rounds_;
  if (coarse_ || fine_rounds_ <= kMaxFineMatchings) {
    dense_->place(mounting, laser_dl_);
    set_ = dense_->match(coarse_, fine_gate_m_);
  }
  ++section_.rounds;
  section_.search_time_s += set_.seconds;
  section_.points_searched += set_.points_searched;
  if (!coarse_ && fine_rounds_ <= kMaxFineMatchings && !set_.correspondences.empty()) {  // the fine gate shrinks to max(r/2, 10 σ_MAD)
    std::vector<double> d;
    for (const Correspondence& c : set_.correspondences) d.push_back(std::abs(c.distance_m));
    std::nth_element(d.begin(), d.begin() + static_cast<long>(d.size() / 2), d.end());
    fine_gate_m_ = std::max(0.5 * set_.radius_m, std::min(fine_gate_m_, 10.0 * 1.4826 * d[d.size() / 2]));
  }
  const int L = static_cast<int>(laser_dl_.size());
  laser_block_ = nullptr;
  if (L > 0) {
    laser_block_ = P->addNuisanceBlock(L, laser_dl_.data(), nullptr, false);
    // Priors: each offset N(0, σ_prior); their mean held at 0 (the boresight pitch's direction).
    const double sp = deg2rad(options_.laser_elevation_sigma_deg);
    for (int i = 0; i < L; ++i) {
      auto* prior = new ceres::DynamicAutoDiffCostFunction<LaserPrior>(new LaserPrior{i, L, sp, false});
      prior->AddParameterBlock(L);
      prior->SetNumResiduals(1);
      P->addResidualBlock(prior, 0.0, {laser_block_});
    }
    auto* mean = new ceres::DynamicAutoDiffCostFunction<LaserPrior>(new LaserPrior{0, L, 1e-6, true});
    mean->AddParameterBlock(L);
    mean->SetNumResiduals(1);
    P->addResidualBlock(mean, 0.0, {laser_block_});
  }
  const Mat3& R_nom = data_.mounting_used.R_nom;
  const double loss_scale = coarse_ ? 0.3 * set_.radius_m : -1.0;
  blocks_.clear();
  for (const Correspondence& c : set_.correspondences) {
    std::vector<detail::DenseResidual::Point> pts;
    auto add = [&](int s, std::size_t i, double w) {
      detail::DenseResidual::Point q;
      q.p_m = dense_->p_m(s, i);
      q.R_mb = dense_->R_mb(s, i);
      q.r_s = data_.strips[static_cast<std::size_t>(s)].r_s[i];
      q.laser = L > 0 ? dense_->laser(s, i) : -1;
      q.weight = w;
      pts.push_back(q);
    };
    add(c.strip_a, c.point_a, 1.0);
    for (std::size_t j : c.points_b) add(c.strip_b, j, -1.0 / static_cast<double>(c.points_b.size()));
    auto* cost = new detail::DenseResidual(pts, c.normal, R_nom, set_.sigma_m, L);
    std::vector<double*> blocks = {P->mounting(), P->stripOffset(data_.strips[static_cast<std::size_t>(c.strip_a)].id),
                                   P->stripOffset(data_.strips[static_cast<std::size_t>(c.strip_b)].id)};
    if (L > 0) blocks.push_back(laser_block_);
    blocks_.push_back(loss_scale > 0 ? P->addResidualBlock(cost, set_.sigma_m, blocks, loss_scale) : P->addResidualBlock(cost, set_.sigma_m, blocks));
  }
}

void CorrespondenceObservations::addBlocks(const std::array<double, 6>& mounting, AdjustmentProblem* P) {
  if (options_.dense) {
    addDenseBlocks(mounting, P);
    return;
  }
  if (!matcher_) matcher_ = std::make_unique<detail::Matcher>(data_, options_);
  detail::Matcher& matcher = *matcher_;
  set_ = matcher.match(mounting, mounting == data_.mounting_used.toArray());
  ++section_.rounds;
  section_.search_time_s += set_.seconds;
  section_.points_searched += set_.points_searched;
  const MountingParameters& used = data_.mounting_used;
  const Mat3 R_bs_used = used.R_bs();
  const double inv_sigma = 1.0 / set_.sigma_m;
  ceres::NumericDiffOptions nd;
  nd.relative_step_size = P->numericDiffRelativeStep();
  blocks_.clear();
  for (const Correspondence& c : set_.correspondences) {
    auto* f = new CorrespondenceResidual;
    const StripData& A = data_.strips[static_cast<std::size_t>(c.strip_a)];
    const StripData& B = data_.strips[static_cast<std::size_t>(c.strip_b)];
    const Vec3& n = c.normal;
    Vec3 cb = Vec3::Zero(), hb = Vec3::Zero();
    Eigen::Matrix<double, 9, 1> gb = Eigen::Matrix<double, 9, 1>::Zero();
    for (std::size_t j : c.points_b) {
      cb += matcher.x0(c.strip_b)[j];
      const Vec3 nR = matcher.R_mb(c.strip_b, j).transpose() * n;
      hb += nR;
      for (int k = 0; k < 3; ++k)
        for (int l = 0; l < 3; ++l) gb[3 * k + l] += nR[k] * B.r_s[j][l];
    }
    const double kb = static_cast<double>(c.points_b.size());
    const Vec3 nRa = matcher.R_mb(c.strip_a, c.point_a).transpose() * n;
    for (int k = 0; k < 3; ++k)
      for (int l = 0; l < 3; ++l) f->g[3 * k + l] = nRa[k] * A.r_s[c.point_a][l] - gb[3 * k + l] / kb;
    f->h = nRa - hb / kb;
    f->c0 = n.dot(matcher.x0(c.strip_a)[c.point_a] - cb / kb);
    f->n = n;
    f->used = &data_.mounting_used;
    f->R_bs_used = R_bs_used;
    f->inv_sigma = inv_sigma;
    auto* cost = new ceres::NumericDiffCostFunction<CorrespondenceResidual, ceres::CENTRAL, 1, 6, 3, 3>(f, ceres::TAKE_OWNERSHIP, 1, nd);
    blocks_.push_back(P->addResidualBlock(cost, set_.sigma_m,
                                          {P->mounting(), P->stripOffset(data_.strips[static_cast<std::size_t>(c.strip_a)].id),
                                           P->stripOffset(data_.strips[static_cast<std::size_t>(c.strip_b)].id)}));
  }
}

void CorrespondenceObservations::finish(const std::array<double, 6>& m0, const std::array<double, 6>& m, const AdjustmentProblem& P,
                                        const AnalysisOptions& analysis) {
  if (options_.dense) {
    finishDense(m0, m, P, analysis);
    return;
  }
  detail::Matcher& matcher = *matcher_;
  fillSection(P, [&](int s, std::size_t i) -> const Vec3& { return matcher.x0(s)[i]; });
}

void CorrespondenceObservations::fillSection(const AdjustmentProblem& P, const std::function<const Vec3&(int, std::size_t)>& before) {
  section_.used = static_cast<int>(set_.correspondences.size());
  section_.radius_m = set_.radius_m;
  section_.sigma_m = set_.sigma_m;
  section_.spacing_m = set_.spacing_m;
  section_.pairs = set_.pairs;
  std::map<std::pair<int, int>, std::pair<std::vector<double>, std::vector<double>>> dist;
  std::vector<double> all_b, all_a;
  for (std::size_t k = 0; k < set_.correspondences.size(); ++k) {
    const Correspondence& c = set_.correspondences[k];
    Vec3 cb = Vec3::Zero();
    for (std::size_t j : c.points_b) cb += before(c.strip_b, j);
    cb /= static_cast<double>(c.points_b.size());
    const double d_before = std::abs(c.normal.dot(before(c.strip_a, c.point_a) - cb));
    const double d_after = std::abs(P.residual(blocks_[k])[0] * set_.sigma_m);
    dist[{c.strip_a, c.strip_b}].first.push_back(d_before);
    dist[{c.strip_a, c.strip_b}].second.push_back(d_after);
    all_b.push_back(d_before);
    all_a.push_back(d_after);
  }
  auto stats = [](std::vector<double> v, double* median, double* rms) {
    if (v.empty()) return;
    double ss = 0;
    for (double x : v) ss += x * x;
    *rms = std::sqrt(ss / static_cast<double>(v.size()));
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    *median = v[v.size() / 2];
  };
  std::map<std::string, int> index;
  for (std::size_t s = 0; s < data_.strips.size(); ++s) index[data_.strips[s].id] = static_cast<int>(s);
  for (CorrespondencePairStats& p : section_.pairs) {
    auto it = dist.find({index[p.strip_a], index[p.strip_b]});
    if (it == dist.end()) continue;
    stats(it->second.first, &p.median_before_m, &p.rms_before_m);
    stats(it->second.second, &p.median_after_m, &p.rms_after_m);
  }
  stats(all_b, &section_.median_before_m, &section_.rms_before_m);
  stats(all_a, &section_.median_after_m, &section_.rms_after_m);
}

void CorrespondenceObservations::finishDense(const std::array<double, 6>& m0, const std::array<double, 6>& /*m*/, const AdjustmentProblem& P,
                                             const AnalysisOptions& /*analysis*/) {
  // Before: the same correspondences at the mounting used (no laser offsets, no strip offsets).
  dense_->place(m0, {});
  fillSection(P, [&](int s, std::size_t i) -> const Vec3& { return dense_->x(s, i); });
  // Per-laser elevation offsets: values, σ and correlation with the boresight (a-priori σ of
  // the distances; the mounting's own σ in the summary eliminates these offsets).
  const int L = static_cast<int>(laser_dl_.size());
  if (L == 0 || !laser_block_) return;
  section_.laser_elevation_deg.assign(static_cast<std::size_t>(L), 0.0);
  section_.laser_elevation_sigma_deg.assign(static_cast<std::size_t>(L), std::nan(""));
  section_.laser_boresight_correlation.assign(static_cast<std::size_t>(L), std::nan(""));
  section_.laser_points.assign(static_cast<std::size_t>(L), 0);
  for (int i = 0; i < L; ++i) section_.laser_elevation_deg[static_cast<std::size_t>(i)] = rad2deg(laser_block_[i]);
  for (const Correspondence& c : set_.correspondences) {
    const int la = dense_->laser(c.strip_a, c.point_a);
    if (la >= 0) ++section_.laser_points[static_cast<std::size_t>(la)];
    for (std::size_t j : c.points_b) {
      const int lb = dense_->laser(c.strip_b, j);
      if (lb >= 0) ++section_.laser_points[static_cast<std::size_t>(lb)];
    }
  }
  ceres::Problem& problem = const_cast<AdjustmentProblem&>(P).ceresProblem();
  double* mount = const_cast<AdjustmentProblem&>(P).mounting();
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  co.null_space_rank = -1;
  ceres::Covariance cov(co);
  std::vector<std::pair<const double*, const double*>> blocks = {{laser_block_, laser_block_}};
  const bool mount_free = !problem.IsParameterBlockConstant(mount);
  if (mount_free) blocks.push_back({laser_block_, mount}), blocks.push_back({mount, mount});
  if (!cov.Compute(blocks, &problem)) return;
  Eigen::MatrixXd C_ll(L, L);
  cov.GetCovarianceBlock(laser_block_, laser_block_, C_ll.data());  // row-major, symmetric
  Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor> C_lm(L, 6);
  Eigen::Matrix<double, 6, 6, Eigen::RowMajor> C_mm = Eigen::Matrix<double, 6, 6, Eigen::RowMajor>::Zero();
  if (mount_free) {
    cov.GetCovarianceBlock(laser_block_, mount, C_lm.data());
    cov.GetCovarianceBlock(mount, mount, C_mm.data());
  }
  for (int i = 0; i < L; ++i) {
    if (section_.laser_points[static_cast<std::size_t>(i)] == 0) continue;
    const double v = C_ll(i, i);
    section_.laser_elevation_sigma_deg[static_cast<std::size_t>(i)] = rad2deg(std::sqrt(std::max(v, 0.0)));
    double rho = 0;
    for (int j = 3; j < 6 && mount_free; ++j)
      if (C_mm(j, j) > 0 && v > 0) rho = std::max(rho, std::abs(C_lm(i, j)) / std::sqrt(v * C_mm(j, j)));
    section_.laser_boresight_correlation[static_cast<std::size_t>(i)] = rho;
  }
}

}  // namespace mountcal
