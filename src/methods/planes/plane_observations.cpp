#include "mountcal/methods/planes/plane_observations.hpp"

#include <ceres/ceres.h>
#include <ceres/product_manifold.h>
#include <ceres/sphere_manifold.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <set>

#include "geometry/plane_ransac.hpp"
#include "methods/common/laser_intrinsics.hpp"
#include "methods/common/strip_geometry.hpp"
#include "mountcal/core/error.hpp"

namespace mountcal {

bool PlaneOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  if (!(sigma_m >= 0) || !std::isfinite(sigma_m)) return fail("sigma_m must be finite and non-negative");
  if (!(ransac_threshold_m > 0) || !std::isfinite(ransac_threshold_m)) return fail("ransac_threshold_m must be positive");
  if (ransac_iterations < 1 || ransac_iterations > 100000) return fail("ransac_iterations must be in [1, 100000]");
  if (min_points_per_strip < 3) return fail("min_points_per_strip must be at least 3");
  if (max_points_per_strip < min_points_per_strip) return fail("max_points_per_strip must be at least min_points_per_strip");
  if (!(max_normal_angle_deg > 0 && max_normal_angle_deg < 90)) return fail("max_normal_angle_deg must be in (0, 90)");
  if (!(cell_size_m >= 0) || cell_size_m > 1000) return fail("cell_size_m must be in [0, 1000]");
  if (!(max_roughness_m > 0) || !std::isfinite(max_roughness_m)) return fail("max_roughness_m must be positive");
  if (!(growing_angle_deg > 0 && growing_angle_deg < 90)) return fail("growing_angle_deg must be in (0, 90)");
  if (!(max_plane_offset_m > 0) || !std::isfinite(max_plane_offset_m)) return fail("max_plane_offset_m must be positive");
  if (!(search_margin_m >= 0) || search_margin_m > 100) return fail("search_margin_m must be in [0, 100]");
  if (!(edge_margin_m >= 0) || edge_margin_m > 1000) return fail("edge_margin_m must be in [0, 1000]");
  if (!(max_patch_size_m > 0) || max_patch_size_m > 10000) return fail("max_patch_size_m must be in (0, 10000]");
  if (max_patches < 1 || max_patches > 100000) return fail("max_patches must be in [1, 100000]");
  if (!laserPriorsValid(error)) return false;
  return true;
}

