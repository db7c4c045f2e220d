#include "mountcal/methods/correspondence/correspondences.hpp"

#include <ceres/ceres.h>

#include <algorithm>
#include <functional>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <set>
#include <unordered_set>

#include "geometry/kd_tree.hpp"
#include "methods/common/strip_geometry.hpp"
#include "dense_matching.hpp"
#include "core/parallel.hpp"
#include "methods/common/section_format.hpp"
#include "mountcal/core/error.hpp"

namespace mountcal {

namespace {
/// The a-priori misalignment's own bound (CorrespondenceOptions::IsValid) [m].
constexpr double kMaxMisalignmentM = 1000.0;
}  // namespace

bool CorrespondenceOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  auto nonneg = [](double v) { return v >= 0 && std::isfinite(v); };
  if (!nonneg(apriori_misalignment_m) || apriori_misalignment_m > kMaxMisalignmentM)
    return fail("apriori_misalignment_m must be in [0, 1000]");
  if (!nonneg(radius_m) || radius_m > 1000) return fail("radius_m must be in [0, 1000] (0: from the point spacing)");
  if (!nonneg(sample_spacing_m) || sample_spacing_m > 10000) return fail("sample_spacing_m must be in [0, 10000]");
  if (min_neighbours < 3) return fail("min_neighbours must be at least 3");
  if (max_neighbours < min_neighbours || max_neighbours > 1000) return fail("max_neighbours must be in [min_neighbours, 1000]");
  if (normal_neighbours < 0 || normal_neighbours > 1000) return fail("normal_neighbours must be in [0, 1000]");
  if (!(max_roughness_relative >= 1) || !std::isfinite(max_roughness_relative)) return fail("max_roughness_relative must be at least 1");
  if (!(max_roughness_m >= 0) || !std::isfinite(max_roughness_m)) return fail("max_roughness_m must be 0 (off) or a positive length");
  if (!(max_roughness_factor > 0) || !(max_distance_factor > 0) || !(mad_factor > 0))
    return fail("roughness, distance and MAD factors must be positive");
  if (!(max_normal_angle_deg > 0 && max_normal_angle_deg < 90)) return fail("max_normal_angle_deg must be in (0, 90)");
  if (!(min_spread_ratio >= 0 && min_spread_ratio < 1)) return fail("min_spread_ratio must be in [0, 1)");
  if (!(coarse_radius_m > 0 && coarse_radius_m <= 100)) return fail("coarse_radius_m must be in (0, 100]");
  if (!(thin_cell_m >= 0 && thin_cell_m <= 10)) return fail("thin_cell_m must be in [0, 10]");
  if (!laserPriorsValid(error)) return false;
  if (budget < 1 || budget > 10000000) return fail("budget must be in [1, 10000000]");
  if (max_misalignment_growths < 0 || max_misalignment_growths > 20) return fail("max_misalignment_growths must be in [0, 20]");
  if (!nonneg(voxel_size_m) || voxel_size_m > 10000) return fail("voxel_size_m must be in [0, 10000]");
  if (!nonneg(sigma_m)) return fail("sigma_m must be finite and non-negative");
  return true;
}

namespace detail {

namespace {

double pairRadius(const CorrespondenceOptions& options, double spacing_a, double spacing_b) {
  return options.radius_m > 0 ? options.radius_m : std::max(0.25, 2.5 * std::max(spacing_a, spacing_b));
}
double pairVoxel(const CorrespondenceOptions& options, double r) {
  return options.voxel_size_m > 0 ? options.voxel_size_m : std::max(2.0, 4 * r);
}
/// The first round's distance gate: max(3 r, 2 × the a-priori misalignment).
double firstGate(const CorrespondenceOptions& options, double r) {
  return std::max(options.max_distance_factor * r, 2.0 * options.apriori_misalignment_m);
}

std::int64_t cellKey(const Vec3& p, double cell) {
  const auto q = [cell](double v) { return static_cast<std::int64_t>(std::floor(v / cell)) & 0x1fffff; };
  return (q(p.x()) << 42) | (q(p.y()) << 21) | q(p.z());
}

/// One strip's points at the mounting used, their plan spacing and bounding box.
struct StripRef {
  std::vector<Vec3> x0;
  double spacing = 0.0;
  Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
};

/// u = x − p of a pair point at the mounting used (IMU → point, mapping frame) [m].
Vec3 pairImuToPoint(const PairPoint& q, const MountingParameters& used, const Mat3& R_bs_used) {
  return q.R_mb * (R_bs_used * q.r_s_m + used.a_b);
}

StripRef stripRef(const CalibrationData& data, const StripData& st) {
  if (st.r_s.size() != st.time_s.size() || (!st.x_m.empty() && st.x_m.size() != st.time_s.size())) {
    throw InvalidInput("strip '" + st.id + "': time, r_s and x_m must have the same length");
  }
  StripRef ref;
  ref.x0 = referencePoints(data, st, data.mounting_used);
  ref.spacing = planSpacing(ref.x0);
  for (const Vec3& p : ref.x0) ref.lo = ref.lo.cwiseMin(p), ref.hi = ref.hi.cwiseMax(p);
  return ref;
}

bool boxesMeet(const StripRef& A, const StripRef& B, double margin) {
  for (int c = 0; c < 3; ++c)
    if (A.lo[c] > B.hi[c] + margin || B.lo[c] > A.hi[c] + margin) return false;
  return !A.x0.empty() && !B.x0.empty();
}

/// The voxels holding a point of x and their 26 neighbours (a coarse hull dilated by one voxel
/// for the misalignment).
std::unordered_set<std::int64_t> dilatedHull(const std::vector<Vec3>& x, double voxel) {
  std::unordered_set<std::int64_t> occupied, hull;
  for (const Vec3& p : x) {
    if (!occupied.insert(cellKey(p, voxel)).second) continue;
    const Vec3 c((std::floor(p.x() / voxel) + 0.5) * voxel, (std::floor(p.y() / voxel) + 0.5) * voxel,
                 (std::floor(p.z() / voxel) + 0.5) * voxel);
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) hull.insert(cellKey(c + Vec3(dx, dy, dz) * voxel, voxel));
  }
  return hull;
}

/// A k-d tree over some points of a strip (their strip indices kept), exact k nearest.
class PointTree {
 public:
  PointTree(const std::vector<Vec3>& x, std::vector<std::size_t> indices) : index_(std::move(indices)) {
    if (index_.size() < 3) return;
    std::vector<double> xyz(3 * index_.size());
    for (std::size_t k = 0; k < index_.size(); ++k)
      for (int c = 0; c < 3; ++c) xyz[3 * k + static_cast<std::size_t>(c)] = x[index_[k]][c];
    tree_ = KdTree<double, 3>(std::move(xyz));
  }
  /// Strip indices of the k nearest of p within `radius`, nearest first.
  void nearest(const Vec3& p, std::size_t k, double radius, std::vector<std::size_t>* out) {
    out->clear();
    I_.resize(k);
    D_.resize(k);
    const std::size_t found = tree_.nearest(p.data(), k, I_.data(), D_.data());
    for (std::size_t j = 0; j < found; ++j)
      if (D_[j] <= radius * radius) out->push_back(index_[I_[j]]);
  }
  /// Strip indices of every point within `radius` of p (any order).
  void within(const Vec3& p, double radius, std::vector<std::size_t>* out) {
    tree_.within(p.data(), radius, /*sorted=*/false, &W_);
    out->clear();
    for (std::size_t j : W_) out->push_back(index_[j]);
  }
  bool empty() const { return tree_.empty(); }

