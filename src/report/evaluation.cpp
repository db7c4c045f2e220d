#include "mountcal/report/evaluation.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>

#include "mountcal/core/error.hpp"
#include "mountcal/core/sensor_model.hpp"
#include "geometry/kd_tree.hpp"
#include "geometry/point_geometry.hpp"
#include "methods/common/vtp_strip.hpp"
#include "mountcal/core/georeference_model.hpp"

namespace mountcal {

CheckPointReport evaluateCheckPoints(const CalibrationData& data, const MountingParameters& mounting, const VtpOptions& options) {
  CheckPointReport report;
  std::map<std::string, const StripData*> strips;
  for (const StripData& s : data.strips) strips[s.id] = &s;
  std::map<std::string, VtpStrip> built;
  std::map<std::string, std::vector<VirtualTiePoint>> by_tie;
  for (const TieObservation& t : data.ties) {
    auto it = strips.find(t.strip_id);
    if (it == strips.end()) throw InvalidInput("check point '" + t.tie_id + "' names strip '" + t.strip_id + "', which is not in the job");
    auto b = built.find(t.strip_id);
    if (b == built.end()) b = built.emplace(t.strip_id, VtpStrip(*it->second, data.trajectory, data.mounting_used)).first;
    VirtualTiePoint v;
    std::string reason;
    if (b->second.build(t, options, &v, &reason))
      by_tie[t.tie_id].push_back(std::move(v));
    else
      report.rejected.push_back({t.tie_id, t.strip_id, reason});
  }
  const auto m6 = mounting.toArray();
  Vec3 ss = Vec3::Zero();
  for (const auto& [id, vtps] : by_tie) {
    if (vtps.size() < 2) {
      for (const auto& v : vtps) report.rejected.push_back({id, v.stripId(), "the check point has a usable observation on only one strip"});
      continue;
    }
    std::vector<Vec3> P;
    Vec3 mean = Vec3::Zero();
    for (const auto& v : vtps) {
      P.push_back(v.position(m6.data()));  // Rule 2
      mean += P.back();
    }
    mean /= static_cast<double>(P.size());  // seed eq. (7)
    for (std::size_t i = 0; i < P.size(); ++i) {
      report.residuals.push_back({id, vtps[i].stripId(), P[i] - mean});  // seed eq. (8)
      ss += (P[i] - mean).cwiseAbs2();
    }
  }
  if (!report.residuals.empty()) report.rms_m = (ss / static_cast<double>(report.residuals.size())).cwiseSqrt();
  return report;
}

std::vector<CheckPlaneResult> evaluateCheckPlanes(const CalibrationData& data, const std::vector<PlaneRegion>& regions,
                                                  const MountingParameters& mounting) {
  std::vector<CheckPlaneResult> out;
  std::vector<std::vector<Vec3>> pts(regions.size());
  const Mat3 R_bs = mounting.R_bs();
  for (const StripData& s : data.strips) {
    if (s.x_m.size() != s.time_s.size()) throw InvalidInput("strip '" + s.id + "': x_m is needed to select check-plane points");
    std::size_t cursor = 0;
    for (std::size_t i = 0; i < s.time_s.size(); ++i) {
      const Vec3& x0 = s.x_m[i];
      for (std::size_t r = 0; r < regions.size(); ++r) {
        const PlaneRegion& g = regions[r];
        if (x0.x() < g.xmin || x0.x() > g.xmax || x0.y() < g.ymin || x0.y() > g.ymax) continue;
        const Pose pose = data.pose(s, i, &cursor);
        pts[r].push_back(georeference(pose, R_bs, mounting.a_b, s.r_s[i]));
      }
    }
  }
  for (std::size_t r = 0; r < regions.size(); ++r) {
    CheckPlaneResult res;
    res.plane_id = regions[r].id;
    res.points = static_cast<int>(pts[r].size());
    if (pts[r].size() < 4) {
      res.rms_m = std::nan("");
      out.push_back(res);
      continue;
    }
    Vec3 c = Vec3::Zero();
    for (const Vec3& p : pts[r]) c += p;
    c /= static_cast<double>(pts[r].size());
    Mat3 C = Mat3::Zero();
    for (const Vec3& p : pts[r]) C += (p - c) * (p - c).transpose();
    const Eigen::SelfAdjointEigenSolver<Mat3> eig(C);
    // Smallest eigenvalue = Σ d_i² about the least-squares plane; seed eq. (13).
    res.rms_m = std::sqrt(std::max(eig.eigenvalues()(0), 0.0) / static_cast<double>(pts[r].size() - 3));
    out.push_back(res);
  }
  return out;
}

}  // namespace mountcal