namespace {

/// The least σ of a point-to-plane distance pooled from the plane fits [m].
constexpr double kPooledSigmaFloorM = 0.002;

/// The σ of a point-to-plane distance pooled from the strips' own plane fits: their median,
/// floored at kPooledSigmaFloorM; 2 cm when no strip fitted a plane. Reorders `fit_sigmas`.
double pooledFitSigma(std::vector<double>* fit_sigmas) {
  if (fit_sigmas->empty()) return 0.02;
  const auto mid = fit_sigmas->begin() + static_cast<long>(fit_sigmas->size() / 2);
  std::nth_element(fit_sigmas->begin(), mid, fit_sigmas->end());
  return std::max(kPooledSigmaFloorM, *mid);
}

struct StripCloud {
  const StripData* strip = nullptr;
  std::vector<Vec3> x0;                    ///< at M_used [m]
  std::vector<Vec3> x_at;                  ///< at the mounting the cloud was made for (empty: M_used) [m]
  std::unique_ptr<detail::PlanGrid> grid;  ///< over at()
  const std::vector<Vec3>& at() const { return x_at.empty() ? x0 : x_at; }
};

/// Every strip's points at M_used and, given `m` (MountingIndex order [m, rad]), at m — the plan
/// grid over the latter.
std::vector<StripCloud> makeClouds(const CalibrationData& data, double cell_m, const std::array<double, 6>* m = nullptr) {
  data.requirePoses();
  std::vector<StripCloud> clouds;
  const MountingParameters& used = data.mounting_used;
  for (const StripData& s : data.strips) {
    if (s.r_s.size() != s.time_s.size() || (!s.x_m.empty() && s.x_m.size() != s.time_s.size())) {
      throw InvalidInput("strip '" + s.id + "': time, r_s and x_m must have the same length");
    }
    StripCloud c;
    c.strip = &s;
    c.x0 = detail::referencePoints(data, s, used);
    if (m && *m != used.toArray()) {
      const detail::MountingMotion motion(used.R_nom, used.R_bs(), used.a_b, m->data());
      c.x_at.resize(c.x0.size());
      std::size_t cursor = 0;
      for (std::size_t i = 0; i < c.x0.size(); ++i) c.x_at[i] = c.x0[i] + motion.displacement(data.pose(s, i, &cursor).R_mb, s.r_s[i]);
    }
    c.grid = std::make_unique<detail::PlanGrid>(c.at(), cell_m);
    clouds.push_back(std::move(c));
  }
  return clouds;
}

/// Orientation bin of a normal: 0 level (tilt < 10°), 1–8 sloped by aspect octant, 9–16 steep.
int normalBin(const Vec3& n) {
  const double tilt = rad2deg(std::acos(std::min(1.0, std::abs(n.z()))));
  if (tilt < 10.0) return 0;
  const double aspect = std::fmod(rad2deg(std::atan2(n.x(), n.y())) + 360.0, 360.0);
  const int octant = static_cast<int>(aspect / 45.0) % 8;
  return (tilt < 60.0 ? 1 : 9) + octant;
}

/// RANSAC plane of a strip's points, refined by least squares; the inliers.
std::vector<std::uint32_t> ransacPlane(const std::vector<Vec3>& X, const std::vector<std::uint32_t>& idx, double threshold, int iterations,
                                       std::uint32_t seed, detail::PlaneFit* fit) {
  if (idx.size() < 3) return {};
  std::mt19937 rng(seed);
  std::uniform_int_distribution<std::size_t> pick(0, idx.size() - 1);
  const detail::PlaneHypothesis plane = detail::ransacPlane(X, idx, threshold, iterations, [&] { return pick(rng); });
  if (!plane.found) return {};
  const std::vector<std::uint32_t> best = detail::planeInliers(X, idx, plane.normal, plane.point, threshold);
  if (best.size() < 3) return {};
  *fit = detail::fitPlane(best.size(), [&](std::size_t k) { return X[best[k]]; });
  // Refine: inliers within 3 robust σ of the least-squares plane (never wider than the RANSAC
  // threshold, never tighter than 5 mm), so that a neighbouring surface's points near a shared
  // edge do not enter the patch.
  std::vector<double> dist;
  for (std::uint32_t i : best) dist.push_back(std::abs(fit->normal.dot(X[i] - fit->centroid)));
  std::nth_element(dist.begin(), dist.begin() + static_cast<long>(dist.size() / 2), dist.end());
  const double limit = std::clamp(3.0 * 1.4826 * dist[dist.size() / 2], 0.005, threshold);
  std::vector<std::uint32_t> in;
  for (int pass = 0; pass < 2; ++pass) {
    in.clear();
    for (std::uint32_t i : idx)
      if (std::abs(fit->normal.dot(X[i] - fit->centroid)) <= limit) in.push_back(i);
    if (in.size() < 3) return {};
    *fit = detail::fitPlane(in.size(), [&](std::size_t k) { return X[in[k]]; });
  }
  return in;
}

/// One point of a patch: r = (n̂·(x(M) + o − c) − d)/σ, x(M) by SPEC §2 eq. (1) relative to
/// the point's position at the mounting used (detail::MountingMotion, exact).
struct PlanePointResidual {
  const PlaneObservations::PatchPoint* p;
  const MountingParameters* used;
  Mat3 R_bs_used;
  double inv_sigma;
  bool operator()(const double* m, const double* plane, const double* o, double* r) const {
    const detail::MountingMotion motion = detail::cachedMountingMotion(used->R_nom, R_bs_used, used->a_b, m);
    const Vec3 x = p->x0_rel + motion.displacement(p->R_mb, p->r_s) + Vec3(o[0], o[1], o[2]);
    const Vec3 n(plane[0], plane[1], plane[2]);
    r[0] = (n.dot(x) / n.norm() - plane[3]) * inv_sigma;
    return true;
  }
};

/// PlanePointResidual of a multi-beam point whose laser's intrinsics are θ (dl: LaserCorrection's
/// five groups, detail::OneLaserOfBlock): its laser vector corrected exactly by LaserCorrector (the
/// correction apply writes), and x(M, θ) = x(M) + R_mb R_bs(M) (r_s' − r_s), with
/// R_bs(M) = R_bs,used + ΔR_bs (MountingMotion).
struct PlaneLaserPointResidual {
  const PlaneObservations::PatchPoint* p;
  const MountingParameters* used;
  Mat3 R_bs_used;
  double inv_sigma;
  bool operator()(const double* m, const double* plane, const double* o, const double* dl, double* r) const {
    const detail::MountingMotion motion = detail::cachedMountingMotion(used->R_nom, R_bs_used, used->a_b, m);
    const Vec3 dr = LaserCorrector(LaserCorrection{dl[0], dl[1], dl[2], dl[3], dl[4]})(p->r_s) - p->r_s;
    const Vec3 x = p->x0_rel + motion.displacement(p->R_mb, p->r_s) + p->R_mb * ((R_bs_used + motion.dR_bs) * dr) + Vec3(o[0], o[1], o[2]);
    const Vec3 n(plane[0], plane[1], plane[2]);
    r[0] = (n.dot(x) / n.norm() - plane[3]) * inv_sigma;
    return true;
  }
};

}  // namespace