 private:
  std::vector<std::size_t> index_;
  KdTree<double, 3> tree_;
  std::vector<std::size_t> I_, W_;
  std::vector<double> D_;
};

/// The candidate neighbourhoods of strips a and b (see PairCandidates).
PairCandidates extractPair(const CalibrationData& data, int ia, int ib, const StripRef& A, const StripRef& B,
                           const CorrespondenceOptions& options) {
  const StripData& SA = data.strips[static_cast<std::size_t>(ia)];
  const StripData& SB = data.strips[static_cast<std::size_t>(ib)];
  PairCandidates pc;
  pc.strip_a = SA.id;
  pc.strip_b = SB.id;
  pc.spacing_a_m = A.spacing;
  pc.spacing_b_m = B.spacing;
  const double r = pairRadius(options, A.spacing, B.spacing);
  pc.radius_m = r;
  const double voxel = pairVoxel(options, r);
  if (!boxesMeet(A, B, 2 * voxel)) return pc;
  // A point of one strip is in the overlap where the other's dilated hull holds it.
  const std::unordered_set<std::int64_t> hull_a = dilatedHull(A.x0, voxel), hull_b = dilatedHull(B.x0, voxel);
  const double sample = options.sample_spacing_m > 0 ? options.sample_spacing_m : 2 * r;
  std::vector<std::size_t> act_a, act_b;
  // Samples of A in the overlap: one per sample cell (the point nearest its centre in plan:
  // a choice by height would pick the points with the largest upward noise).
  std::map<std::int64_t, std::pair<double, std::size_t>> cells;
  for (std::size_t i = 0; i < A.x0.size(); ++i) {
    const Vec3& p = A.x0[i];
    if (!hull_b.count(cellKey(p, voxel))) continue;
    act_a.push_back(i);
    const Vec3 q = p / sample;
    const Vec3 f(std::floor(q.x()), std::floor(q.y()), std::floor(q.z()));
    const std::int64_t k = ((static_cast<std::int64_t>(f.x()) & 0x1fffff) << 42) | ((static_cast<std::int64_t>(f.y()) & 0x1fffff) << 21) |
                           (static_cast<std::int64_t>(f.z()) & 0x1fffff);
    const double d = (q - f - Vec3::Constant(0.5)).head<2>().squaredNorm();
    auto it = cells.find(k);
    if (it == cells.end() || d < it->second.first) cells[k] = {d, i};
  }
  if (act_a.empty()) return pc;
  for (std::size_t i = 0; i < B.x0.size(); ++i)
    if (hull_a.count(cellKey(B.x0[i], voxel))) act_b.push_back(i);
  pc.overlap = true;
  pc.overlap_points = act_a.size() + act_b.size();
  std::vector<std::size_t> samples;
  for (const auto& c : cells) samples.push_back(c.second.second);
  std::sort(samples.begin(), samples.end());
  PointTree tree_a(A.x0, act_a), tree_b(B.x0, act_b);
  const auto K = static_cast<std::size_t>(options.max_neighbours);
  const auto min_n = static_cast<std::size_t>(options.min_neighbours);
  const double search_first = std::max(r, firstGate(options, r));  // the first round's neighbour radius
  std::vector<std::size_t> na, nb, around;
  std::vector<std::size_t> kept, ub;
  std::vector<char> in_b(B.x0.size(), 0);
  for (std::size_t i : samples) {
    tree_b.nearest(A.x0[i], K, search_first, &nb);
    tree_a.nearest(A.x0[i], K, r, &na);
    if (nb.size() < min_n || na.size() < min_n) {
      ++pc.sparse_samples;
      continue;
    }
    const PlaneFit fa = fitPlane(na.size(), [&](std::size_t j) { return A.x0[na[j]]; });
    kept.push_back(i);
    pc.normal_a.push_back(fa.normal);
    pc.spread_a.push_back(fa.spread_ratio);
    // B's points a later matching can take as the sample's neighbours: within the K-th
    // neighbour's distance plus the largest discrepancy expected between the strips.
    const double d_k = (B.x0[nb.back()] - A.x0[i]).norm();
    tree_b.within(A.x0[i], d_k + options.apriori_misalignment_m, &around);
    for (std::size_t j : around) in_b[j] = 1;  // balls overlap: marked, not listed again and again
  }
  for (std::size_t j = 0; j < in_b.size(); ++j)
    if (in_b[j]) ub.push_back(j);
  // Poses without a cursor: at a trajectory sample's own time the interval a cursor lands in
  // can differ in the last bit; the solve from a pair file looks the time up the same way.
  auto point = [&](const StripData& S, const StripRef& R, std::size_t i) {
    PairPoint q;
    q.index = i;
    q.time_s = S.time_s[i];
    q.x0_m = R.x0[i];
    q.R_mb = data.pose(S, i).R_mb;
    q.r_s_m = S.r_s[i];
    return q;
  };
  pc.attitudes_stored = !SA.poses.empty() || !SB.poses.empty();
  pc.samples_a.reserve(kept.size());
  pc.points_b.reserve(ub.size());
  for (std::size_t i : kept) pc.samples_a.push_back(point(SA, A, i));
  for (std::size_t i : ub) pc.points_b.push_back(point(SB, B, i));
  return pc;
}

}  // namespace