// ---- pass-to-pass discrepancy ------------------------------------------------------------------

namespace mountcal {

bool DiscrepancyOptions::IsValid(std::string* why) const {
  auto bad = [&](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (neighbours < 3 || neighbours > 1000) return bad("neighbours must be in [3, 1000]");
  if (!(max_neighbour_distance_m > 0) || !std::isfinite(max_neighbour_distance_m)) return bad("max_neighbour_distance_m must be > 0");
  if (!(max_plane_sigma_m > 0) || !std::isfinite(max_plane_sigma_m)) return bad("max_plane_sigma_m must be > 0");
  if (!(min_spread_ratio >= 0 && min_spread_ratio <= 1)) return bad("min_spread_ratio must be in [0, 1]");
  if (!(max_extent_m > 0) || !std::isfinite(max_extent_m)) return bad("max_extent_m must be > 0");
  if (max_queries < 1) return bad("max_queries must be >= 1");
  return true;
}

DiscrepancyOptions DiscrepancyOptions::forSpacing(double spacing_m) const {
  DiscrepancyOptions o = *this;
  if (!from_spacing || !(spacing_m > 0) || !std::isfinite(spacing_m)) return o;
  const double disc_radius_m = spacing_m * std::sqrt(static_cast<double>(neighbours) / kPi);
  o.max_extent_m = std::max(max_extent_m, 1.5 * disc_radius_m);
  o.max_neighbour_distance_m = std::max(max_neighbour_distance_m, 3.0 * spacing_m);
  return o;
}

namespace {

DiscrepancyStats statsOf(std::vector<double> d, std::size_t queries) {
  DiscrepancyStats s;
  s.queries = queries;
  s.used = d.size();
  if (d.empty()) return s;
  double ss = 0, sa = 0;
  for (double v : d) {
    ss += v * v;
    sa += v;
  }
  s.rms_m = std::sqrt(ss / static_cast<double>(d.size()));
  s.mean_m = sa / static_cast<double>(d.size());
  auto quantile = [&](double q) {
    const std::size_t k = std::min(d.size() - 1, static_cast<std::size_t>(std::floor(q * static_cast<double>(d.size() - 1) + 0.5)));
    std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(k), d.end());
    return d[k];
  };
  s.median_m = quantile(0.5);
  s.p90_m = quantile(0.9);
  return s;
}

/// The mean plan spacing of `points` when `opts` widens its gates with it (0 otherwise: no grid built).
double gateSpacing(const std::vector<Vec3>& points, const DiscrepancyOptions& opts) {
  return opts.from_spacing ? detail::planSpacing(points) : 0.0;
}

/// A used query point: its distance to the reference's local plane, its index in the query
/// strip and the plane's tilt (its normal from the vertical) [deg].
struct Used {
  double d;
  std::size_t q;
  double tilt_deg;
};

std::vector<double> distancesOf(const std::vector<Used>& used) {
  std::vector<double> d(used.size());
  for (std::size_t i = 0; i < used.size(); ++i) d[i] = used[i].d;
  return d;
}

/// The query points examined (every `stride`-th) and used of `query` against `reference`, with
/// the gates of `options` as given (already widened for the reference's spacing:
/// DiscrepancyOptions::forSpacing).
std::vector<Used> distances(const std::vector<Vec3>& query, const std::vector<Vec3>& reference, const DiscrepancyOptions& options,
                            std::size_t* queries, std::size_t* stride_out = nullptr) {
  std::vector<Used> out;
  *queries = 0;
  if (stride_out) *stride_out = 0;
  if (query.empty() || reference.size() < static_cast<std::size_t>(options.neighbours)) return out;
  // Coordinates relative to the reference's first point: kilometre-size values never enter the tree.
  const Vec3 origin = reference.front();
  std::vector<double> ref(3 * reference.size());
  for (std::size_t i = 0; i < reference.size(); ++i) Eigen::Map<Vec3>{&ref[3 * i]} = reference[i] - origin;
  const detail::KdTree<double, 3> tree(ref);
  const std::size_t stride = (query.size() + options.max_queries - 1) / options.max_queries;
  if (stride_out) *stride_out = stride;
  const int k = options.neighbours;
  std::vector<std::size_t> idx(static_cast<std::size_t>(k));
  std::vector<double> dist(static_cast<std::size_t>(k));
  const double max_d2 = options.max_neighbour_distance_m * options.max_neighbour_distance_m;
  const double max_var = options.max_plane_sigma_m * options.max_plane_sigma_m, max_ext2 = options.max_extent_m * options.max_extent_m;
  const double min_ratio2 = options.min_spread_ratio * options.min_spread_ratio;
  for (std::size_t q = 0; q < query.size(); q += stride) {
    ++*queries;
    Vec3 x = query[q] - origin;
    tree.nearest(x.data(), static_cast<std::size_t>(k), idx.data(), dist.data());
    if (dist[0] > max_d2) continue;
    Vec3 c = Vec3::Zero();
    for (int j = 0; j < k; ++j) c += Eigen::Map<const Vec3>(&ref[3 * idx[static_cast<std::size_t>(j)]]);
    c /= k;
    Mat3 C = Mat3::Zero();
    for (int j = 0; j < k; ++j) {
      const Vec3 d = Eigen::Map<const Vec3>(&ref[3 * idx[static_cast<std::size_t>(j)]]) - c;
      C += d * d.transpose();
    }
    C /= k;
    const Eigen::SelfAdjointEigenSolver<Mat3> eig(C);
    const Vec3 lam = eig.eigenvalues().cwiseMax(0.0);
    if (lam(0) > max_var || lam(2) > max_ext2 || lam(1) < min_ratio2 * lam(2)) continue;
    const Vec3 n = eig.eigenvectors().col(0);
    out.push_back({std::abs(n.dot(x - c)), q, rad2deg(std::acos(std::min(1.0, std::abs(n.z()))))});
  }
  return out;
}

}  // namespace

std::vector<Vec3> georeferencedStrip(const CalibrationData& data, const StripData& st, const MountingParameters& m,
                                     const LaserCorrections& lasers) {
  data.requirePoses();
  const Mat3 R_bs = m.R_bs();
  const bool turn = !lasers.empty() && st.laser.size() == st.r_s.size();
  const std::vector<LaserCorrector> correct = laserCorrectors(lasers);
  std::vector<Vec3> x(st.r_s.size());
  std::size_t cursor = 0;
  for (std::size_t i = 0; i < st.r_s.size(); ++i) {
    if (turn && st.laser[i] >= lasers.size())
      throw InvalidInput("strip '" + st.id + "': laser id " + std::to_string(st.laser[i]) + " has no intrinsics");
    const Vec3 r = turn ? correct[st.laser[i]](st.r_s[i]) : st.r_s[i];
    x[i] = georeference(data.pose(st, i, &cursor), R_bs, m.a_b, r);
  }
  return x;
}

std::vector<std::vector<Vec3>> georeferencedStrips(const CalibrationData& data, const MountingParameters& m,
                                                   const LaserCorrections& lasers) {
  data.requirePoses();
  std::vector<std::vector<Vec3>> x;
  for (const StripData& st : data.strips) x.push_back(georeferencedStrip(data, st, m, lasers));
  return x;
}

namespace {

/// Every strip pair of `x`, the smaller strip (q) against the larger (r): f(q, r, used points,
/// queries, stride). Each strip's spacing is found once, not once per pair.
template <typename F>
void forEachPair(const std::vector<std::vector<Vec3>>& x, const DiscrepancyOptions& opts, F&& f) {
  std::vector<double> spacing(x.size());
  for (std::size_t s = 0; s < x.size(); ++s) spacing[s] = gateSpacing(x[s], opts);
  for (std::size_t a = 0; a < x.size(); ++a) {
    for (std::size_t b = a + 1; b < x.size(); ++b) {
      const bool a_smaller = x[a].size() <= x[b].size();
      const std::size_t q = a_smaller ? a : b, r = a_smaller ? b : a;
      std::size_t queries = 0, stride = 0;
      std::vector<Used> used = distances(x[q], x[r], opts.forSpacing(spacing[r]), &queries, &stride);
      f(q, r, std::move(used), queries, stride);
    }
  }
}

/// The classes of DiscrepancyBreakdown from the pairs' examined and used points.
class BreakdownBuilder {
 public:
  explicit BreakdownBuilder(const CalibrationData& data) : data_(data) {
    for (const StripData& s : data.strips) {
      const bool timed = s.time_s.size() == s.r_s.size() && !s.time_s.empty();
      const auto [lo, hi] = timed ? std::minmax_element(s.time_s.begin(), s.time_s.end()) : std::make_pair(s.time_s.end(), s.time_s.end());
      span_.push_back(timed && *hi > *lo ? std::make_pair(*lo, *hi) : std::make_pair(0.0, 0.0));
    }
  }