namespace {

/// The automatic patches' plan cell [m]: stated, or 5 × the point spacing, at least 1.5 m.
double patchCell(const CalibrationData& data, const PlaneOptions& opts) {
  if (opts.cell_size_m > 0) return opts.cell_size_m;
  std::vector<StripCloud> probe = makeClouds(data, 2.0);
  double spacing = 1e300;
  for (const auto& c : probe) spacing = std::min(spacing, detail::planSpacing(c.x0));
  return std::max(1.5, 5.0 * spacing);
}

/// findPlanarPatches with the strips' points at mounting m (null: at M_used), on a plan grid of
/// `cell` (patchCell).
std::vector<PlanarPatch> findPatchesAt(const CalibrationData& data, const PlaneOptions& opts, double cell, const std::array<double, 6>* m) {
  std::vector<StripCloud> clouds = makeClouds(data, cell, m);
  // Per cell, the plane of every strip that sees it (planar ones only).
  struct CellPlane {
    int strip;
    detail::PlaneFit fit;
  };
  struct Cell {
    std::int64_t ix, iy;
    Vec3 normal;
    std::vector<CellPlane> planes;
  };
  std::map<std::pair<std::int64_t, std::int64_t>, Cell> cells;
  const int min_pts = 6;
  std::map<std::pair<std::int64_t, std::int64_t>, std::vector<CellPlane>> per_cell;
  for (int s = 0; s < static_cast<int>(clouds.size()); ++s) {
    for (const auto& cell : clouds[s].grid->cells()) {
      const auto& idx = cell.second;  // a named reference: a lambda may not capture a structured binding before C++20
      if (static_cast<int>(idx.size()) < min_pts) continue;
      const detail::PlaneFit f = detail::fitPlane(idx.size(), [&](std::size_t k) { return clouds[s].at()[idx[k]]; });
      if (f.sigma_m > opts.max_roughness_m) continue;
      const Vec3& c = f.centroid;
      per_cell[{clouds[s].grid->cellIndex(c.x()), clouds[s].grid->cellIndex(c.y())}].push_back({s, f});
    }
  }
  for (auto& [k, planes] : per_cell) {
    if (planes.size() < 2) continue;
    std::sort(planes.begin(), planes.end(), [](const CellPlane& a, const CellPlane& b) { return a.fit.n > b.fit.n; });
    const Vec3 n0 = planes[0].fit.normal;
    std::vector<CellPlane> agree;
    Vec3 nsum = Vec3::Zero();
    for (const auto& p : planes)
      if (detail::angleDeg(p.fit.normal, n0) <= opts.max_normal_angle_deg) {
        agree.push_back(p);
        nsum += p.fit.normal.dot(n0) < 0 ? -p.fit.normal : p.fit.normal;
      }
    if (agree.size() < 2) continue;
    cells[k] = Cell{k.first, k.second, nsum.normalized(), agree};
  }
  // Region growing over 8-neighbour cells: similar normal, coplanar on a strip both see.
  std::set<std::pair<std::int64_t, std::int64_t>> used;
  struct Region {
    Vec3 normal;
    std::vector<std::pair<std::int64_t, std::int64_t>> members;
  };
  std::vector<Region> regions;
  const int half = std::max(0, static_cast<int>(std::floor(0.5 * opts.max_patch_size_m / cell)));
  for (const auto& [k, seed] : cells) {
    if (used.count(k)) continue;
    Region reg{seed.normal, {k}};
    used.insert(k);
    std::vector<std::pair<std::int64_t, std::int64_t>> queue{k};
    while (!queue.empty()) {
      const auto cur = queue.back();
      queue.pop_back();
      for (int dx = -1; dx <= 1; ++dx)
        for (int dy = -1; dy <= 1; ++dy) {
          const std::pair<std::int64_t, std::int64_t> nb{cur.first + dx, cur.second + dy};
          if (used.count(nb) || std::abs(nb.first - k.first) > half || std::abs(nb.second - k.second) > half) continue;
          auto it = cells.find(nb);
          if (it == cells.end() || detail::angleDeg(it->second.normal, seed.normal) > opts.growing_angle_deg) continue;
          bool coplanar = false, common = false;
          for (const auto& a : seed.planes)
            for (const auto& b : it->second.planes)
              if (a.strip == b.strip) {
                common = true;
                coplanar |= std::abs(a.fit.normal.dot(b.fit.centroid - a.fit.centroid)) < std::max(0.1, 3 * opts.max_roughness_m);
              }
          if (!common || !coplanar) continue;
          used.insert(nb);
          reg.members.push_back(nb);
          queue.push_back(nb);
        }
    }
    regions.push_back(reg);
  }
  // Normal-space selection: round robin over orientation bins, largest regions first.
  std::map<int, std::vector<const Region*>> bins;
  for (const Region& r : regions) bins[normalBin(r.normal)].push_back(&r);
  for (auto& [b, list] : bins)
    std::stable_sort(list.begin(), list.end(), [](const Region* a, const Region* c) { return a->members.size() > c->members.size(); });
  std::vector<PlanarPatch> out;
  for (std::size_t round = 0; static_cast<int>(out.size()) < opts.max_patches; ++round) {
    bool any = false;
    for (auto& [b, list] : bins) {
      if (round >= list.size() || static_cast<int>(out.size()) >= opts.max_patches) continue;
      any = true;
      const Region& r = *list[round];
      std::int64_t x0 = r.members[0].first, x1 = x0, y0 = r.members[0].second, y1 = y0;
      for (const auto& m : r.members) {
        x0 = std::min(x0, m.first);
        x1 = std::max(x1, m.first);
        y0 = std::min(y0, m.second);
        y1 = std::max(y1, m.second);
      }
      // The cells' box, less a margin: edge cells may reach the next surface on a strip that is
      // still misaligned.
      const double mx = std::min(opts.edge_margin_m, 0.25 * static_cast<double>(x1 - x0 + 1) * cell);
      const double my = std::min(opts.edge_margin_m, 0.25 * static_cast<double>(y1 - y0 + 1) * cell);
      PlanarPatch p;
      p.region = {"auto_" + std::to_string(out.size() + 1), static_cast<double>(x0) * cell + mx, static_cast<double>(y0) * cell + my,
                  static_cast<double>(x1 + 1) * cell - mx, static_cast<double>(y1 + 1) * cell - my};
      p.normal = r.normal;
      p.cells = static_cast<int>(r.members.size());
      out.push_back(p);
    }
    if (!any) break;
  }
  return out;
}

}  // namespace