// Matcher (declared in the public header, so not file-local itself) holds this file's local
// types: GCC warns about that when the file is not the main file of its translation unit (the
// sanitizer build is a unity build), not a problem here — nothing outside this file sees them.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wsubobject-linkage"
#endif

/// The matching machinery: every overlapping pair's candidate neighbourhoods — found once,
/// from the strips (pairs on all threads) or given (a workflow's pair files) — and the
/// matchings at each round's mounting, which select from them.
class Matcher {
 public:
  /// A correspondence's points in its pair's tables.
  struct Ref {
    int pair = 0;
    std::uint32_t a = 0;
    std::vector<std::uint32_t> b;
  };

  Matcher(const CalibrationData& data, const CorrespondenceOptions& opts, int threads) : data_(data), o_(opts), threads_(threads) {
    std::string why;
    if (!opts.IsValid(&why)) throw InvalidInput("correspondence options: " + why);
    if (data.correspondence_candidates) {
      takeGiven(*data.correspondence_candidates);
    } else {
      data.requirePoses();
      std::vector<StripRef> refs(data.strips.size());
      parallelFor(refs.size(), threads_, [&](std::size_t s) { refs[s] = stripRef(data, data.strips[s]); });
      const std::vector<std::pair<int, int>> candidates = pairsOf(data, refs, opts);
      std::vector<PairCandidates> found(candidates.size());
      parallelFor(found.size(), threads_, [&](std::size_t k) {
        found[k] = extractPair(data, candidates[k].first, candidates[k].second, refs[static_cast<std::size_t>(candidates[k].first)],
                               refs[static_cast<std::size_t>(candidates[k].second)], opts);
      });
      for (std::size_t k = 0; k < found.size(); ++k) {
        if (!found[k].overlap) continue;
        index_.push_back(candidates[k]);
        pairs_.push_back(std::move(found[k]));
      }
    }
    for (const PairCandidates& p : pairs_) spacing_ = std::max({spacing_, p.spacing_a_m, p.spacing_b_m});
    // Each pair's k-d tree of B's points at the mounting used, for every matching.
    trees_.resize(pairs_.size());
    ball_.resize(pairs_.size());
    parallelFor(pairs_.size(), threads_, [&](std::size_t k) {
      std::vector<Vec3> x0(pairs_[k].points_b.size());
      std::vector<std::size_t> all(x0.size());
      for (std::size_t j = 0; j < x0.size(); ++j) x0[j] = pairs_[k].points_b[j].x0_m, all[j] = j;
      trees_[k] = std::make_unique<PointTree>(x0, std::move(all));
      ball_[k] = completeRadii(pairs_[k], trees_[k].get());
    });
    r_ = opts.radius_m > 0 ? opts.radius_m : std::max(0.25, 2.5 * spacing_);
  }

  /// Per sample of a pair, the radius about its place at the mounting used within which the
  /// candidates hold every point of B (extractPair): the K-th neighbour's distance d_k plus the
  /// a-priori misalignment — and, where fewer than K points lie within the first round's
  /// search radius, that radius too (B has no other point there).
  std::vector<double> completeRadii(const PairCandidates& pc, PointTree* tree) const {
    const auto K = static_cast<std::size_t>(o_.max_neighbours);
    const double search_first = std::max(pc.radius_m, firstGate(o_, pc.radius_m));
    std::vector<double> out(pc.samples_a.size(), 0.0);
    std::vector<std::size_t> nb;
    for (std::size_t k = 0; k < out.size(); ++k) {
      const Vec3& x = pc.samples_a[k].x0_m;
      tree->nearest(x, K, search_first, &nb);
      if (nb.empty()) continue;
      const double d_k = (pc.points_b[nb.back()].x0_m - x).norm();
      out[k] = nb.size() < K ? std::max(search_first, d_k + o_.apriori_misalignment_m) : d_k + o_.apriori_misalignment_m;
    }
    return out;
  }

  static std::vector<std::pair<int, int>> pairsOf(const CalibrationData& data, const std::vector<StripRef>& refs,
                                                  const CorrespondenceOptions& options) {
    std::vector<std::pair<int, int>> out;
    for (std::size_t a = 0; a < refs.size(); ++a)
      for (std::size_t b = a + 1; b < refs.size(); ++b)
        if (boxesMeet(refs[a], refs[b], 2 * pairVoxel(options, pairRadius(options, refs[a].spacing, refs[b].spacing))))
          out.emplace_back(static_cast<int>(a), static_cast<int>(b));
    (void)data;
    return out;
  }

  double spacing() const { return spacing_; }
  const PairCandidates& pair(int k) const { return pairs_[static_cast<std::size_t>(k)]; }
  const std::vector<Ref>& refs() const { return refs_; }

