#include "mountcal/report/swath_qc.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <map>
#include <sstream>
#include <unordered_map>

#include <nlohmann/json.hpp>

#include "geometry/point_geometry.hpp"
#include "mountcal/core/error.hpp"
#include "mountcal/core/rotation.hpp"
#include "mountcal/report/evaluation.hpp"
#include "mountcal/report/svg_plot.hpp"
#include "report/html_text.hpp"

namespace mountcal {

std::vector<QualityLevel> usgsQualityLevels() {
  // QL1 and QL2 share one absolute class (RMSE_z 10 cm) and so one relative limit.
  const std::string src = "USGS Lidar Base Specification (TM 11-B4 v1.2/v1.3), relative vertical accuracy table";
  return {{"USGS QL0", 0.03, 0.04, 0.08, src},
          {"USGS QL1", 0.06, 0.08, 0.16, src},
          {"USGS QL2", 0.06, 0.08, 0.16, src},
          {"USGS QL3", 0.12, 0.16, 0.32, src}};
}

QualityLevel asprsVerticalClass(double rmse_v_m) {
  char name[64];
  std::snprintf(name, sizeof name, "ASPRS %.3g-cm", 100 * rmse_v_m);
  return {name, 0.6 * rmse_v_m, 0.8 * rmse_v_m, 1.6 * rmse_v_m,
          "ASPRS Positional Accuracy Standards (Ed. 1 2014, Ed. 2 2023), lidar relative accuracy: 0.6 / 0.8 / 1.6 x RMSE_V"};
}

std::vector<QualityLevel> asprsVerticalClasses() {
  std::vector<QualityLevel> out;
  for (double cm : {1.0, 2.5, 5.0, 10.0, 15.0, 20.0, 33.3}) out.push_back(asprsVerticalClass(cm / 100));
  return out;
}

std::vector<QualityLevel> defaultQualityLevels() {
  std::vector<QualityLevel> out = usgsQualityLevels();
  for (QualityLevel& l : asprsVerticalClasses()) out.push_back(std::move(l));
  return out;
}

double SwathQcOptions::cellSizeFor(double spacing_m) const {
  const double want = std::max(spacing_m, 1e-3) * std::sqrt(2.0 * std::max(min_points, 3));
  double step = std::pow(10.0, std::floor(std::log10(want)));
  for (double f : {1.0, 2.0, 5.0, 10.0})
    if (f * step >= want) return f * step;
  return 10 * step;
}

bool SwathQcOptions::IsValid(std::string* why) const {
  auto fail = [&](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (!(cell_size_m >= 0 && cell_size_m <= 1000)) return fail("cell_size_m must be in [0, 1000] m (0: from the point spacing)");
  if (min_points < 3 || min_points > 100000) return fail("min_points must be in [3, 100000]");
  if (!(max_slope_deg > 0 && max_slope_deg < 90)) return fail("max_slope_deg must be in (0, 90)");
  if (!(max_roughness_m > 0 && max_roughness_m <= 10)) return fail("max_roughness_m must be in (0, 10] m");
  if (!(max_plane_angle_deg > 0 && max_plane_angle_deg <= 90)) return fail("max_plane_angle_deg must be in (0, 90] deg");
  if (!(min_edge_turn_deg >= 5 && min_edge_turn_deg <= 120)) return fail("min_edge_turn_deg must be in [5, 120] deg");
  if (!(plane_cell_m >= 0 && plane_cell_m <= 1000)) return fail("plane_cell_m must be in [0, 1000] m (0: half the dZ cell)");
  if (!(max_plane_slope_deg >= max_slope_deg && max_plane_slope_deg <= 75))
    return fail("max_plane_slope_deg must be in [max_slope_deg, 75] deg (a cell's plane is a height field z(x, y))");
  if (!(intraswath_cell_m >= 0 && intraswath_cell_m <= 100)) return fail("intraswath_cell_m must be in [0, 100] m (0: from the spacing)");
  for (double t : thresholds_m)
    if (!(t > 0 && t < 1000)) return fail("thresholds_m must be positive lengths below 1000 m");
  return true;
}

DzStats dzStats(const std::vector<double>& dz, const std::vector<double>& thresholds_m) {
  DzStats s;
  s.cells = dz.size();
  s.share_over.assign(thresholds_m.size(), NAN);
  if (dz.empty()) return s;
  double ss = 0, sum = 0, mx = 0;
  std::vector<std::size_t> over(thresholds_m.size(), 0);
  for (double d : dz) {
    ss += d * d;
    sum += d;
    mx = std::max(mx, std::abs(d));
    for (std::size_t k = 0; k < thresholds_m.size(); ++k) over[k] += std::abs(d) > thresholds_m[k];
  }
  const double n = static_cast<double>(dz.size());
  s.rmsdz_m = std::sqrt(ss / n);
  s.mean_dz_m = sum / n;
  s.max_abs_dz_m = mx;
  for (std::size_t k = 0; k < over.size(); ++k) s.share_over[k] = static_cast<double>(over[k]) / n;
  return s;
}

namespace {

/// Sums of one strip's points in one cell, about the cell's centre (x, y) and its first point's
/// height (z), for the least-squares plane z = a + b x + c y.
struct CellSums {
  double n = 0, x = 0, y = 0, z = 0, xx = 0, xy = 0, yy = 0, xz = 0, yz = 0, zz = 0, z0 = NAN;
  void add(double dx, double dy, double zabs) {
    if (std::isnan(z0)) z0 = zabs;
    const double dz = zabs - z0;
    n += 1, x += dx, y += dy, z += dz;
    xx += dx * dx, xy += dx * dy, yy += dy * dy, xz += dx * dz, yz += dy * dz, zz += dz * dz;
  }
};

/// A strip's plane in one cell: height at the centre, slope, roughness, the points' centroid
/// (about the centre); smooth by the gates, planar when only the slope gate fails (up to
/// max_plane_slope_deg: roofs).
struct CellPlane {
  double z = NAN, b = 0, c = 0, roughness = NAN;
  double mx = 0, my = 0, mz = NAN;  ///< centroid: x, y about the cell's centre, z absolute
  double tilt_sigma = NAN;          ///< σ of the plane's tilt from its points: roughness / (√n · spread) [rad]
  bool smooth = false, planar = false;
  Vec3 normal() const { return Vec3(-b, -c, 1.0); }  ///< upwards, not unit
  /// Signed distance of a point (x, y about the centre, z) from the plane, along its normal.
  double distance(double x, double y, double zp) const { return (zp - (z + b * x + c * y)) / normal().norm(); }
};

using CellKey = std::int64_t;
using CellIndex = std::pair<std::int64_t, std::int64_t>;
CellKey key(std::int64_t ix, std::int64_t iy) {
  return static_cast<CellKey>((static_cast<std::uint64_t>(ix) << 32) ^ (static_cast<std::uint64_t>(iy) & 0xffffffffu));
}

struct Grid {
  double cell = 1, x0 = 0, y0 = 0;  ///< cell (i, j) spans [x0 + i·cell, …) × [y0 + j·cell, …)
  std::int64_t ix(double x) const { return static_cast<std::int64_t>(std::floor((x - x0) / cell)); }
  std::int64_t iy(double y) const { return static_cast<std::int64_t>(std::floor((y - y0) / cell)); }
  double cx(std::int64_t i) const { return x0 + (static_cast<double>(i) + 0.5) * cell; }
  double cy(std::int64_t j) const { return y0 + (static_cast<double>(j) + 0.5) * cell; }
};

CellPlane fitPlane(const CellSums& s, double cell, const SwathQcOptions& o) {
  CellPlane p;
  if (s.n < o.min_points) return p;
  Eigen::Matrix3d A;
  A << s.n, s.x, s.y, s.x, s.xx, s.xy, s.y, s.xy, s.yy;
  const Eigen::Vector3d r(s.z, s.xz, s.yz);
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(A);
  if (ldlt.info() != Eigen::Success || std::abs(A.determinant()) < 1e-12 * std::pow(s.n, 3) * std::pow(s.xx / s.n + s.yy / s.n + 1e-12, 2))
    return p;  // points on a line: no plane
  const Eigen::Vector3d beta = ldlt.solve(r);
  const double ssr = std::max(s.zz - beta.dot(r), 0.0);
  p.z = s.z0 + beta(0);
  p.b = beta(1);
  p.c = beta(2);
  p.roughness = std::sqrt(ssr / std::max(s.n - 3, 1.0));
  const double slope = std::atan(std::hypot(p.b, p.c));
  // The points must cover the cell (a uniform spread has σ = cell/√12 ≈ 0.29 cell per axis): a
  // strip that sees only part of it — the rest hidden behind a building — measures another surface.
  const double sx = std::sqrt(std::max(s.xx / s.n - (s.x / s.n) * (s.x / s.n), 0.0)),
               sy = std::sqrt(std::max(s.yy / s.n - (s.y / s.n) * (s.y / s.n), 0.0));
  const bool covered = sx >= 0.2 * cell && sy >= 0.2 * cell;
  p.mx = s.x / s.n, p.my = s.y / s.n, p.mz = s.z0 + s.z / s.n;
  p.tilt_sigma = p.roughness / (std::sqrt(s.n) * std::max(std::min(sx, sy), 1e-9));
  p.smooth = covered && slope <= deg2rad(o.max_slope_deg) && p.roughness <= o.max_roughness_m;
  // The roughness is a vertical RMS: on a slope the points' distance to the plane is cos(slope) of it.
  p.planar = covered && !p.smooth && slope <= deg2rad(o.max_plane_slope_deg) && p.roughness * std::cos(slope) <= o.max_roughness_m;
  return p;
}

using StripCells = std::unordered_map<CellKey, std::pair<CellIndex, CellPlane>>;
/// Which points of a strip lie in each cell (indices into the strip).
using CellMembers = std::unordered_map<CellKey, std::vector<std::uint32_t>>;

/// Every cell's plane of one strip; with `members`, also which of its points each cell holds
/// (in the same pass over the points).
StripCells stripCells(const std::vector<Vec3>& x, const Grid& g, const SwathQcOptions& o, CellMembers* members = nullptr) {
  std::unordered_map<CellKey, std::pair<CellIndex, CellSums>> sums;
  for (std::size_t n = 0; n < x.size(); ++n) {
    const Vec3& p = x[n];
    const std::int64_t i = g.ix(p.x()), j = g.iy(p.y());
    const CellKey k = key(i, j);
    auto& e = sums[k];
    e.first = {i, j};
    e.second.add(p.x() - g.cx(i), p.y() - g.cy(j), p.z());
    if (members) (*members)[k].push_back(static_cast<std::uint32_t>(n));
  }
  StripCells out;
  out.reserve(sums.size());
  for (const auto& [k, e] : sums) out.emplace(k, std::make_pair(e.first, fitPlane(e.second, g.cell, o)));
  return out;
}

/// The strip's intraswath precision over its smooth cells (a second pass over its points): the
/// RMS of the residuals to the cells' planes, and the within-range of those residuals in
/// sub-cells of `sub` m (≥ 2 points), at their 95th percentile.
StripQc intraswath(const std::string& id, const std::vector<Vec3>& x, const StripCells& cells, const Grid& g, double sub) {
  StripQc q;
  q.id = id;
  struct Range {
    double lo = 1e300, hi = -1e300;
    int count = 0;
  };
  std::unordered_map<CellKey, Range> range;  // sub-cell → residuals' extremes
  double ss = 0, n = 0;
  for (const Vec3& p : x) {
    const std::int64_t i = g.ix(p.x()), j = g.iy(p.y());
    const auto it = cells.find(key(i, j));
    if (it == cells.end() || !it->second.second.smooth) continue;
    const CellPlane& c = it->second.second;
    const double r = p.z() - (c.z + c.b * (p.x() - g.cx(i)) + c.c * (p.y() - g.cy(j)));
    ss += r * r;
    n += 1;
    Range& e = range[key(static_cast<std::int64_t>(std::floor(p.x() / sub)), static_cast<std::int64_t>(std::floor(p.y() / sub)))];
    e.lo = std::min(e.lo, r), e.hi = std::max(e.hi, r), ++e.count;
  }
  for (const auto& [k, e] : cells) q.smooth_cells += e.second.smooth;  // a smooth cell holds points
  if (n > 0) q.intraswath_precision_m = std::sqrt(ss / n);
  std::vector<double> spans;
  for (const auto& [k, e] : range)
    if (e.count >= 2) spans.push_back(e.hi - e.lo);
  if (!spans.empty()) {
    std::sort(spans.begin(), spans.end());
    q.intraswath_max_m =
        spans[std::min(spans.size() - 1, static_cast<std::size_t>(std::ceil(0.95 * static_cast<double>(spans.size()))) - 1)];
  }
  return q;
}

/// Point to tangent plane of a pair on the cells both strips occupy (query: the smaller strip):
/// the work follows the overlap, not the strips' whole size.
DiscrepancyStats overlapPointToPlane(const std::vector<Vec3>& xq, const CellMembers& mq, const std::vector<Vec3>& xr, const CellMembers& mr,
                                     const DiscrepancyOptions& d) {
  std::vector<Vec3> q, r;
  for (const auto& [k, idx] : mq) {
    const auto it = mr.find(k);
    if (it == mr.end()) continue;
    for (std::uint32_t i : idx) q.push_back(xq[i]);
    for (std::uint32_t i : it->second) r.push_back(xr[i]);
  }
  if (q.empty() || r.size() < 3) return DiscrepancyStats{};
  return pointToPlaneDiscrepancy(q, r, d);
}

/// A pair's common cells: dZ = z_A − z_B at the cells both strips find smooth (A the earlier
/// strip), and at the cells both find planar and sloped (roofs) the distance of B's centroid from
/// A's plane along its normal — the ASPRS 2018 roof-plane measure at cell scale.
struct PairCellValues {
  std::vector<std::pair<CellIndex, double>> dz;
  std::vector<double> plane_distance, edge_distance;
};
using PairCells = std::map<std::pair<std::size_t, std::size_t>, PairCellValues>;

/// Every strip pair's common cells, dZ at the smooth ones or (`planes`) the distances at the
/// sloped planar ones: one pass over the cells, so the work grows with the cells and the
/// overlaps, not with pairs × cells.
PairCells pairCells(const std::vector<StripCells>& strips, bool planes, double max_plane_angle_deg = 90) {
  const double cos_conjugate = std::cos(deg2rad(max_plane_angle_deg));
  std::unordered_map<CellKey, std::vector<std::pair<std::size_t, const std::pair<CellIndex, CellPlane>*>>> at;
  for (std::size_t s = 0; s < strips.size(); ++s)
    for (const auto& [k, e] : strips[s])
      if (planes ? e.second.planar : e.second.smooth) at[k].push_back({s, &e});
  PairCells out;
  for (const auto& [k, list] : at)
    for (std::size_t u = 0; u < list.size(); ++u)
      for (std::size_t v = u + 1; v < list.size(); ++v) {
        const bool ordered = list[u].first < list[v].first;
        const auto& [sa, ea] = ordered ? list[u] : list[v];
        const auto& [sb, eb] = ordered ? list[v] : list[u];
        const CellPlane &pa = ea->second, &pb = eb->second;
        PairCellValues& values = out[{sa, sb}];
        if (planes) {
          // Conjugate planes only: two strips that see different surfaces in one cell (a car's
          // side and the ground behind it) are not a misalignment.
          if (pa.normal().normalized().dot(pb.normal().normalized()) >= cos_conjugate)
            values.plane_distance.push_back(-pa.distance(pb.mx, pb.my, pb.mz));
        } else
          values.dz.push_back({ea->first, pa.z - pb.z});
      }
  for (auto& [pair, values] : out) {  // independent of the hash order
    std::sort(values.dz.begin(), values.dz.end());
    std::sort(values.plane_distance.begin(), values.plane_distance.end());
  }
  return out;
}

/// A strip's plane in a cell as n·x = d in absolute coordinates, n = (−b, −c, 1).
struct AbsPlane {
  Vec3 n;
  double d;
};
AbsPlane absPlane(const CellPlane& p, const Grid& g, const CellIndex& c) {
  return {p.normal(), p.normal().dot(Vec3(g.cx(c.first), g.cy(c.second), p.z))};
}

/// The line where two planes meet, as the point on it nearest `m` and its direction; false when
/// the planes are (nearly) parallel.
bool meetLine(const AbsPlane& p, const AbsPlane& q, const Vec3& m, Vec3* x, Vec3* u) {
  *u = p.n.cross(q.n);
  if (u->norm() < 1e-9 * p.n.norm() * q.n.norm()) return false;
  u->normalize();
  // x = m + λ₁ n₁ + λ₂ n₂ on both planes (the nearest point to m: x − m ⟂ u).
  Eigen::Matrix2d A;
  A << p.n.dot(p.n), p.n.dot(q.n), q.n.dot(p.n), q.n.dot(q.n);
  const Eigen::Vector2d rhs(p.d - p.n.dot(m), q.d - q.n.dot(m));
  const Eigen::Vector2d l = A.ldlt().solve(rhs);
  *x = m + l(0) * p.n + l(1) * q.n;
  return true;
}

/// The ASPRS 2018 roof-edge measure at cell scale: where a strip's planar cells within two cells
/// of each other turn by more than `min_turn_deg` (two faces of a roof), the line where their
/// planes meet — a ridge or valley — lying between them; in the other strip the same two cells'
/// planes give the conjugate line; its distance from the first, across the first's direction.
/// Per pair (A the earlier strip), one value per pair of cells.
std::map<std::pair<std::size_t, std::size_t>, std::vector<double>> roofEdges(const std::vector<StripCells>& strips, const Grid& g,
                                                                             double min_turn_deg) {
  const double cos_turn = std::cos(deg2rad(min_turn_deg));
  // A face's plane must be well determined: a normal uncertain by degrees (a few noisy points on
  // a small cell) puts the meeting line anywhere.
  const double max_tilt_sigma = deg2rad(1.0);
  auto face = [&](const CellPlane& p) { return p.planar && p.tilt_sigma <= max_tilt_sigma; };
  auto planar = [&](std::size_t s, CellKey k) -> const std::pair<CellIndex, CellPlane>* {
    const auto it = strips[s].find(k);
    return it != strips[s].end() && face(it->second.second) ? &it->second : nullptr;
  };
  std::map<std::pair<std::size_t, std::size_t>, std::vector<double>> out;
  for (std::size_t a = 0; a < strips.size(); ++a)
    for (const auto& [k1, e1] : strips[a]) {
      if (!face(e1.second)) continue;
      const auto [i, j] = e1.first;
      for (std::int64_t di = 0; di <= 2; ++di)
        for (std::int64_t dj = -2; dj <= 2; ++dj) {
          if (di == 0 && dj <= 0) continue;  // each pair of cells once
          const CellKey k2 = key(i + di, j + dj);
          const auto* e2 = planar(a, k2);
          if (!e2) continue;
          const AbsPlane p1 = absPlane(e1.second, g, e1.first), p2 = absPlane(e2->second, g, e2->first);
          if (p1.n.normalized().dot(p2.n.normalized()) > cos_turn) continue;  // one face
          const Vec3 m(0.5 * (g.cx(i) + g.cx(i + di)), 0.5 * (g.cy(j) + g.cy(j + dj)), 0.5 * (e1.second.z + e2->second.z));
          Vec3 xa, ua;
          if (!meetLine(p1, p2, m, &xa, &ua)) continue;
          if (std::hypot(xa.x() - m.x(), xa.y() - m.y()) > 0.5 * g.cell * std::hypot(double(di), double(dj)) + 1e-9) continue;
          for (std::size_t b = a + 1; b < strips.size(); ++b) {
            const auto *f1 = planar(b, k1), *f2 = planar(b, k2);
            if (!f1 || !f2) continue;
            Vec3 xb, ub;
            if (!meetLine(absPlane(f1->second, g, f1->first), absPlane(f2->second, g, f2->first), xa, &xb, &ub)) continue;
            if (std::abs(ua.dot(ub)) < std::cos(deg2rad(10.0))) continue;  // not the conjugate edge
            const Vec3 d = xb - xa;
            out[{a, b}].push_back((d - d.dot(ua) * ua).norm());
          }
        }
    }
  for (auto& [pair, v] : out) std::sort(v.begin(), v.end());
  return out;
}

/// One pair's dZ values, and its raster over the pair's common extent.
std::vector<double> pairDz(const std::vector<std::pair<CellIndex, double>>& cells, const Grid& g, DzRaster* raster) {
  std::vector<double> dz;
  *raster = DzRaster{};
  raster->cell_m = g.cell;
  if (cells.empty()) return dz;
  std::int64_t i0 = cells[0].first.first, i1 = i0, j0 = cells[0].first.second, j1 = j0;
  for (const auto& c : cells) {
    i0 = std::min(i0, c.first.first), i1 = std::max(i1, c.first.first);
    j0 = std::min(j0, c.first.second), j1 = std::max(j1, c.first.second);
    dz.push_back(c.second);
  }
  raster->nx = static_cast<int>(i1 - i0 + 1);
  raster->ny = static_cast<int>(j1 - j0 + 1);
  raster->x0_m = g.x0 + static_cast<double>(i0) * g.cell;
  raster->y1_m = g.y0 + static_cast<double>(j1 + 1) * g.cell;
  raster->dz_m.assign(static_cast<std::size_t>(raster->nx) * static_cast<std::size_t>(raster->ny), std::nanf(""));
  for (const auto& c : cells) {
    const std::size_t col = static_cast<std::size_t>(c.first.first - i0), row = static_cast<std::size_t>(j1 - c.first.second);
    raster->dz_m[row * static_cast<std::size_t>(raster->nx) + col] = static_cast<float>(c.second);
  }
  return dz;
}

/// The verdict per level at the mounting after: the strips' largest intraswath repeatability and
/// the pooled interswath figures against the level's limits.
std::vector<LevelVerdict> verdictsOf(const SwathQcResult& qc, const std::vector<QualityLevel>& levels) {
  double intra = 0;
  for (const StripQc& s : qc.strips)
    if (!std::isnan(s.intraswath_max_m)) intra = std::max(intra, s.intraswath_max_m);
  std::vector<LevelVerdict> out;
  for (const QualityLevel& l : levels) {
    LevelVerdict v;
    v.level = l;
    v.intraswath_pass = l.intraswath_max_m <= 0 || intra <= l.intraswath_max_m;
    v.rmsdz_pass = l.interswath_rmsdz_m <= 0 || (qc.overall_after.cells > 0 && qc.overall_after.rmsdz_m <= l.interswath_rmsdz_m);
    v.max_pass = l.interswath_max_m <= 0 || (qc.overall_after.cells > 0 && qc.overall_after.max_abs_dz_m <= l.interswath_max_m);
    out.push_back(v);
  }
  return out;
}

/// Statistics of several disjoint sets of values pooled from their own statistics (n, RMS, mean,
/// largest, shares: the sums they were made of).
DzStats pooledStats(const std::vector<const DzStats*>& parts, std::size_t thresholds) {
  DzStats s;
  s.share_over.assign(thresholds, NAN);
  double ss = 0, sum = 0, mx = 0;
  std::vector<double> over(thresholds, 0.0);
  for (const DzStats* p : parts) {
    if (p->cells == 0) continue;
    const double n = static_cast<double>(p->cells);
    s.cells += p->cells;
    ss += p->rmsdz_m * p->rmsdz_m * n;
    sum += p->mean_dz_m * n;
    mx = std::max(mx, p->max_abs_dz_m);
    for (std::size_t k = 0; k < thresholds && k < p->share_over.size(); ++k) over[k] += p->share_over[k] * n;
  }
  if (s.cells == 0) return s;
  const double n = static_cast<double>(s.cells);
  s.rmsdz_m = std::sqrt(ss / n);
  s.mean_dz_m = sum / n;
  s.max_abs_dz_m = mx;
  for (std::size_t k = 0; k < thresholds; ++k) s.share_over[k] = std::round(over[k]) / n;
  return s;
}

/// The pooled figures of every measure from the pairs' own (pooledStats).
void poolPairs(SwathQcResult* out) {
  std::vector<const DzStats*> b, a, pb, pa, eb, ea;
  for (const PairQc& p : out->pairs) {
    b.push_back(&p.before), a.push_back(&p.after);
    pb.push_back(&p.sloped_planes_before), pa.push_back(&p.sloped_planes_after);
    eb.push_back(&p.roof_edges_before), ea.push_back(&p.roof_edges_after);
  }
  const std::size_t t = out->thresholds_m.size();
  out->overall_before = pooledStats(b, t);
  out->overall_after = pooledStats(a, t);
  out->sloped_planes_before = pooledStats(pb, t);
  out->sloped_planes_after = pooledStats(pa, t);
  out->roof_edges_before = pooledStats(eb, t);
  out->roof_edges_after = pooledStats(ea, t);
}

/// The sloped-plane and roof-edge measures, on their own, finer grid (a roof face holds few cells
/// of the dZ grid), into each pair's values before and after.
void addPlaneMeasures(const std::vector<std::vector<Vec3>>& xb, const std::vector<std::vector<Vec3>>& xa, const Grid& g,
                      double plane_cell_m, const SwathQcOptions& options, PairCells* pb, PairCells* pa) {
  Grid gp = g;
  gp.cell = plane_cell_m;
  for (int state = 0; state < 2; ++state) {
    const auto& x = state == 0 ? xb : xa;
    PairCells& out = state == 0 ? *pb : *pa;
    std::vector<StripCells> cells;
    for (const auto& strip : x) cells.push_back(stripCells(strip, gp, options));
    for (auto& [pair, v] : pairCells(cells, true, options.max_plane_angle_deg)) out[pair].plane_distance = std::move(v.plane_distance);
    for (auto& [pair, v] : roofEdges(cells, gp, options.min_edge_turn_deg)) out[pair].edge_distance = std::move(v);
  }
}

}  // namespace

double swathQcCellSize(const std::vector<std::vector<Vec3>>& strips, const SwathQcOptions& options) {
  double sparsest = 0;
  for (const auto& s : strips) sparsest = std::max(sparsest, detail::planSpacing(s));
  return options.cellSizeFor(sparsest);
}

SwathQcResult mergeSwathQc(const std::vector<SwathQcResult>& parts, const std::vector<QualityLevel>& levels) {
  SwathQcResult out;
  for (const SwathQcResult& q : parts) {
    if (q.pairs.empty() && q.strips.empty()) continue;
    if (out.cell_size_m == 0) {
      out.cell_size_m = q.cell_size_m;
      out.plane_cell_size_m = q.plane_cell_size_m;
      out.thresholds_m = q.thresholds_m;
    } else if (q.cell_size_m != out.cell_size_m || q.plane_cell_size_m != out.plane_cell_size_m || q.thresholds_m != out.thresholds_m) {
      throw InvalidInput("swath QC: the parts were measured on different cells or thresholds (give every pair the same --cell)");
    }
    for (const PairQc& p : q.pairs) {
      for (const PairQc& seen : out.pairs)
        if (seen.a == p.a && seen.b == p.b) throw InvalidInput("swath QC: the pair " + p.a + " – " + p.b + " is in two parts");
      out.pairs.push_back(p);
    }
    for (const StripQc& s : q.strips)
      if (std::none_of(out.strips.begin(), out.strips.end(), [&](const StripQc& t) { return t.id == s.id; })) out.strips.push_back(s);
  }
  poolPairs(&out);
  out.verdicts = verdictsOf(out, levels);
  return out;
}

SwathQcResult swathQc(const CalibrationData& data, const MountingParameters& before, const MountingParameters& after,
                      const SwathQcOptions& options, const LaserCorrections& lasers_after) {
  std::vector<std::string> ids;
  for (const StripData& st : data.strips) ids.push_back(st.id);
  return swathQcOfPoints(ids, georeferencedStrips(data, before), georeferencedStrips(data, after, lasers_after), options);
}

SwathQcResult swathQcOfPoints(const std::vector<std::string>& ids, const std::vector<std::vector<Vec3>>& xb,
                              const std::vector<std::vector<Vec3>>& xa, const SwathQcOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidInput("swath QC options: " + why);
  if (xb.size() != ids.size() || xa.size() != ids.size()) throw InvalidInput("swath QC: one point set per strip, before and after");
  SwathQcResult out;
  // One grid for before and after, every strip, and every run: cells at multiples of the cell
  // from the frame's origin, so that a pair's QC alone (mountcal qc --pair, the block workflow)
  // sees the cells of the whole block's.
  Grid g;
  g.cell = options.cell_size_m > 0 ? options.cell_size_m : swathQcCellSize(xb, options);
  out.cell_size_m = g.cell;
  out.thresholds_m = options.thresholds_m;
  std::vector<StripCells> cb, ca;
  std::vector<CellMembers> mb(options.point_to_plane ? xb.size() : 0), ma(mb.size());  // for the point-to-plane measure
  for (std::size_t s = 0; s < xb.size(); ++s) {
    cb.push_back(stripCells(xb[s], g, options, options.point_to_plane ? &mb[s] : nullptr));
    ca.push_back(stripCells(xa[s], g, options, options.point_to_plane ? &ma[s] : nullptr));
    const double sub = options.intraswath_cell_m > 0 ? options.intraswath_cell_m : 2.0 * std::max(detail::planSpacing(xa[s]), 1e-3);
    out.strips.push_back(intraswath(ids[s], xa[s], ca.back(), g, sub));
  }
  PairCells pb = pairCells(cb, false), pa = pairCells(ca, false);
  out.plane_cell_size_m = options.sloped_planes ? (options.plane_cell_m > 0 ? options.plane_cell_m : g.cell / 2) : 0.0;
  if (options.sloped_planes) addPlaneMeasures(xb, xa, g, out.plane_cell_size_m, options, &pb, &pa);
  static const PairCellValues kNone;
  for (std::size_t a = 0; a < xb.size(); ++a)
    for (std::size_t b = a + 1; b < xb.size(); ++b) {
      const auto ib = pb.find({a, b}), ia = pa.find({a, b});
      if (ib == pb.end() && ia == pa.end()) continue;
      PairQc p;
      p.a = ids[a];
      p.b = ids[b];
      const PairCellValues &vb = ib == pb.end() ? kNone : ib->second, &va = ia == pa.end() ? kNone : ia->second;
      const std::vector<double> db = pairDz(vb.dz, g, &p.raster_before), da = pairDz(va.dz, g, &p.raster_after);
      p.before = dzStats(db, options.thresholds_m);
      p.after = dzStats(da, options.thresholds_m);
      p.sloped_planes_before = dzStats(vb.plane_distance, options.thresholds_m);
      p.sloped_planes_after = dzStats(va.plane_distance, options.thresholds_m);
      p.roof_edges_before = dzStats(vb.edge_distance, options.thresholds_m);
      p.roof_edges_after = dzStats(va.edge_distance, options.thresholds_m);
      if (options.point_to_plane) {
        DiscrepancyOptions d;
        d.max_queries = options.point_to_plane_queries;
        const bool a_smaller = xa[a].size() <= xa[b].size();
        const std::size_t q = a_smaller ? a : b, r = a_smaller ? b : a;
        p.point_to_plane_before = overlapPointToPlane(xb[q], mb[q], xb[r], mb[r], d);
        p.point_to_plane_after = overlapPointToPlane(xa[q], ma[q], xa[r], ma[r], d);
      }
      out.pairs.push_back(std::move(p));
    }
  poolPairs(&out);
  out.verdicts = verdictsOf(out, options.levels);
  return out;
}

namespace {
nlohmann::json num(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

nlohmann::json statsJson(const DzStats& s, const std::vector<double>& thresholds) {
  nlohmann::json j = {
      {"cells", s.cells}, {"rmsdz_m", num(s.rmsdz_m)}, {"mean_dz_m", num(s.mean_dz_m)}, {"max_abs_dz_m", num(s.max_abs_dz_m)}};
  nlohmann::json over = nlohmann::json::array();
  for (std::size_t k = 0; k < s.share_over.size() && k < thresholds.size(); ++k)
    over.push_back({{"threshold_m", thresholds[k]}, {"share", num(s.share_over[k])}});
  j["share_over"] = over;
  return j;
}

/// The sloped-plane distances' statistics (PairQc::sloped_planes_*).
nlohmann::json planesJson(const DzStats& s) {
  return {{"cells", s.cells}, {"rms_m", num(s.rmsdz_m)}, {"mean_m", num(s.mean_dz_m)}, {"max_abs_m", num(s.max_abs_dz_m)}};
}
}  // namespace

std::string swathQcJson(const SwathQcResult& qc) {
  const std::vector<double>& thresholds = qc.thresholds_m;
  nlohmann::json j;
  j["cell_size_m"] = qc.cell_size_m;
  j["plane_cell_size_m"] = qc.plane_cell_size_m;
  j["pairs"] = nlohmann::json::array();
  for (const PairQc& p : qc.pairs) {
    nlohmann::json pj = statsJson(p.after, thresholds);
    pj["a"] = p.a;
    pj["b"] = p.b;
    pj["before"] = statsJson(p.before, thresholds);
    pj["after"] = statsJson(p.after, thresholds);
    auto ptp = [](const DiscrepancyStats& d) {
      return nlohmann::json{
          {"queries", d.queries}, {"used", d.used}, {"median_m", num(d.median_m)}, {"rms_m", num(d.rms_m)}, {"p90_m", num(d.p90_m)}};
    };
    pj["point_to_plane"] = {{"before", ptp(p.point_to_plane_before)}, {"after", ptp(p.point_to_plane_after)}};
    pj["sloped_planes"] = {{"before", planesJson(p.sloped_planes_before)}, {"after", planesJson(p.sloped_planes_after)}};
    pj["roof_edges"] = {{"before", planesJson(p.roof_edges_before)}, {"after", planesJson(p.roof_edges_after)}};
    j["pairs"].push_back(pj);
  }
  j["strips"] = nlohmann::json::array();
  for (const StripQc& s : qc.strips)
    j["strips"].push_back({{"id", s.id},
                           {"smooth_cells", s.smooth_cells},
                           {"intraswath_precision_m", num(s.intraswath_precision_m)},
                           {"intraswath_max_m", num(s.intraswath_max_m)}});
  nlohmann::json summary = statsJson(qc.overall_after, thresholds);
  summary["before"] = statsJson(qc.overall_before, thresholds);
  summary["sloped_planes"] = {{"before", planesJson(qc.sloped_planes_before)}, {"after", planesJson(qc.sloped_planes_after)}};
  summary["roof_edges"] = {{"before", planesJson(qc.roof_edges_before)}, {"after", planesJson(qc.roof_edges_after)}};
  summary["classes"] = nlohmann::json::array();
  for (const LevelVerdict& v : qc.verdicts)
    summary["classes"].push_back({{"name", v.level.name},
                                  {"pass", v.pass()},
                                  {"intraswath_max_m", v.level.intraswath_max_m},
                                  {"interswath_rmsdz_m", v.level.interswath_rmsdz_m},
                                  {"interswath_max_m", v.level.interswath_max_m},
                                  {"intraswath_pass", v.intraswath_pass},
                                  {"rmsdz_pass", v.rmsdz_pass},
                                  {"max_pass", v.max_pass},
                                  {"source", v.level.source}});
  j["summary"] = summary;
  return j.dump(2) + "\n";
}

namespace {
double numberOr(const nlohmann::json& j, const char* key) {
  if (!j.contains(key) || j[key].is_null()) return NAN;
  if (!j[key].is_number()) throw InvalidInput(std::string("qc.json: '") + key + "' is not a number");
  return j[key].get<double>();
}

std::size_t countOf(const nlohmann::json& j, const char* key) {
  if (!j.contains(key) || !j[key].is_number_unsigned()) throw InvalidInput(std::string("qc.json: '") + key + "' is not a count");
  return j[key].get<std::size_t>();
}

DzStats statsFromJson(const nlohmann::json& j, const char* rms, const char* mean, const char* max) {
  if (!j.is_object()) throw InvalidInput("qc.json: statistics are not an object");
  DzStats s;
  s.cells = countOf(j, "cells");
  s.rmsdz_m = numberOr(j, rms);
  s.mean_dz_m = numberOr(j, mean);
  s.max_abs_dz_m = numberOr(j, max);
  if (j.contains("share_over"))
    for (const auto& o : j.at("share_over")) s.share_over.push_back(numberOr(o, "share"));
  return s;
}

DiscrepancyStats ptpFromJson(const nlohmann::json& j) {
  DiscrepancyStats d;
  d.queries = countOf(j, "queries");
  d.used = countOf(j, "used");
  d.median_m = numberOr(j, "median_m");
  d.rms_m = numberOr(j, "rms_m");
  d.p90_m = numberOr(j, "p90_m");
  return d;
}
}  // namespace

SwathQcResult swathQcFromJson(const std::string& text) {
  SwathQcResult q;
  try {
    const nlohmann::json j = nlohmann::json::parse(text);
    q.cell_size_m = numberOr(j, "cell_size_m");
    q.plane_cell_size_m = j.contains("plane_cell_size_m") ? numberOr(j, "plane_cell_size_m") : 0.0;
    if (!(q.cell_size_m > 0)) throw InvalidInput("qc.json: 'cell_size_m' must be a positive number");
    for (const auto& o : j.at("summary").at("share_over")) q.thresholds_m.push_back(numberOr(o, "threshold_m"));
    for (const auto& pj : j.at("pairs")) {
      PairQc p;
      p.a = pj.at("a").get<std::string>();
      p.b = pj.at("b").get<std::string>();
      p.before = statsFromJson(pj.at("before"), "rmsdz_m", "mean_dz_m", "max_abs_dz_m");
      p.after = statsFromJson(pj.at("after"), "rmsdz_m", "mean_dz_m", "max_abs_dz_m");
      p.point_to_plane_before = ptpFromJson(pj.at("point_to_plane").at("before"));
      p.point_to_plane_after = ptpFromJson(pj.at("point_to_plane").at("after"));
      p.sloped_planes_before = statsFromJson(pj.at("sloped_planes").at("before"), "rms_m", "mean_m", "max_abs_m");
      p.sloped_planes_after = statsFromJson(pj.at("sloped_planes").at("after"), "rms_m", "mean_m", "max_abs_m");
      p.roof_edges_before = statsFromJson(pj.at("roof_edges").at("before"), "rms_m", "mean_m", "max_abs_m");
      p.roof_edges_after = statsFromJson(pj.at("roof_edges").at("after"), "rms_m", "mean_m", "max_abs_m");
      for (DzStats* s : {&p.sloped_planes_before, &p.sloped_planes_after, &p.roof_edges_before, &p.roof_edges_after})
        s->share_over.assign(q.thresholds_m.size(), NAN);
      q.pairs.push_back(std::move(p));
    }
    for (const auto& sj : j.at("strips")) {
      StripQc s;
      s.id = sj.at("id").get<std::string>();
      s.smooth_cells = countOf(sj, "smooth_cells");
      s.intraswath_precision_m = numberOr(sj, "intraswath_precision_m");
      s.intraswath_max_m = numberOr(sj, "intraswath_max_m");
      q.strips.push_back(std::move(s));
    }
  } catch (const nlohmann::json::exception& e) {
    throw InvalidInput(std::string("qc.json: ") + e.what());
  }
  return q;
}

namespace {
/// One dZ raster as an SVG map (at most 100 cells a side: coarser blocks take their largest |dZ|),
/// coloured by the thresholds' classes.
std::string rasterSvg(const DzRaster& r, const std::vector<double>& t) {
  if (r.nx == 0 || r.ny == 0) return "<p>no common smooth cells</p>";
  auto absDz = [&r](int x, int y) {
    return std::abs(
        static_cast<double>(r.dz_m[static_cast<std::size_t>(y) * static_cast<std::size_t>(r.nx) + static_cast<std::size_t>(x)]));
  };
  return svgClassedGrid(r.nx, r.ny, absDz, t);
}

std::string statsRow(const std::string& what, const DzStats& s) {
  std::ostringstream o;
  o << "<tr><td>" << detail::htmlEscape(what) << "</td><td>" << s.cells << "</td><td>" << detail::formatNumber(s.rmsdz_m, "%.4f")
    << "</td><td>" << detail::formatNumber(s.mean_dz_m, "%+.4f") << "</td><td>" << detail::formatNumber(s.max_abs_dz_m, "%.4f") << "</td>";
  for (double v : s.share_over) o << "<td>" << detail::formatNumber(100 * v, "%.1f") << " %</td>";
  o << "</tr>";
  return o.str();
}
}  // namespace

std::string swathQcHtml(const SwathQcResult& qc, const std::string& title) {
  std::ostringstream o;
  o << "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>" << detail::htmlEscape(title)
    << "</title><style>body{font-family:sans-serif;margin:2em}table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px "
       "6px;text-align:right}td:first-child{text-align:left}.pass{color:#1a9850}.fail{color:#d73027}</style></head><body><h1>"
    << detail::htmlEscape(title) << "</h1>" << swathQcSection(qc, 2) << "</body></html>\n";
  return o.str();
}

std::string swathQcSection(const SwathQcResult& qc, int level) {
  const std::string h = "h" + std::to_string(level), h2 = "h" + std::to_string(level + 1);
  std::ostringstream o;
  if (qc.pairs.empty()) return "<" + h + ">Swath QC</" + h + "><p>No two strips share a smooth open cell.</p>";
  o << "<" << h << ">Swath QC</" << h << "><p>Cells of " << detail::formatNumber(qc.cell_size_m, "%.3g")
    << " m; dZ where both strips are smooth and open (docs/swath-qc.md). Verdict at the mounting "
       "after:</p><table><tr><th>level</th><th>intraswath "
       "≤</th><th>RMSDz ≤</th><th>max |dZ| ≤</th><th>verdict</th></tr>";
  for (const LevelVerdict& v : qc.verdicts)
    o << "<tr><td>" << detail::htmlEscape(v.level.name) << "</td><td>" << detail::formatNumber(v.level.intraswath_max_m, "%.2f")
      << " m</td><td>" << detail::formatNumber(v.level.interswath_rmsdz_m, "%.2f") << " m</td><td>"
      << detail::formatNumber(v.level.interswath_max_m, "%.2f") << " m</td><td class=\"" << (v.pass() ? "pass\">pass" : "fail\">fail")
      << "</td></tr>";
  o << "</table><" << h2 << ">Interswath</" << h2
    << "><table><tr><th></th><th>cells</th><th>RMSDz [m]</th><th>mean [m]</th><th>max |dZ| [m]</th>";
  for (double t : qc.thresholds_m) o << "<th>|dZ| &gt; " << detail::formatNumber(t, "%.2f") << " m</th>";
  o << "</tr>" << statsRow("all pairs, before", qc.overall_before) << statsRow("all pairs, after", qc.overall_after);
  for (const PairQc& p : qc.pairs)
    o << statsRow(p.a + " – " + p.b + ", before", p.before) << statsRow(p.a + " – " + p.b + ", after", p.after);
  o << "</table>";
  const bool ptp = std::any_of(qc.pairs.begin(), qc.pairs.end(), [](const PairQc& p) { return p.point_to_plane_after.queries > 0; });
  if (ptp)
    o << "<" << h2 << ">Point to tangent plane (ASPRS 2018, 3-D)</" << h2
      << "><p>Each point of the smaller strip of a pair against the local plane of the larger's 10 nearest points (docs/swath-qc.md).</p>"
         "<table><tr><th>pair</th><th>points used</th><th>median before [m]</th><th>median after [m]</th><th>RMS before [m]</th><th>RMS "
         "after "
         "[m]</th><th>P90 after [m]</th></tr>";
  for (const PairQc& p : qc.pairs)
    if (ptp)
      o << "<tr><td>" << detail::htmlEscape(p.a + " – " + p.b) << "</td><td>" << p.point_to_plane_after.used << "</td><td>"
        << detail::formatNumber(p.point_to_plane_before.median_m, "%.4f") << "</td><td>"
        << detail::formatNumber(p.point_to_plane_after.median_m, "%.4f") << "</td><td>"
        << detail::formatNumber(p.point_to_plane_before.rms_m, "%.4f") << "</td><td>"
        << detail::formatNumber(p.point_to_plane_after.rms_m, "%.4f") << "</td><td>"
        << detail::formatNumber(p.point_to_plane_after.p90_m, "%.4f") << "</td></tr>";
  if (ptp) o << "</table>";
  auto measureTable = [&](const std::string& heading, const std::string& text, const DzStats& all_b, const DzStats& all_a,
                          DzStats PairQc::*before, DzStats PairQc::*after) {
    if (all_b.cells + all_a.cells == 0) return;
    o << "<" << h2 << ">" << heading << "</" << h2 << "><p>" << text
      << "</p><table><tr><th></th><th>cells</th><th>RMS [m]</th><th>mean [m]</th><th>max |d| [m]</th></tr>";
    auto row = [&](const std::string& what, const DzStats& d) {
      o << "<tr><td>" << detail::htmlEscape(what) << "</td><td>" << d.cells << "</td><td>" << detail::formatNumber(d.rmsdz_m, "%.4f")
        << "</td><td>" << detail::formatNumber(d.mean_dz_m, "%+.4f") << "</td><td>" << detail::formatNumber(d.max_abs_dz_m, "%.4f")
        << "</td></tr>";
    };
    row("all pairs, before", all_b);
    row("all pairs, after", all_a);
    for (const PairQc& p : qc.pairs) {
      row(p.a + " – " + p.b + ", before", p.*before);
      row(p.a + " – " + p.b + ", after", p.*after);
    }
    o << "</table>";
  };
  const std::string cells = detail::formatNumber(qc.plane_cell_size_m, "%.3g");
  measureTable("Sloped planes (ASPRS 2018 roof planes, 3-D)",
               "On cells of " + cells +
                   " m where both strips are planar and sloped (roofs): the distance of one strip's centroid from the other's plane, "
                   "along its normal; a horizontal shift h across a slope θ shows as h·sin θ.",
               qc.sloped_planes_before, qc.sloped_planes_after, &PairQc::sloped_planes_before, &PairQc::sloped_planes_after);
  measureTable("Roof edges (ASPRS 2018, 3-D)",
               "Where two planar cells of " + cells +
                   " m turn by more than 20° (two faces of a roof), the line where their planes meet in one strip against the same "
                   "cells' line in the other: the distance across it (a horizontal shift h across a ridge shows as h). 'cells' counts "
                   "pairs of cells.",
               qc.roof_edges_before, qc.roof_edges_after, &PairQc::roof_edges_before, &PairQc::roof_edges_after);
  o << "<" << h2 << ">Intraswath (at the mounting after)</" << h2
    << "><table><tr><th>strip</th><th>smooth cells</th><th>precision (RMS) "
       "[m]</th><th>largest "
       "within-cell range (P95) [m]</th></tr>";
  for (const StripQc& s : qc.strips)
    o << "<tr><td>" << detail::htmlEscape(s.id) << "</td><td>" << s.smooth_cells << "</td><td>"
      << detail::formatNumber(s.intraswath_precision_m, "%.4f") << "</td><td>" << detail::formatNumber(s.intraswath_max_m, "%.4f")
      << "</td></tr>";
  o << "</table><" << h2 << ">dZ maps</" << h2 << "><p>Colours by |dZ|: green ≤ " << (qc.thresholds_m.empty() ? 0.0 : qc.thresholds_m[0])
    << " m";
  for (std::size_t k = 1; k < qc.thresholds_m.size() && k < 3; ++k)
    o << ", " << (k == 1 ? "yellow" : "orange") << " ≤ " << qc.thresholds_m[k] << " m";
  o << ", red beyond; north up.</p>";
  // The maps of the pairs with most cells (at most 8: a block has hundreds of pairs; every
  // pair's raster is in its GeoTIFF).
  std::vector<const PairQc*> drawn;
  std::size_t elsewhere = 0;  // merged from per-pair QC: the maps are in each pair's own files
  for (const PairQc& p : qc.pairs) {
    if (p.raster_before.nx == 0 && p.raster_after.nx == 0 && p.before.cells + p.after.cells > 0)
      ++elsewhere;
    else
      drawn.push_back(&p);
  }
  if (elsewhere > 0)
    o << "<p>" << elsewhere << " pairs' maps are in their own qc.html and GeoTIFF files (measured one pair at a time).</p>";
  std::stable_sort(drawn.begin(), drawn.end(), [](const PairQc* x, const PairQc* y) { return x->after.cells > y->after.cells; });
  if (drawn.size() > 8) {
    o << "<p>The " << 8 << " pairs with most common cells of " << drawn.size() << "; every pair's raster is in its GeoTIFF.</p>";
    drawn.resize(8);
  }
  for (const PairQc* pp : drawn)
    o << "<h" << level + 2 << ">" << detail::htmlEscape(pp->a + " – " + pp->b) << "</h" << level + 2
      << "><table><tr><th>before</th><th>after</th></tr><tr><td>" << rasterSvg(pp->raster_before, qc.thresholds_m) << "</td><td>"
      << rasterSvg(pp->raster_after, qc.thresholds_m) << "</td></tr></table>";
  return o.str();
}

}  // namespace mountcal