std::vector<PlanarPatch> findPlanarPatches(const CalibrationData& data, const PlaneOptions& opts) {
  std::string why;
  if (!opts.IsValid(&why)) throw InvalidInput("plane options: " + why);
  return findPatchesAt(data, opts, patchCell(data, opts), nullptr);
}

PlaneObservations::~PlaneObservations() = default;

PlaneObservations::PlaneObservations(const CalibrationData& data, const PlaneOptions& options)
    : options_(options), used_(data.mounting_used) {
  std::string why;
  if (!options_.IsValid(&why)) throw InvalidInput("plane options: " + why);
  section_.automatic = options_.automatic;
  selected_at_ = found_at_ = used_.toArray();
  if (options_.automatic) {
    data_ = &data;
    cell_m_ = patchCell(data, options_);
    // Probes of how far the strips move as the mounting changes: evenly over each strip.
    for (const StripData& st : data.strips) {
      const std::size_t n = st.r_s.size(), step = std::max<std::size_t>(1, n / 256);
      std::size_t cursor = 0;
      for (std::size_t i = 0; i < n; i += step) probes_.push_back({data.pose(st, i, &cursor).R_mb, st.r_s[i]});
    }
  }
  if (options_.estimatesLaserIntrinsics()) {
    laser_ = std::make_unique<detail::LaserIntrinsicsBlock>();
    laser_->setUp(data, "planes", options_.laserPrior());
  }
  strip_order_.clear();
  for (const StripData& s : data.strips) strip_order_.push_back(s.id);
  if (options_.automatic) {
    search(nullptr);
  } else {
    collectCandidates(data, data.plane_regions, nullptr);
    select(selected_at_);
  }
}