  /// One matching at mounting m. The first round of an estimation (at the mounting used)
  /// gates distances at max(3 r, 2 × the a-priori misalignment) and applies no MAD rejection
  /// (the discrepancies are still systematic: the largest are the sloped surfaces that carry
  /// the horizontal information); later rounds gate at 3 r and reject beyond 3 σ_MAD.
  CorrespondenceSet match(const std::array<double, 6>& m, bool first_round, const PointShifts& shifts) {
    const auto t0 = std::chrono::steady_clock::now();
    refs_.clear();
    CorrespondenceSet out;
    out.radius_m = r_;
    out.spacing_m = spacing_;
    out.max_distance_m = 0;
    const MountingParameters& used = data_.mounting_used;
    const MountingMotion motion(used.R_nom, used.R_bs(), used.a_b, m.data());
    out.pairs.resize(pairs_.size());
    std::vector<std::vector<Candidate>> per_pair(pairs_.size());
    std::vector<double> gates(pairs_.size(), 0.0);
    // Each pair on its own thread: its points at m, then every sample (selection from the
    // candidate neighbourhoods, the plane fits and the gates). Slots merged in pair order.
    std::vector<double> needed(pairs_.size(), 0.0);
    parallelFor(pairs_.size(), threads_, [&](std::size_t pi) {
      gates[pi] = matchPair(pi, motion, shifts, first_round, &out.pairs[pi], &per_pair[pi], &needed[pi]);
    });
    for (double v : needed) out.needed_misalignment_m = std::max(out.needed_misalignment_m, v);
    std::vector<Candidate> cand;
    for (std::size_t pi = 0; pi < pairs_.size(); ++pi) {
      out.points_searched += pairs_[pi].overlap_points;
      out.max_distance_m = std::max(out.max_distance_m, gates[pi]);
      for (Candidate& c : per_pair[pi]) cand.push_back(std::move(c));
    }
    rejectRough(&cand, &out);
    out.sigma_m = distanceSigma(cand);
    if (!cand.empty() && !first_round) rejectOutliersPerSurfaceClass(out.sigma_m, &cand, &out);
    keepWithinBudget(&cand, &out);
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return out;
  }

 private:
  struct Candidate {
    Correspondence c;
    Ref ref;
  };
  static std::size_t pairOf(const Candidate& c) { return static_cast<std::size_t>(c.ref.pair); }

  /// The candidates of pair pi at the mounting of `motion`, with its statistics; returns the
  /// pair's distance gate [m].
  double matchPair(std::size_t pi, const MountingMotion& motion, const PointShifts& shifts, bool first_round,
                   CorrespondencePairStats* stats, std::vector<Candidate>* candidates, double* needed_misalignment) {
    CorrespondencePairStats& st = *stats;
    const PairCandidates& pr = pairs_[pi];
    st.strip_a = pr.strip_a;
    st.strip_b = pr.strip_b;
    st.samples = static_cast<int>(pr.samples());
    st.rejected_sparse = pr.sparse_samples;
    const double r = pr.radius_m;
    const double gate_m = first_round ? firstGate(o_, r) : o_.max_distance_factor * r;
    const double search_r = std::max(r, gate_m);
    PointTree& tree = *trees_[pi];
    std::vector<std::size_t> found;
    // Where the adjustment puts a point: at m, moved by the last solve's strip offset,
    // corrections and time offset (u from the mounting used: a millimetre-scale difference).
    const MountingParameters& used = data_.mounting_used;
    const Mat3 R_bs_used = used.R_bs();
    const PointShifts::Strip shift_a = shifts.strip(pr.strip_a), shift_b = shifts.strip(pr.strip_b);
    const bool shifted = !shifts.empty();
    auto at = [&](const PairPoint& q, const PointShifts::Strip& shift) {
      Vec3 x = q.x0_m + motion.displacement(q.R_mb, q.r_s_m);
      if (shifted) x += shift.at(q.time_s, pairImuToPoint(q, used, R_bs_used));
      return x;
    };
    std::vector<Vec3> xb(pr.points_b.size());
    for (std::size_t k = 0; k < xb.size(); ++k) xb[k] = at(pr.points_b[k], shift_b);
    const auto K = static_cast<std::size_t>(o_.max_neighbours);
    std::vector<std::uint32_t> nb;
    for (std::size_t k = 0; k < pr.samples_a.size(); ++k) {
      const PairPoint& qa = pr.samples_a[k];
      const Vec3 p = at(qa, shift_a);
      // B: its K points nearest p at m, within the search radius. The tree holds B at the
      // mounting used: the query moves back by the displacement of B's point nearest p, so
      // the neighbours found are those at m up to the displacement's variation across a
      // neighbourhood (a rotation of a few 1e-3 rad over a few metres: millimetres).
      tree.nearest(p, 1, 1e300, &found);
      if (found.empty()) {
        ++st.rejected_sparse;
        continue;
      }
      const Vec3 q = p - (xb[found[0]] - pr.points_b[found[0]].x0_m);
      tree.nearest(q, K, 1e300, &found);
      nb.clear();
      double reach = 0;  // the neighbourhood's extent about q at the mounting used
      for (std::size_t t : found)
        if ((xb[t] - p).squaredNorm() <= search_r * search_r) {
          nb.push_back(static_cast<std::uint32_t>(t));
          reach = std::max(reach, (pr.points_b[t].x0_m - q).norm());
        }
      // Complete only while the ball of the neighbours about q lies within the ball about the
      // sample's place at the mounting used that the candidates hold whole. (A neighbourhood cut
      // short by the search radius, at the edge of B's coverage, is checked on the points it has.)
      const double beyond = (q - qa.x0_m).norm() + reach - ball_[pi][k];
      if (beyond > 0) {
        ++st.rejected_moved;
        *needed_misalignment = std::max(*needed_misalignment, o_.apriori_misalignment_m + beyond);
        continue;
      }
      if (static_cast<int>(nb.size()) < o_.min_neighbours) {
        ++st.rejected_sparse;
        continue;
      }
      const PlaneFit fb = fitPlane(nb.size(), [&](std::size_t j) { return xb[nb[j]]; });
      if (fb.sigma_m > o_.maxPlaneSigma(r) || fb.spread_ratio < o_.min_spread_ratio) {
        ++st.rejected_rough;
        continue;
      }
      const double d = fb.normal.dot(p - fb.centroid);
      if (std::abs(d) > gate_m) {
        ++st.rejected_far;
        continue;
      }
      // A's own plane (at the mounting used: A's points move together).
      if (pr.spread_a[k] < o_.min_spread_ratio) {
        ++st.rejected_rough;
        continue;
      }
      if (angleDeg(pr.normal_a[k], fb.normal) > o_.max_normal_angle_deg) {
        ++st.rejected_normal;
        continue;
      }
      Candidate c;
      c.ref.pair = static_cast<int>(pi);
      c.ref.a = static_cast<std::uint32_t>(k);
      c.ref.b = nb;
      c.c.strip_a = index_[pi].first;
      c.c.strip_b = index_[pi].second;
      c.c.point_a = static_cast<std::size_t>(qa.index);
      for (std::uint32_t t : nb) c.c.points_b.push_back(static_cast<std::size_t>(pr.points_b[t].index));
      c.c.normal = fb.normal;
      c.c.distance_m = d;
      c.c.roughness_m = fb.sigma_m;
      candidates->push_back(std::move(c));
    }
    return gate_m;
  }