  /// A pair whose query strip is `strip` (georeferenced: `x`): its examined points (every
  /// `stride`-th of `queries`) and its used ones.
  void add(std::size_t strip, const std::vector<Vec3>& x, const std::vector<Used>& used, std::size_t queries, std::size_t stride) {
    for (std::size_t k = 0; k < queries; ++k) examined_.push_back({strip, k * stride, 0.0, 0.0});
    for (const Used& u : used) {
      used_.push_back({strip, u.q, u.d, u.tilt_deg});
      xy_.emplace_back(x[u.q].x(), x[u.q].y());
    }
  }

  DiscrepancyBreakdown finish() const {
    DiscrepancyBreakdown b;
    // Range classes: bounded at the quintiles of the examined points' ranges.
    std::vector<double> ranges;
    for (const Point& p : examined_) ranges.push_back(range(p));
    std::sort(ranges.begin(), ranges.end());
    std::vector<double> edges;
    for (int i = 1; i < 5 && !ranges.empty(); ++i) edges.push_back(ranges[ranges.size() * static_cast<std::size_t>(i) / 5]);
    auto rangeClass = [&](const Point& p) {
      return static_cast<int>(std::upper_bound(edges.begin(), edges.end(), range(p)) - edges.begin());
    };
    auto rangeLabel = [&](int c) {
      const double lo = c == 0 ? ranges.front() : edges[static_cast<std::size_t>(c) - 1];
      const double hi = c == static_cast<int>(edges.size()) ? ranges.back() : edges[static_cast<std::size_t>(c)];
      char buf[64];
      std::snprintf(buf, sizeof buf, "%.1f-%.1f m", lo, hi);
      return std::string(buf);
    };
    auto placeLabel = [](int c) {
      char buf[64];
      std::snprintf(buf, sizeof buf, "%.1f-%.1f of the pass", 0.1 * c, 0.1 * (c + 1));
      return std::string(buf);
    };
    auto tiltLabel = [](int c) { return std::to_string(15 * c) + "-" + std::to_string(15 * (c + 1)) + " deg"; };
    auto laserOf = [&](const Point& p) -> int {
      const StripData& s = data_.strips[p.strip];
      return s.laser.size() == s.r_s.size() ? static_cast<int>(s.laser[p.index]) : -1;
    };
    b.by_laser = classes(laserOf, [](int c) { return "laser " + std::to_string(c); });
    b.by_place = classes([&](const Point& p) { return place(p); }, placeLabel);
    if (!ranges.empty()) b.by_range = classes(rangeClass, rangeLabel);
    auto tiltClass = [](const Point& p) { return std::min(5, static_cast<int>(p.tilt_deg / 15.0)); };
    b.by_tilt = classes(tiltClass, tiltLabel, false);  // a tilt needs a plane: only used points have one
    b.map = map();
    return b;
  }