void PlaneObservations::search(const std::array<double, 6>* m) {
  // The option's roughness bound, doubled (at most kRoughnessGrowths times) while fewer than
  // kFewPatches patches are used — found and seen by two strips that agree on them at m.
  constexpr int kFewPatches = 3, kRoughnessGrowths = 2;
  PlaneOptions o = options_;
  const std::array<double, 6> at = m ? *m : used_.toArray();
  int growths = 0;
  for (;; ++growths) {
    std::vector<PlaneRegion> regions;
    for (const PlanarPatch& p : findPatchesAt(*data_, o, cell_m_, m)) regions.push_back(p.region);
    collectCandidates(*data_, regions, m);
    if (!m) section_.sigma_m = 0.0;  // pooled from the search that is kept (select)
    select(at);
    if (growths == kRoughnessGrowths || static_cast<int>(patches_.size()) >= kFewPatches) break;
    o.max_roughness_m *= 2;
  }
  section_.roughness_bound_m = o.max_roughness_m;
  section_.roughness_growths = growths;
  section_.search_bounds_m.push_back(o.max_roughness_m);
  section_.search_patches.push_back(static_cast<int>(patches_.size()));
  found_at_ = at;
  solves_since_search_ = trim_rounds_ = 0;
}

void PlaneObservations::collectCandidates(const CalibrationData& data, const std::vector<PlaneRegion>& regions,
                                          const std::array<double, 6>* m) {
  regions_.clear();
  std::vector<StripCloud> clouds = makeClouds(data, 4.0, m);
  // Candidates: every strip point within the region (at m) grown by the search margin (points
  // move in and out of a region as the mounting changes; select() picks the inliers each round).
  const double g = options_.search_margin_m;
  for (const PlaneRegion& reg : regions) {
    Region region;
    region.box = reg;
    for (const StripCloud& c : clouds) {
      for (std::uint32_t i : c.grid->box(c.at(), reg.xmin - g, reg.ymin - g, reg.xmax + g, reg.ymax + g)) {
        Candidate cand;
        cand.strip_id = c.strip->id;
        cand.x0 = c.x0[i];
        cand.r_s = c.strip->r_s[i];
        cand.R_mb = data.pose(*c.strip, i).R_mb;
        cand.time_s = c.strip->time_s[i];
        if (laser_) cand.laser = c.strip->laser[i];
        region.candidates.push_back(cand);
      }
    }
    regions_.push_back(std::move(region));
  }
}

double PlaneObservations::movedSinceFound(const std::array<double, 6>& m) const {
  const detail::MountingMotion now(used_.R_nom, used_.R_bs(), used_.a_b, m.data());
  const detail::MountingMotion then(used_.R_nom, used_.R_bs(), used_.a_b, found_at_.data());
  double moved = 0.0;
  for (const Probe& p : probes_) moved = std::max(moved, (now.displacement(p.R_mb, p.r_s) - then.displacement(p.R_mb, p.r_s)).norm());
  return moved;
}

