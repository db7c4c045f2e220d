#include "mountcal/report/swath_qc.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <sstream>
#include <unordered_map>

#include <nlohmann/json.hpp>

#include "geometry/point_geometry.hpp"
#include "mountcal/core/error.hpp"
#include "mountcal/core/rotation.hpp"
#include "mountcal/report/evaluation.hpp"
#include "report/html_text.hpp"

namespace mountcal {

std::vector<QualityLevel> usgsQualityLevels() {
  const std::string src = "USGS Lidar Base Specification (TM 11-B4 v1.2/v1.3), data precision requirements";
  return {{"USGS QL0", 0.03, 0.04, 0.08, src},
          {"USGS QL1", 0.06, 0.06, 0.12, src},
          {"USGS QL2", 0.06, 0.08, 0.16, src},
          {"USGS QL3", 0.12, 0.16, 0.32, src}};
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

/// A strip's plane in one cell: height at the centre, slope, roughness; smooth by the gates.
struct CellPlane {
  double z = NAN, b = 0, c = 0, roughness = NAN;
  bool smooth = false;
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
  p.smooth = covered && slope <= deg2rad(o.max_slope_deg) && p.roughness <= o.max_roughness_m;
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

using PairCells = std::map<std::pair<std::size_t, std::size_t>, std::vector<std::pair<CellIndex, double>>>;

/// Every strip pair's common smooth cells with dZ = z_A − z_B (A the earlier strip): one pass
/// over the cells, so the work grows with the cells and the overlaps, not with pairs × cells.
PairCells pairCells(const std::vector<StripCells>& strips) {
  std::unordered_map<CellKey, std::vector<std::pair<std::size_t, const std::pair<CellIndex, CellPlane>*>>> at;
  for (std::size_t s = 0; s < strips.size(); ++s)
    for (const auto& [k, e] : strips[s])
      if (e.second.smooth) at[k].push_back({s, &e});
  PairCells out;
  for (const auto& [k, list] : at)
    for (std::size_t u = 0; u < list.size(); ++u)
      for (std::size_t v = u + 1; v < list.size(); ++v) {
        const auto& [sa, ea] = list[u];
        const auto& [sb, eb] = list[v];
        const bool ordered = sa < sb;
        const double dz = ordered ? ea->second.z - eb->second.z : eb->second.z - ea->second.z;
        out[{std::min(sa, sb), std::max(sa, sb)}].push_back({ea->first, dz});
      }
  for (auto& [pair, cells] : out) std::sort(cells.begin(), cells.end());  // independent of the hash order
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

}  // namespace

SwathQcResult swathQc(const CalibrationData& data, const MountingParameters& before, const MountingParameters& after,
                      const SwathQcOptions& options) {
  std::vector<std::string> ids;
  for (const StripData& st : data.strips) ids.push_back(st.id);
  return swathQcOfPoints(ids, georeferencedStrips(data, before), georeferencedStrips(data, after), options);
}

SwathQcResult swathQcOfPoints(const std::vector<std::string>& ids, const std::vector<std::vector<Vec3>>& xb,
                              const std::vector<std::vector<Vec3>>& xa, const SwathQcOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidInput("swath QC options: " + why);
  if (xb.size() != ids.size() || xa.size() != ids.size()) throw InvalidInput("swath QC: one point set per strip, before and after");
  SwathQcResult out;
  Grid g;
  double sparsest = 0, xmin = 1e300, ymin = 1e300;
  for (const auto& s : xb) {
    sparsest = std::max(sparsest, detail::planSpacing(s));
    for (const Vec3& p : s) xmin = std::min(xmin, p.x()), ymin = std::min(ymin, p.y());
  }
  g.cell = options.cell_size_m > 0 ? options.cell_size_m : options.cellSizeFor(sparsest);
  g.x0 = std::floor(xmin / g.cell) * g.cell;  // one grid for before and after, and every strip
  g.y0 = std::floor(ymin / g.cell) * g.cell;
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
  std::vector<double> all_b, all_a;
  const PairCells pb = pairCells(cb), pa = pairCells(ca);
  static const std::vector<std::pair<CellIndex, double>> kNone;
  for (std::size_t a = 0; a < xb.size(); ++a)
    for (std::size_t b = a + 1; b < xb.size(); ++b) {
      const auto ib = pb.find({a, b}), ia = pa.find({a, b});
      if (ib == pb.end() && ia == pa.end()) continue;
      PairQc p;
      p.a = ids[a];
      p.b = ids[b];
      const std::vector<double> db = pairDz(ib == pb.end() ? kNone : ib->second, g, &p.raster_before),
                                da = pairDz(ia == pa.end() ? kNone : ia->second, g, &p.raster_after);
      p.before = dzStats(db, options.thresholds_m);
      p.after = dzStats(da, options.thresholds_m);
      if (options.point_to_plane) {
        DiscrepancyOptions d;
        d.max_queries = options.point_to_plane_queries;
        const bool a_smaller = xa[a].size() <= xa[b].size();
        const std::size_t q = a_smaller ? a : b, r = a_smaller ? b : a;
        p.point_to_plane_before = overlapPointToPlane(xb[q], mb[q], xb[r], mb[r], d);
        p.point_to_plane_after = overlapPointToPlane(xa[q], ma[q], xa[r], ma[r], d);
      }
      all_b.insert(all_b.end(), db.begin(), db.end());
      all_a.insert(all_a.end(), da.begin(), da.end());
      out.pairs.push_back(std::move(p));
    }
  out.overall_before = dzStats(all_b, options.thresholds_m);
  out.overall_after = dzStats(all_a, options.thresholds_m);
  double intra = 0;
  for (const StripQc& s : out.strips)
    if (!std::isnan(s.intraswath_max_m)) intra = std::max(intra, s.intraswath_max_m);
  for (const QualityLevel& l : options.levels) {
    LevelVerdict v;
    v.level = l;
    v.intraswath_pass = l.intraswath_max_m <= 0 || intra <= l.intraswath_max_m;
    v.rmsdz_pass = l.interswath_rmsdz_m <= 0 || (out.overall_after.cells > 0 && out.overall_after.rmsdz_m <= l.interswath_rmsdz_m);
    v.max_pass = l.interswath_max_m <= 0 || (out.overall_after.cells > 0 && out.overall_after.max_abs_dz_m <= l.interswath_max_m);
    out.verdicts.push_back(v);
  }
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
}  // namespace

std::string swathQcJson(const SwathQcResult& qc) {
  const std::vector<double>& thresholds = qc.thresholds_m;
  nlohmann::json j;
  j["cell_size_m"] = qc.cell_size_m;
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
/// One dZ raster as an SVG map (at most 100 cells a side: coarser blocks take their largest |dZ|),
/// coloured by the thresholds' classes.
std::string rasterSvg(const DzRaster& r, const std::vector<double>& t) {
  if (r.nx == 0 || r.ny == 0) return "<p>no common smooth cells</p>";
  const int step = std::max(1, (std::max(r.nx, r.ny) + 99) / 100);
  const int w = (r.nx + step - 1) / step, h = (r.ny + step - 1) / step;
  const int px = std::max(1, 400 / std::max(w, h));
  static const char* colours[] = {"#1a9850", "#fee08b", "#fc8d59", "#d73027"};
  std::ostringstream o;
  o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << w * px << "\" height=\"" << h * px << "\" style=\"background:#eee\">";
  for (int by = 0; by < h; ++by)
    for (int bx = 0; bx < w; ++bx) {
      double worst = -1;
      for (int y = by * step; y < std::min(r.ny, (by + 1) * step); ++y)
        for (int x = bx * step; x < std::min(r.nx, (bx + 1) * step); ++x) {
          const float v = r.dz_m[static_cast<std::size_t>(y) * static_cast<std::size_t>(r.nx) + static_cast<std::size_t>(x)];
          if (!std::isnan(v)) worst = std::max(worst, std::abs(static_cast<double>(v)));
        }
      if (worst < 0) continue;
      std::size_t c = 0;
      while (c < t.size() && c < 3 && worst > t[c]) ++c;
      o << "<rect x=\"" << bx * px << "\" y=\"" << by * px << "\" width=\"" << px << "\" height=\"" << px << "\" fill=\"" << colours[c]
        << "\"/>";
    }
  o << "</svg>";
  return o.str();
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
  for (const PairQc& p : qc.pairs) drawn.push_back(&p);
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