 private:
  struct Point {
    std::size_t strip, index;
    double d, tilt_deg;
  };

  double range(const Point& p) const { return data_.strips[p.strip].r_s[p.index].norm(); }

  /// Tenths of the strip's time span (of its record order when every time is the same).
  int place(const Point& p) const {
    const StripData& s = data_.strips[p.strip];
    const auto [lo, hi] = span_[p.strip];
    const double f = hi > lo ? (s.time_s[p.index] - lo) / (hi - lo) : static_cast<double>(p.index) / static_cast<double>(s.r_s.size());
    return std::clamp(static_cast<int>(f * 10.0), 0, 9);
  }

  /// The classes (ids ≥ 0) that `classOf` gives the points, each with its statistics; a class's
  /// queries are its examined points, or its used ones when `examined` is false.
  template <typename C, typename L>
  std::vector<DiscrepancyClass> classes(C classOf, L label, bool examined = true) const {
    std::map<int, std::size_t> queries;
    std::map<int, std::vector<double>> d;
    if (examined)
      for (const Point& p : examined_)
        if (const int c = classOf(p); c >= 0) ++queries[c];
    for (const Point& p : used_) {
      const int c = classOf(p);
      if (c < 0) continue;
      d[c].push_back(p.d);
      if (!examined) ++queries[c];
    }
    std::vector<DiscrepancyClass> out;
    for (const auto& [c, n] : queries) {
      auto it = d.find(c);
      out.push_back({label(c), statsOf(it == d.end() ? std::vector<double>{} : it->second, n)});
    }
    return out;
  }