void PlaneObservations::select(const std::array<double, 6>& m) {
  patches_.clear();
  section_.rejected.clear();
  const detail::MountingMotion motion(used_.R_nom, used_.R_bs(), used_.a_b, m.data());
  std::vector<double> fit_sigmas;
  for (const Region& region : regions_) {
    const PlaneRegion& reg = region.box;
    // The candidates inside the region at mounting m, per strip.
    std::map<std::string, std::vector<std::uint32_t>> by_strip;
    std::vector<Vec3> X(region.candidates.size());
    for (std::size_t k = 0; k < region.candidates.size(); ++k) {
      const Candidate& c = region.candidates[k];
      X[k] = c.x0 + motion.displacement(c.R_mb, c.r_s);
      if (!c.off_surface && X[k].x() >= reg.xmin && X[k].x() <= reg.xmax && X[k].y() >= reg.ymin && X[k].y() <= reg.ymax) {
        by_strip[c.strip_id].push_back(static_cast<std::uint32_t>(k));
      }
    }
    struct Seen {
      std::string strip;
      std::vector<std::uint32_t> inliers;
      detail::PlaneFit fit;
    };
    std::vector<Seen> seen;
    for (const std::string& sid : strip_order_) {
      auto it = by_strip.find(sid);
      if (it == by_strip.end()) continue;  // the strip does not cover the region
      const std::vector<std::uint32_t>& idx = it->second;
      if (static_cast<int>(idx.size()) < options_.min_points_per_strip) {
        section_.rejected.push_back({reg.id, sid,
                                     "too few points: " + std::to_string(idx.size()) + " in the region (need " +
                                         std::to_string(options_.min_points_per_strip) + ")"});
        continue;
      }
      detail::PlaneFit fit;
      const auto seed = static_cast<std::uint32_t>(std::hash<std::string>{}(reg.id + "/" + sid));
      std::vector<std::uint32_t> in = ransacPlane(X, idx, options_.ransac_threshold_m, options_.ransac_iterations, seed, &fit);
      if (static_cast<int>(in.size()) < options_.min_points_per_strip) {
        section_.rejected.push_back({reg.id, sid,
                                     "no plane: " + std::to_string(in.size()) + " of " + std::to_string(idx.size()) + " points within " +
                                         std::to_string(options_.ransac_threshold_m).substr(0, 5) + " m of one plane"});
        continue;
      }
      seen.push_back({sid, std::move(in), fit});
    }
    if (seen.empty()) {
      section_.rejected.push_back({reg.id, "", "no strip has points in the region"});
      continue;
    }
    // The surface most strips agree on (the best-supported strip's plane as reference).
    std::stable_sort(seen.begin(), seen.end(), [](const Seen& a, const Seen& b) { return a.inliers.size() > b.inliers.size(); });
    const Vec3 n_ref = seen[0].fit.normal;
    std::vector<Seen> agree;
    const Vec3 c_ref = seen[0].fit.centroid;
    for (auto& sn : seen) {
      const double apart = std::abs(n_ref.dot(sn.fit.centroid - c_ref));
      if (detail::angleDeg(sn.fit.normal, n_ref) > options_.max_normal_angle_deg) {
        char buf[160];
        std::snprintf(buf, sizeof buf, "another surface: its plane differs by %.1f° from the patch's",
                      detail::angleDeg(sn.fit.normal, n_ref));
        section_.rejected.push_back({reg.id, sn.strip, buf});
      } else if (apart > options_.max_plane_offset_m) {
        char buf[160];
        std::snprintf(buf, sizeof buf, "another surface: parallel to the patch's plane but %.2f m from it", apart);
        section_.rejected.push_back({reg.id, sn.strip, buf});
      } else {
        agree.push_back(std::move(sn));
      }
    }
    if (agree.size() < 2) {
      section_.rejected.push_back({reg.id, "", "seen by fewer than two strips"});
      continue;
    }
    Patch patch;
    patch.id = reg.id;
    patch.region = static_cast<std::size_t>(&region - regions_.data());
    patch.strips = static_cast<int>(agree.size());
    std::vector<Vec3> now;  // positions at m
    for (const Seen& sn : agree) {
      fit_sigmas.push_back(sn.fit.sigma_m);
      // Evenly thinned inliers, in time order — per laser when per-laser offsets are estimated,
      // so that every laser the strip sees the patch with keeps its points.
      std::map<int, std::vector<std::uint32_t>> by_laser;
      for (std::uint32_t i : sn.inliers) by_laser[region.candidates[i].laser].push_back(i);
      for (auto& [laser, in] : by_laser) {
        std::sort(in.begin(), in.end());
        const std::size_t keep = std::min<std::size_t>(in.size(), static_cast<std::size_t>(options_.max_points_per_strip));
        for (std::size_t k = 0; k < keep; ++k) {
          const std::uint32_t i = in[k * in.size() / keep];
          const Candidate& c = region.candidates[i];
          patch.points.push_back({c.strip_id, c.x0 /* made relative below */, c.R_mb, c.r_s, c.time_s, c.laser, i});
          now.push_back(X[i]);
        }
      }
    }
    Vec3 centre = Vec3::Zero();
    for (const PatchPoint& pp : patch.points) centre += pp.x0_rel;
    centre /= static_cast<double>(patch.points.size());
    for (PatchPoint& pp : patch.points) pp.x0_rel -= centre;
    patch.centre_m = centre;
    // The plane's starting value: the points at m, relative to the centre.
    const detail::PlaneFit all = detail::fitPlane(now.size(), [&](std::size_t k) { return Vec3(now[k] - centre); });
    patch.plane0 = Eigen::Vector4d(all.normal.x(), all.normal.y(), all.normal.z(), all.normal.dot(all.centroid));
    patches_.push_back(std::move(patch));
  }
  // σ of a point-to-plane distance: stated, or pooled from the strips' own plane fits (fixed
  // at the first selection, so that every round weighs alike).
  if (!(section_.sigma_m > 0)) section_.sigma_m = options_.sigma_m > 0 ? options_.sigma_m : pooledFitSigma(&fit_sigmas);
  section_.patches_used = static_cast<int>(patches_.size());
  section_.points_off_surface = 0;
  for (const Region& region : regions_)
    for (const Candidate& c : region.candidates) section_.points_off_surface += c.off_surface;
  section_.points_used = 0;
  for (const Patch& p : patches_) section_.points_used += static_cast<int>(p.points.size());
}