  /// Rough relative to the typical plane: neighbourhoods across a ridge, an eave or a wall
  /// edge fit a plane with a σ well above the noise (and a distance biased by the edge).
  void rejectRough(std::vector<Candidate>* candidates, CorrespondenceSet* out) const {
    std::vector<Candidate>& cand = *candidates;
    std::vector<double> rough;
    for (const auto& c : cand) rough.push_back(c.c.roughness_m);
    if (!rough.empty()) {
      std::nth_element(rough.begin(), rough.begin() + static_cast<long>(rough.size() / 2), rough.end());
      const double limit = std::max(o_.max_roughness_relative * rough[rough.size() / 2], 0.005);
      std::vector<Candidate> kept;
      for (auto& c : cand) {
        if (c.c.roughness_m > limit)
          ++out->pairs[pairOf(c)].rejected_rough;
        else
          kept.push_back(std::move(c));
      }
      cand.swap(kept);
    }
  }

  /// σ of a distance: stated, or from the planes' roughness (median, both sides' noise).
  double distanceSigma(const std::vector<Candidate>& cand) const {
    std::vector<double> rough;
    for (const auto& c : cand) rough.push_back(c.c.roughness_m);
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
    return sigma;
  }

  /// Beyond mad_factor × σ_MAD of the distances (never tighter than 3σ): rejected — per
  /// class of surface (level, sloped, steep), since a sloped surface shows what is left of a
  /// horizontal misalignment and level ground does not: gated by the ground's spread, the
  /// roofs that still disagree would go, and with them what pulls the mounting back.
  void rejectOutliersPerSurfaceClass(double sigma, std::vector<Candidate>* candidates, CorrespondenceSet* out) const {
    std::vector<Candidate>& cand = *candidates;
    {
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
        if (per[k].size() >= 10)
          medianAndLimit(per[k], &med[k], &lim[k]);
        else
          med[k] = med_all, lim[k] = lim_all;
      }
      std::vector<Candidate> kept;
      for (auto& c : cand) {
        const auto k = static_cast<std::size_t>(tiltClass(c.c.normal));
        if (std::abs(c.c.distance_m - med[k]) > lim[k])
          ++out->pairs[pairOf(c)].rejected_mad;
        else
          kept.push_back(std::move(c));
      }
      cand.swap(kept);
    }
  }

  /// Normal-space thinning to the budget: round robin over orientation bins (level, sloped
  /// and steep by aspect octant), evenly spread within each bin; the kept go into `out`.
  void keepWithinBudget(std::vector<Candidate>* candidates, CorrespondenceSet* out) {
    std::vector<Candidate>& cand = *candidates;
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
      CorrespondencePairStats& st = out->pairs[pairOf(cand[i])];
      if (take[i]) {
        ++st.kept;
        out->correspondences.push_back(std::move(cand[i].c));
        refs_.push_back(std::move(cand[i].ref));
      } else {
        ++st.rejected_budget;
      }
    }
  }

  /// Pair files: each pair's strips by id, in strip order, once.
  void takeGiven(const std::vector<PairCandidates>& given) {
    std::map<std::string, int> by_id;
    for (std::size_t s = 0; s < data_.strips.size(); ++s) by_id[data_.strips[s].id] = static_cast<int>(s);
    std::vector<std::pair<std::pair<int, int>, const PairCandidates*>> order;
    for (const PairCandidates& p : given) {
      auto a = by_id.find(p.strip_a), b = by_id.find(p.strip_b);
      if (a == by_id.end() || b == by_id.end())
        throw InvalidInput("correspondence candidates of strips '" + p.strip_a + "' and '" + p.strip_b + "': the job has no strip '" +
                           (a == by_id.end() ? p.strip_a : p.strip_b) + "'");
      if (a->second >= b->second)
        throw InvalidInput("correspondence candidates of strips '" + p.strip_a + "' and '" + p.strip_b +
                           "': the strips must be in the job's order (match the pair as '" + p.strip_b + "' '" + p.strip_a + "')");
      if (!p.overlap) continue;
      order.push_back({{a->second, b->second}, &p});
    }
    std::sort(order.begin(), order.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
    for (std::size_t k = 1; k < order.size(); ++k)
      if (order[k].first == order[k - 1].first)
        throw InvalidInput("correspondence candidates of strips '" + order[k].second->strip_a + "' and '" + order[k].second->strip_b +
                           "' given twice");
    for (const auto& e : order) {
      index_.push_back(e.first);
      pairs_.push_back(*e.second);
    }
  }

  const CalibrationData& data_;
  CorrespondenceOptions o_;
  int threads_ = 0;
  std::vector<std::pair<int, int>> index_;  // strip indices of each pair
  std::vector<PairCandidates> pairs_;
  std::vector<std::unique_ptr<PointTree>> trees_;
  std::vector<std::vector<double>> ball_;  // per pair and sample: completeRadii
  std::vector<Ref> refs_;                  // of the last matching's correspondences
  double spacing_ = 0, r_ = 0;
};