  /// The used points' medians in plan-view cells (DiscrepancyMap).
  DiscrepancyMap map() const {
    DiscrepancyMap m;
    if (used_.empty()) return m;
    double x0 = xy_[0].first, x1 = x0, y0 = xy_[0].second, y1 = y0;
    for (const auto& [x, y] : xy_) x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
    m.cell_m = std::max(0.05, std::max(x1 - x0, y1 - y0) / DiscrepancyMap::kMaxCells);
    m.nx = std::max(1, static_cast<int>(std::ceil((x1 - x0) / m.cell_m)));
    m.ny = std::max(1, static_cast<int>(std::ceil((y1 - y0) / m.cell_m)));
    m.x0_m = x0, m.y1_m = y1;
    std::vector<std::vector<double>> cells(static_cast<std::size_t>(m.nx) * static_cast<std::size_t>(m.ny));
    std::vector<double> all;
    for (std::size_t k = 0; k < used_.size(); ++k) {
      const int cx = std::min(m.nx - 1, static_cast<int>((xy_[k].first - x0) / m.cell_m));
      const int cy = std::min(m.ny - 1, static_cast<int>((y1 - xy_[k].second) / m.cell_m));
      cells[static_cast<std::size_t>(cy) * static_cast<std::size_t>(m.nx) + static_cast<std::size_t>(cx)].push_back(used_[k].d);
      all.push_back(used_[k].d);
    }
    m.median_m.reserve(cells.size());
    for (std::vector<double>& c : cells) m.median_m.push_back(c.empty() ? NAN : static_cast<float>(statsOf(std::move(c), 0).median_m));
    m.median_all_m = statsOf(std::move(all), 0).median_m;
    return m;
  }