ObservationSource::StartSigma PlaneObservations::sigmaFromStart() const {
  if (options_.sigma_m > 0) return {};
  return {section_.sigma_m, kPooledSigmaFloorM};
}

void PlaneObservations::addBlocks(const std::array<double, 6>& mounting, AdjustmentProblem* problem) {
  // Automatic patches are found again where the strips now lie once some point has moved beyond
  // the search margin (the candidates' reach; at least half a plan cell) since the last search:
  // from a mounting far from the truth the first search sees the strips apart and keeps level
  // patches only (a sloped roof's faces do not meet), which see the horizontal lever arm, pitch
  // and heading only through the aircraft's attitude changes (the crossing field flown with a
  // boresight of 0.25°, −0.30°, 0.40°: 118 level patches, the lever arm 5 m off at 50σ).
  //
  // And once, where the first solve has moved the strips by more than the cells' roughness bound:
  // a strip's own looks at a cell disagree by the misalignment (a spinning multi-beam sensor sees
  // a cell from many lasers and directions), so cells that were rough at the a-priori mounting
  // are planar at the solved one (the HDL-32E survey flown 1.5° off: 3 patches used there, 24
  // at the first solution).
  refound_ = false;
  const double moved = data_ ? movedSinceFound(mounting) : 0.0;
  const bool at_first_solution = data_ && !searched_at_solution_ && moved > section_.roughness_bound_m;
  if (data_ && section_.patch_searches < kMaxPatchSearches &&
      (at_first_solution || moved > std::max(options_.search_margin_m, 0.5 * cell_m_))) {
    searched_at_solution_ = true;
    search(&mounting);
    refound_ = true;
    ++section_.patch_searches;
  } else if (mounting != selected_at_) {
    select(mounting);
  }
  selected_at_ = mounting;
  const Mat3 R_bs_used = used_.R_bs();
  const double inv_sigma = 1.0 / section_.sigma_m;
  ceres::NumericDiffOptions nd;
  nd.relative_step_size = problem->numericDiffRelativeStep();
  blocks_.assign(patches_.size(), {});
  double* lasers = nullptr;
  if (laser_) {
    std::vector<bool> seen;
    for (int n : laserPoints()) seen.push_back(n > 0);
    lasers = laser_->add(problem, seen);
  }
  for (std::size_t q = 0; q < patches_.size(); ++q) {
    Patch& patch = patches_[q];
    // One plane per patch: unit normal on the sphere × offset (a nuisance block).
    auto* manifold = new ceres::ProductManifold<ceres::SphereManifold<3>, ceres::EuclideanManifold<1>>();
    patch.block = problem->addNuisanceBlock(4, patch.plane0.data(), manifold);
    for (const PatchPoint& pp : patch.points) {
      if (lasers) {
        auto* cost =
            new detail::OneLaserOfBlock(new ceres::NumericDiffCostFunction<PlaneLaserPointResidual, ceres::CENTRAL, 1, 6, 4, 3, 5>(
                                            new PlaneLaserPointResidual{&pp, &used_, R_bs_used, inv_sigma}, ceres::TAKE_OWNERSHIP, 1, nd),
                                        laser_->layout(), pp.laser);
        blocks_[q].push_back(problem->addResidualBlock(cost, section_.sigma_m,
                                                       {problem->mounting(), patch.block, problem->stripOffset(pp.strip_id), lasers}));
      } else {
        auto* cost = new ceres::NumericDiffCostFunction<PlanePointResidual, ceres::CENTRAL, 1, 6, 4, 3>(
            new PlanePointResidual{&pp, &used_, R_bs_used, inv_sigma}, ceres::TAKE_OWNERSHIP, 1, nd);
        blocks_[q].push_back(
            problem->addResidualBlock(cost, section_.sigma_m, {problem->mounting(), patch.block, problem->stripOffset(pp.strip_id)}));
      }
      problem->setEpoch(blocks_[q].back(), pp.strip_id, pp.time_s, pp.R_mb * (R_bs_used * pp.r_s + used_.a_b));
    }
  }
}

std::vector<int> PlaneObservations::laserPoints() const {
  std::vector<int> points(static_cast<std::size_t>(laser_->lasers()), 0);
  for (const Patch& patch : patches_)
    for (const PatchPoint& pp : patch.points) ++points[static_cast<std::size_t>(pp.laser)];
  return points;
}