#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif

}  // namespace detail

void PairCandidates::attitudesFrom(const Trajectory& trajectory) {
  for (auto* table : {&samples_a, &points_b})
    for (PairPoint& q : *table) q.R_mb = trajectory.pose(q.time_s).R_mb;
}

CorrespondenceSet findCorrespondences(const CalibrationData& data, const std::array<double, 6>& mounting,
                                      const CorrespondenceOptions& options, bool first_round, int threads) {
  detail::Matcher matcher(data, options, threads);
  return matcher.match(mounting, first_round, PointShifts{});
}

std::vector<std::pair<int, int>> candidateStripPairs(const CalibrationData& data, const CorrespondenceOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidInput("correspondence options: " + why);
  data.requirePoses();
  std::vector<detail::StripRef> refs(data.strips.size());
  detail::parallelFor(refs.size(), 0, [&](std::size_t s) { refs[s] = detail::stripRef(data, data.strips[s]); });
  return detail::Matcher::pairsOf(data, refs, options);
}

PairCandidates findPairCandidates(const CalibrationData& data, int a, int b, const CorrespondenceOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidInput("correspondence options: " + why);
  const int n = static_cast<int>(data.strips.size());
  if (a < 0 || b < 0 || a >= n || b >= n || a == b)
    throw InvalidInput("findPairCandidates: strips " + std::to_string(a) + " and " + std::to_string(b) + " are not two strips of the data");
  data.requirePoses();
  const detail::StripRef A = detail::stripRef(data, data.strips[static_cast<std::size_t>(a)]);
  const detail::StripRef B = detail::stripRef(data, data.strips[static_cast<std::size_t>(b)]);
  return detail::extractPair(data, a, b, A, B, options);
}