  const CalibrationData& data_;
  std::vector<std::pair<double, double>> span_;  // each strip's time span (0, 0: none)
  std::vector<Point> examined_, used_;
  std::vector<std::pair<double, double>> xy_;  // of each used point, in used_'s order
};

}  // namespace

DiscrepancyStats pointToPlaneDiscrepancy(const std::vector<Vec3>& query, const std::vector<Vec3>& reference,
                                         const DiscrepancyOptions& opts) {
  std::string why;
  if (!opts.IsValid(&why)) throw InvalidInput("discrepancy options: " + why);
  std::size_t queries = 0;
  const std::vector<Used> used = distances(query, reference, opts.forSpacing(gateSpacing(reference, opts)), &queries);
  return statsOf(distancesOf(used), queries);
}

namespace {
/// Every pair with used points; their examined and used points also to `breakdown` when given.
std::vector<PairDiscrepancy> pairsOf(const CalibrationData& data, const MountingParameters& m, const DiscrepancyOptions& opts,
                                     BreakdownBuilder* breakdown) {
  std::string why;
  if (!opts.IsValid(&why)) throw InvalidInput("discrepancy options: " + why);
  std::vector<PairDiscrepancy> out;
  const std::vector<std::vector<Vec3>> x = georeferencedStrips(data, m);
  forEachPair(x, opts, [&](std::size_t q, std::size_t r, std::vector<Used> used, std::size_t queries, std::size_t stride) {
    if (used.empty()) return;
    if (breakdown) breakdown->add(q, x[q], used, queries, stride);
    out.push_back({data.strips[q].id, data.strips[r].id, statsOf(distancesOf(used), queries)});
  });
  return out;
}
}  // namespace

double DiscrepancyMap::at(double x_m, double y_m) const {
  if (empty()) return NAN;
  const double fx = (x_m - x0_m) / cell_m, fy = (y1_m - y_m) / cell_m;
  if (!(fx >= 0 && fy >= 0 && fx < nx && fy < ny)) return NAN;
  return median_m[static_cast<std::size_t>(fy) * static_cast<std::size_t>(nx) + static_cast<std::size_t>(fx)];
}

std::vector<PairDiscrepancy> passDiscrepancies(const CalibrationData& data, const MountingParameters& m, const DiscrepancyOptions& opts) {
  return pairsOf(data, m, opts, nullptr);
}

DiscrepancyReport discrepancyReport(const CalibrationData& data, const MountingParameters& m, const DiscrepancyOptions& opts) {
  DiscrepancyReport out;
  BreakdownBuilder breakdown(data);
  out.pairs = pairsOf(data, m, opts, &breakdown);
  out.breakdown = breakdown.finish();
  return out;
}

DiscrepancyStats pooledDiscrepancy(const CalibrationData& data, const MountingParameters& m, const DiscrepancyOptions& opts) {
  std::string why;
  if (!opts.IsValid(&why)) throw InvalidInput("discrepancy options: " + why);
  std::vector<double> all;
  std::size_t total = 0;
  forEachPair(georeferencedStrips(data, m), opts, [&](std::size_t, std::size_t, std::vector<Used> used, std::size_t queries, std::size_t) {
    for (const Used& u : used) all.push_back(u.d);
    total += queries;
  });
  return statsOf(std::move(all), total);
}

std::vector<DiscrepancyGroupChange> compareBreakdowns(const DiscrepancyBreakdown& before, const DiscrepancyBreakdown& after) {
  struct Group {
    const char* key;
    const char* title;
    std::vector<DiscrepancyClass> DiscrepancyBreakdown::*classes;
  };
  const Group groups[] = {{"by_laser", "laser", &DiscrepancyBreakdown::by_laser},
                          {"by_place", "place along the pass", &DiscrepancyBreakdown::by_place},
                          {"by_range", "range", &DiscrepancyBreakdown::by_range},
                          {"by_tilt", "surface tilt", &DiscrepancyBreakdown::by_tilt}};
  std::vector<DiscrepancyGroupChange> out;
  for (const Group& grp : groups) {
    DiscrepancyGroupChange group;
    group.key = grp.key;
    group.title = grp.title;
    for (const DiscrepancyClass& a : after.*grp.classes) {
      DiscrepancyClassChange c;
      c.label = a.label;
      c.after = a.stats;
      for (const DiscrepancyClass& b : before.*grp.classes)
        if (b.label == a.label) c.in_before = true, c.before = b.stats;
      group.classes.push_back(std::move(c));
    }
    out.push_back(std::move(group));
  }
  return out;
}

}  // namespace mountcal