void PlaneObservations::solved(const AdjustmentProblem& problem) {
  if (laser_) laser_->solved();
  // Points off the patch's surface: a strip's RANSAC plane keeps every point within
  // ransac_threshold_m (10 cm), and where a patch meets a wall or another roof face a few points
  // of that surface are in it (noise-free on the HDL-32E field: three points 2–6 cm off in one
  // patch of 24, which then fits to 2 mm RMS against 0.01 mm, and the boresight ends 2e-4° off).
  // From the second solve on the patches as selected, a point whose distance exceeds kOffSurface
  // times its patch's robust scale (1.4826 × the median |distance|; a Gaussian's share beyond is
  // 6e-7), twice the σ of a distance and a tenth of ransac_threshold_m (what RANSAC cannot tell
  // apart is not judged here; noise-free, a laser's points not yet fitted lie 0.1–0.3 mm off) is
  // not selected again — unless that would take a fifth of the patch (then the patch is no longer
  // a few points on another surface: finish() flags it). At most kTrimRounds times, each followed
  // by another solve (settled()).
  constexpr double kOffSurface = 5.0;
  constexpr int kTrimRounds = 2;
  trimmed_ = false;
  if (solves_since_search_++ == 0 || trim_rounds_ >= kTrimRounds) return;
  int newly = 0;
  for (std::size_t q = 0; q < patches_.size(); ++q) {
    const Patch& patch = patches_[q];
    const std::vector<int>& blocks = blocks_[q];
    if (blocks.size() != patch.points.size() || blocks.size() < 10) continue;
    std::vector<double> d(blocks.size());
    for (std::size_t i = 0; i < blocks.size(); ++i) d[i] = std::abs(problem.residual(blocks[i])[0]) * section_.sigma_m;
    const double cut = std::max({kOffSurface * robustScaleFromNorms(d, 1), 2.0 * section_.sigma_m, 0.1 * options_.ransac_threshold_m});
    std::vector<std::size_t> off;
    for (std::size_t i = 0; i < d.size(); ++i)
      if (d[i] > cut) off.push_back(i);
    if (off.empty() || off.size() * 5 > d.size()) continue;
    for (std::size_t i : off) regions_[patch.region].candidates[patch.points[i].candidate].off_surface = true;
    newly += static_cast<int>(off.size());
  }
  if (newly > 0) trimmed_ = true, ++trim_rounds_;
}

void PlaneObservations::finish(const std::array<double, 6>& /*m0*/, const std::array<double, 6>& /*m*/, const AdjustmentProblem& problem,
                               const AnalysisOptions& analysis) {
  section_.patches.clear();
  double ss_before = 0, ss_after = 0;
  int n_all = 0;
  std::vector<double> rms;
  for (std::size_t q = 0; q < patches_.size(); ++q) {
    const Patch& patch = patches_[q];
    PatchResidual pr;
    pr.patch_id = patch.id;
    pr.centre_m = patch.centre_m;
    Vec3 n(patch.block[0], patch.block[1], patch.block[2]);
    n.normalize();
    pr.normal = n.z() < 0 ? Vec3(-n) : n;
    pr.points = static_cast<int>(patch.points.size());
    pr.strips = patch.strips;
    // Before: every strip's points at M_used about their one best-fit plane (seed eq. 13).
    const detail::PlaneFit before = detail::fitPlane(patch.points.size(), [&](std::size_t k) { return patch.points[k].x0_rel; });
    double sb = 0;
    for (const PatchPoint& pp : patch.points) sb += std::pow(before.normal.dot(pp.x0_rel - before.centroid), 2);
    ss_before += sb;
    pr.rms_before_m = std::sqrt(sb / std::max<double>(1.0, static_cast<double>(patch.points.size()) - 3.0));
    double sa = 0;
    for (int b : blocks_[q]) {
      const double d = problem.residual(b)[0] * section_.sigma_m;
      sa += d * d;
    }
    ss_after += sa;
    n_all += pr.points;
    pr.rms_after_m = std::sqrt(sa / std::max(1, pr.points));
    rms.push_back(pr.rms_after_m);
    section_.patches.push_back(pr);
  }
  if (n_all > 0) {
    section_.rms_before_m = std::sqrt(ss_before / n_all);
    section_.rms_after_m = std::sqrt(ss_after / n_all);
  }
  const double scale = robustScaleFromNorms(rms, 1);
  for (PatchResidual& pr : section_.patches)
    pr.outlier = pr.rms_after_m > std::max(analysis.outlier_factor * scale, 3.0 * section_.sigma_m);
  if (laser_) section_.laser_intrinsics = laser_->finish(problem, laserPoints());
}

}  // namespace mountcal