namespace {

/// The points of `set`'s correspondences (A's and B's) per laser id, lasers 0..L−1.
std::vector<int> laserPoints(const CorrespondenceSet& set, const detail::DenseMatcher& dense, int L) {
  std::vector<int> n(static_cast<std::size_t>(L), 0);
  auto count = [&](int laser) {
    if (laser >= 0 && laser < L) ++n[static_cast<std::size_t>(laser)];
  };
  for (const Correspondence& c : set.correspondences) {
    count(dense.laser(c.strip_a, c.point_a));
    for (std::size_t j : c.points_b) count(dense.laser(c.strip_b, j));
  }
  return n;
}

/// One correspondence: r = n·((x_A(M) + o_A) − (x̄_B(M) + o_B))/σ, every point moved from its
/// position at the mounting used by SPEC §2 eq. (1) differenced, R_mb (ΔR_bs r_s + Δa_b). With n
/// held, n·R_mb ΔR_bs r_s = Σ_kl (nᵀR_mb)_k r_l ΔR_kl: the sums over A's point and B's k
/// neighbours are gathered once into g (9 numbers) and h = Σ nᵀR_mb (3), so an evaluation is
/// r = (n·(x_A0 − x̄_B0) + g·vec(ΔR_bs) + h·Δa_b + n·(o_A − o_B))/σ — the same value, exactly
/// (a test compares it with GeoreferenceModel), without a loop over the neighbours.
struct CorrespondenceResidual {
  double c0 = 0;                  // n·(x_A0 − x̄_B0) [m]
  Eigen::Matrix<double, 9, 1> g;  // (nᵀR_A)_k r_A,l − mean_j (nᵀR_j)_k r_j,l
  Vec3 h;                         // nᵀR_A − mean_j nᵀR_j
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

CorrespondenceObservations::CorrespondenceObservations(const CalibrationData& data, const CorrespondenceOptions& options, int threads)
    : data_(data), options_(options), threads_(threads) {
  std::string why;
  if (!options_.IsValid(&why)) throw InvalidInput("correspondence options: " + why);
}

bool CorrespondenceObservations::settled() const { return !options_.dense || !coarse_; }

detail::LaserLayout CorrespondenceObservations::laserLayout() const {
  if (!dense_ || laser_dl_.empty()) return {};
  return detail::LaserLayout(dense_->laserCount(), options_.laserPrior());
}

void CorrespondenceObservations::solved(const AdjustmentProblem& problem) {
  // The next matching pairs the points where the adjustment now puts them: an estimated time
  // offset or trajectory correction moves them by decimetres (5 ms at 60 m/s: 0.3 m).
  shifts_ = problem.pointShifts();
  if (laser_block_) std::copy(laser_block_, laser_block_ + static_cast<long>(laser_dl_.size()), laser_dl_.begin());
}

void CorrespondenceObservations::addDenseBlocks(const std::array<double, 6>& mounting, AdjustmentProblem* problem) {
  if (!dense_) {
    dense_ = std::make_unique<detail::DenseMatcher>(data_, options_);
    if (options_.estimatesLaserIntrinsics())
      laser_dl_.assign(static_cast<std::size_t>(detail::LaserLayout(dense_->laserCount(), options_.laserPrior()).size), 0.0);
    coarse_ = true;
  }
  // Stage: coarse until the mounting stops moving (or for 15 rounds), then fine.
  if (coarse_ && section_.rounds > 0) {
    double change_m = 0, change_rad = 0;
    for (int j = 0; j < 3; ++j)
      change_m = std::max(change_m, std::abs(mounting[static_cast<std::size_t>(j)] - last_[static_cast<std::size_t>(j)]));
    for (int j = 3; j < 6; ++j)
      change_rad = std::max(change_rad, std::abs(mounting[static_cast<std::size_t>(j)] - last_[static_cast<std::size_t>(j)]));
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
    dense_->place(mounting, laserLayout().corrections(laser_dl_.data()), shifts_);
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
  // The per-laser offsets join from the third matching on (or when the coarse stage ends): the
  // first two pair the points at the a-priori mounting and after one coarse solve, where the
  // misfit is the mounting's, and a laser's elevation offset free there takes up part of it and
  // settles on a wrong, self-consistent value that the later matchings keep (HDL-32E seed 10,
  // 1000 samples per pair: laser 15 at +0.239 deg against a true -0.068 deg, 16 sigma). Held for
  // the whole coarse stage they start the fine stage too far off to reach the truth (noise-free
  // HDL-32E: an elevation 0.011 deg off, the boresight 0.0066 deg).
  constexpr int kLaserHeldMatchings = 2;
  const detail::LaserLayout layout = coarse_ && section_.rounds <= kLaserHeldMatchings ? detail::LaserLayout{} : laserLayout();
  const int L = layout.lasers;
  laser_block_ = nullptr;
  if (!layout.empty()) {
    laser_block_ = problem->addNuisanceBlock(layout.size, laser_dl_.data(), nullptr, false);
    problem->reportCovariance(laser_block_, "the per-laser offsets");  // σ with the trajectory errors in time, as the mounting's
    // Priors: each value N(0, σ_prior of its group), the means of elevation, azimuth and vertical
    // offsets over the lasers this matching sees held at 0 (detail::addLaserPriors).
    const std::vector<int> points = laserPoints(set_, *dense_, L);
    std::vector<bool> seen;
    for (int n : points) seen.push_back(n > 0);
    detail::addLaserPriors(problem, laser_block_, layout, options_.laserPrior(), seen);
  }
  const Mat3& R_nom = data_.mounting_used.R_nom;
  const double loss_scale = coarse_ ? 0.3 * set_.radius_m : -1.0;
  blocks_.clear();
  const Mat3 R_bs_used = data_.mounting_used.R_bs();
  const Vec3& a_b = data_.mounting_used.a_b;
  auto epochOf = [&](int s, const std::vector<std::size_t>& idx) {
    const StripData& st = data_.strips[static_cast<std::size_t>(s)];
    double t = 0;
    Vec3 u = Vec3::Zero();
    for (std::size_t i : idx) {
      t += st.time_s[i];
      u += dense_->R_mb(s, i) * (R_bs_used * st.r_s[i] + a_b);
    }
    const double k = static_cast<double>(idx.size());
    problem->setEpoch(blocks_.back(), st.id, t / k, u / k);
  };
  for (const Correspondence& c : set_.correspondences) {
    std::vector<detail::DenseResidual::Point> pts;
    auto add = [&](int s, std::size_t i, double w) {
      detail::DenseResidual::Point q;
      q.p_m = dense_->p_m(s, i);
      q.R_mb = dense_->R_mb(s, i);
      q.r_s = data_.strips[static_cast<std::size_t>(s)].r_s[i];
      q.laser = laser_block_ ? dense_->laser(s, i) : -1;
      q.weight = w;
      pts.push_back(q);
    };
    add(c.strip_a, c.point_a, 1.0);
    for (std::size_t j : c.points_b) add(c.strip_b, j, -1.0 / static_cast<double>(c.points_b.size()));
    auto* cost = new detail::DenseResidual(pts, c.normal, R_nom, set_.sigma_m, layout);
    std::vector<double*> blocks = {problem->mounting(), problem->stripOffset(data_.strips[static_cast<std::size_t>(c.strip_a)].id),
                                   problem->stripOffset(data_.strips[static_cast<std::size_t>(c.strip_b)].id)};
    if (laser_block_) blocks.push_back(laser_block_);
    blocks_.push_back(loss_scale > 0 ? problem->addResidualBlock(cost, set_.sigma_m, blocks, loss_scale)
                                     : problem->addResidualBlock(cost, set_.sigma_m, blocks));
    // Trajectory errors in time: the point of A at its time, B's neighbourhood at its mean.
    epochOf(c.strip_a, {c.point_a});
    epochOf(c.strip_b, c.points_b);
  }
}

void CorrespondenceObservations::matchGrowing(const std::array<double, 6>& mounting) {
  section_.candidates_given = data_.correspondence_candidates != nullptr;
  if (!matcher_) matcher_ = std::make_unique<detail::Matcher>(data_, options_, threads_);
  const bool first_round = mounting == data_.mounting_used.toArray();
  set_ = matcher_->match(mounting, first_round, shifts_);
  // The strips moved against each other beyond the misalignment the candidates were found for:
  // found again from the strips with a margin of what this matching needed, grown by half (the
  // solve that follows may move them further), at least doubled.
  while (set_.needed_misalignment_m > 0 && !section_.candidates_given &&
         section_.misalignment_growths < options_.max_misalignment_growths && options_.apriori_misalignment_m < kMaxMisalignmentM) {
    section_.search_time_s += set_.seconds;
    options_.apriori_misalignment_m =
        std::min(kMaxMisalignmentM, std::max(2.0 * options_.apriori_misalignment_m, 1.5 * set_.needed_misalignment_m));
    ++section_.misalignment_growths;
    matcher_ = std::make_unique<detail::Matcher>(data_, options_, threads_);
    set_ = matcher_->match(mounting, first_round, shifts_);
  }
  section_.apriori_misalignment_m = options_.apriori_misalignment_m;
  section_.needed_misalignment_m = set_.needed_misalignment_m;
}

void CorrespondenceObservations::addBlocks(const std::array<double, 6>& mounting, AdjustmentProblem* problem) {
  if (options_.dense) {
    addDenseBlocks(mounting, problem);
    return;
  }
  matchGrowing(mounting);
  const detail::Matcher& matcher = *matcher_;
  ++section_.rounds;
  section_.search_time_s += set_.seconds;
  section_.points_searched += set_.points_searched;
  const MountingParameters& used = data_.mounting_used;
  const Mat3 R_bs_used = used.R_bs();
  const double inv_sigma = 1.0 / set_.sigma_m;
  ceres::NumericDiffOptions nd;
  nd.relative_step_size = problem->numericDiffRelativeStep();
  blocks_.clear();
  for (std::size_t k = 0; k < set_.correspondences.size(); ++k) {
    const Correspondence& c = set_.correspondences[k];
    const detail::Matcher::Ref& ref = matcher.refs()[k];
    const PairCandidates& pr = matcher.pair(ref.pair);
    auto* f = new CorrespondenceResidual;
    const Vec3& n = c.normal;
    Vec3 cb = Vec3::Zero(), hb = Vec3::Zero();
    Eigen::Matrix<double, 9, 1> gb = Eigen::Matrix<double, 9, 1>::Zero();
    for (std::uint32_t j : ref.b) {
      const PairPoint& q = pr.points_b[j];
      cb += q.x0_m;
      const Vec3 nR = q.R_mb.transpose() * n;
      hb += nR;
      for (int kk = 0; kk < 3; ++kk)
        for (int l = 0; l < 3; ++l) gb[3 * kk + l] += nR[kk] * q.r_s_m[l];
    }
    const double kb = static_cast<double>(ref.b.size());
    const PairPoint& qa = pr.samples_a[ref.a];
    const Vec3 nRa = qa.R_mb.transpose() * n;
    for (int kk = 0; kk < 3; ++kk)
      for (int l = 0; l < 3; ++l) f->g[3 * kk + l] = nRa[kk] * qa.r_s_m[l] - gb[3 * kk + l] / kb;
    f->h = nRa - hb / kb;
    f->c0 = n.dot(qa.x0_m - cb / kb);
    f->n = n;
    f->used = &data_.mounting_used;
    f->R_bs_used = R_bs_used;
    f->inv_sigma = inv_sigma;
    auto* cost = new ceres::NumericDiffCostFunction<CorrespondenceResidual, ceres::CENTRAL, 1, 6, 3, 3>(f, ceres::TAKE_OWNERSHIP, 1, nd);
    const std::string& id_a = data_.strips[static_cast<std::size_t>(c.strip_a)].id;
    const std::string& id_b = data_.strips[static_cast<std::size_t>(c.strip_b)].id;
    blocks_.push_back(
        problem->addResidualBlock(cost, set_.sigma_m, {problem->mounting(), problem->stripOffset(id_a), problem->stripOffset(id_b)}));
    // Trajectory errors in time: the point of A at its time, B's neighbourhood at its mean.
    double tb = 0;
    Vec3 ub = Vec3::Zero();
    for (std::uint32_t j : ref.b) {
      tb += pr.points_b[j].time_s;
      ub += detail::pairImuToPoint(pr.points_b[j], used, R_bs_used);
    }
    problem->setEpoch(blocks_.back(), id_a, qa.time_s, detail::pairImuToPoint(qa, used, R_bs_used));
    problem->setEpoch(blocks_.back(), id_b, tb / kb, ub / kb);
  }
}

void CorrespondenceObservations::finish(const std::array<double, 6>& m0, const std::array<double, 6>& m, const AdjustmentProblem& problem,
                                        const AnalysisOptions& analysis) {
  if (options_.dense) {
    finishDense(m0, m, problem, analysis);
    return;
  }
  // Before: each correspondence's distance at the mounting used (its points' x0).
  const detail::Matcher& matcher = *matcher_;
  std::vector<double> before(set_.correspondences.size());
  for (std::size_t k = 0; k < before.size(); ++k) {
    const detail::Matcher::Ref& ref = matcher.refs()[k];
    const PairCandidates& pr = matcher.pair(ref.pair);
    Vec3 cb = Vec3::Zero();
    for (std::uint32_t j : ref.b) cb += pr.points_b[j].x0_m;
    cb /= static_cast<double>(ref.b.size());
    before[k] = std::abs(set_.correspondences[k].normal.dot(pr.samples_a[ref.a].x0_m - cb));
  }
  fillSection(problem, before);
}

void CorrespondenceObservations::fillSection(const AdjustmentProblem& problem, const std::vector<double>& distance_before_m) {
  section_.used = static_cast<int>(set_.correspondences.size());
  section_.radius_m = set_.radius_m;
  section_.sigma_m = set_.sigma_m;
  section_.spacing_m = set_.spacing_m;
  section_.pairs = set_.pairs;
  std::map<std::pair<int, int>, std::pair<std::vector<double>, std::vector<double>>> dist;
  std::vector<double> all_b, all_a;
  for (std::size_t k = 0; k < set_.correspondences.size(); ++k) {
    const Correspondence& c = set_.correspondences[k];
    const double d_before = distance_before_m[k];
    const double d_after = std::abs(problem.residual(blocks_[k])[0] * set_.sigma_m);
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

void CorrespondenceObservations::finishDense(const std::array<double, 6>& m0, const std::array<double, 6>& /*m*/,
                                             const AdjustmentProblem& adjustment, const AnalysisOptions& /*analysis*/) {
  // Before: the same correspondences at the mounting used (no laser offsets, no strip offsets).
  dense_->place(m0, {}, PointShifts{});
  std::vector<double> before;
  for (const Correspondence& c : set_.correspondences) {
    Vec3 cb = Vec3::Zero();
    for (std::size_t j : c.points_b) cb += dense_->x(c.strip_b, j);
    cb /= static_cast<double>(c.points_b.size());
    before.push_back(std::abs(c.normal.dot(dense_->x(c.strip_a, c.point_a) - cb)));
  }
  fillSection(adjustment, before);
  if (laser_block_) fillLaserSection(adjustment);
}

void CorrespondenceObservations::fillLaserSection(const AdjustmentProblem& adjustment) {
  // Per-laser intrinsics: values, σ, correlation with the boresight and the screening.
  const detail::LaserLayout layout = laserLayout();
  section_.laser_intrinsics =
      detail::laserEstimates(adjustment, laser_block_, layout, options_.laserPrior(), laserPoints(set_, *dense_, layout.lasers));
}

}  // namespace mountcal
