#include "mountcal/report/report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "mountcal/report/svg_plot.hpp"

namespace mountcal {

namespace {
std::string esc(const std::string& s) {
  std::string o;
  for (char c : s) o += c == '<' ? "&lt;" : c == '>' ? "&gt;" : c == '&' ? "&amp;" : std::string(1, c);
  return o;
}
std::string f(double v, const char* fmt = "%.4f") {
  if (!std::isfinite(v)) return "—";
  char b[64];
  std::snprintf(b, sizeof b, fmt, v);
  return b;
}

/// One discrepancy map as an SVG (north up), each cell coloured by the class of its median.
std::string mapSvg(const DiscrepancyMap& m, const std::vector<double>& t) {
  if (m.empty()) return "<p>no used point</p>";
  auto median = [&m](int x, int y) {
    return static_cast<double>(m.median_m[static_cast<std::size_t>(y) * static_cast<std::size_t>(m.nx) + static_cast<std::size_t>(x)]);
  };
  return svgClassedGrid(m.nx, m.ny, median, t);
}

/// "Where the discrepancy lies": one table per group of the breakdown, before and after by class,
/// and the map of the residual discrepancy beside the one before.
void breakdownHtml(const DiscrepancyBreakdown& before, const DiscrepancyBreakdown& after, std::ostringstream& h) {
  h << "<h3>Where the discrepancy lies</h3><p>The used points of every pair, classed by the laser that measured them, their "
       "place along their pass, their range and the tilt of the reference surface (its normal from the vertical); |distance| [m].</p>";
  for (const DiscrepancyGroupChange& g : compareBreakdowns(before, after)) {
    if (g.classes.empty()) continue;
    h << "<table><tr><th>by " << esc(g.title) << "</th><th>points</th><th>used</th><th>median before</th><th>median after</th>"
      << "<th>P90 before</th><th>P90 after</th></tr>";
    for (const DiscrepancyClassChange& c : g.classes)
      h << "<tr><td class=l>" << esc(c.label) << "</td><td>" << c.after.queries << "</td><td>" << c.after.used << "</td><td>"
        << f(c.before.median_m) << "</td><td>" << f(c.after.median_m) << "</td><td>" << f(c.before.p90_m) << "</td><td>" << f(c.after.p90_m)
        << "</td></tr>";
    h << "</table>";
  }
  if (after.map.empty()) return;
  // One colour scale for both maps: 1, 2 and 4 times the median after.
  const double m = after.map.median_all_m;
  const std::vector<double> t{m, 2 * m, 4 * m};
  h << "<h3>Map of the discrepancy</h3><p>Plan view, north up: the median |distance| of the used points in each cell ("
    << f(after.map.cell_m, "%.2f") << " m after, " << f(before.map.cell_m, "%.2f") << " m before); green ≤ " << f(t[0])
    << " m (the median after), yellow ≤ " << f(t[1]) << " m, orange ≤ " << f(t[2]) << " m, red beyond; grey: no used point.</p>"
    << "<table><tr><th>before</th><th>after</th></tr><tr><td>" << mapSvg(before.map, t) << "</td><td>" << mapSvg(after.map, t)
    << "</td></tr></table>";
}
}  // namespace

std::string htmlReport(const MountingCalibrator::Summary& summary, const ResultEvaluation* ev, const std::string& title) {
  std::ostringstream h;
  h << "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>" << esc(title) << "</title><style>"
    << "body{font-family:sans-serif;margin:2em;max-width:1100px}table{border-collapse:collapse;margin:1em 0}"
    << "td,th{border:1px solid #ccc;padding:3px 8px;text-align:right}th{background:#f0f0f0}"
    << ".ok{color:#070}.bad{color:#a00}td.l{text-align:left}</style></head><body>";
  h << "<h1>" << esc(title) << "</h1>";
  h << "<p>Termination: <b class=\"" << (summary.IsSolutionUsable() ? "ok" : "bad") << "\">" << toString(summary.termination) << "</b> — "
    << esc(summary.message) << "<br>" << summary.iterations << " iterations, cost " << f(summary.initial_cost, "%.5g") << " → "
    << f(summary.final_cost, "%.5g") << ", " << f(summary.time_s, "%.3f")
    << " s; variance factor σ₀² = " << f(summary.variance_factor, "%.3g") << " (" << summary.degrees_of_freedom
    << " degrees of freedom)</p>";
  h << "<h2>Mounting</h2><table><tr><th>parameter</th><th>used</th><th>calibrated</th><th>σ</th><th>formal σ</th><th>status</th></tr>";
  const auto& names = mountingParameterNames();
  const auto used = summary.mounting_used.toArray(), est = summary.mounting.toArray();
  for (int j = 0; j < 6; ++j) {
    const bool lin = j < 3;
    const double k = lin ? 1.0 : 180.0 / kPi;
    const char* unit = lin ? " m" : "°";
    const bool unobs = std::find(summary.unobservable.begin(), summary.unobservable.end(), names[j]) != summary.unobservable.end();
    h << "<tr><td class=l>" << names[j] << "</td><td>" << f(used[j] * k, "%+.5f") << unit << "</td><td>" << f(est[j] * k, "%+.5f") << unit
      << "</td><td>" << (summary.estimated[j] ? f(summary.sigma[j] * k, "%.5f") + unit : "—") << "</td><td>"
      << (summary.estimated[j] ? f(summary.formal_sigma[j] * k, "%.5f") + unit : "—") << "</td><td class=l>"
      << (summary.estimated[j] ? "estimated"
          : unobs              ? "<span class=bad>undeterminable</span>"
                               : "held fixed")
      << "</td></tr>";
  }
  h << "</table><p>σ: " << esc(summary.sigma_model)
    << (summary.sigma_model == "formal" ? "" : " (the stated trajectory accuracy; the formal σ take the observations as independent)")
    << ".</p>";
  if (!summary.observability_report.empty()) h << "<h2>Observability</h2><pre>" << esc(summary.observability_report) << "</pre>";
  h << "<p>Condition number of the estimated block (normalised): " << f(summary.condition_number, "%.3g") << "</p>";
  h << "<h2>Correlations</h2><table><tr><th></th>";
  for (int j = 0; j < 6; ++j) h << "<th>" << j << "</th>";
  h << "</tr>";
  for (int a = 0; a < 6; ++a) {
    h << "<tr><td class=l>" << a << " " << names[a] << "</td>";
    for (int b = 0; b < 6; ++b) {
      const double c = summary.correlation(a, b);
      h << "<td" << (a != b && std::abs(c) > 0.9 ? " class=bad" : "") << ">" << f(c, "%+.3f") << "</td>";
    }
    h << "</tr>";
  }
  h << "</table>";
  // ---- one section per kind of observation ----------------------------------------------------
  h << "<p>Methods: " << esc([&] {
    std::string m;
    for (const auto& x : summary.methods) m += (m.empty() ? "" : " + ") + x;
    return m;
  }())
    << ". Observations per kind:";
  for (const auto& k : summary.kinds) {
    h << " " << esc(k.kind) << " " << k.blocks << " blocks (" << k.residuals << " residuals";
    if (k.covariance_scale < 1.0) h << "; σ of a distance from the residuals, σ₀² " << f(k.variance_factor, "%.3g");
    h << ");";
  }
  h << "</p>";
  for (const auto& section : summary.sections) h << section->html(summary);
  if (ev) {
    h << "<h2>Check data (seed Tables 2 and 3)</h2>";
    if (ev->has_check_points) {
      const Vec3 b = ev->check_points_before.rms_m, a = ev->check_points_after.rms_m;
      h << "<p>Check points (" << ev->check_points_after.residuals.size() << " observations): RMS before (" << f(b.x()) << ", " << f(b.y())
        << ", " << f(b.z()) << ") m, after (" << f(a.x()) << ", " << f(a.y()) << ", " << f(a.z()) << ") m</p>";
    }
    if (!ev->check_planes_after.empty()) {
      h << "<table><tr><th>plane</th><th>points</th><th>RMS before [m]</th><th>RMS after [m]</th></tr>";
      for (std::size_t i = 0; i < ev->check_planes_after.size(); ++i) {
        h << "<tr><td class=l>" << esc(ev->check_planes_after[i].plane_id) << "</td><td>" << ev->check_planes_after[i].points << "</td><td>"
          << f(ev->check_planes_before[i].rms_m) << "</td><td>" << f(ev->check_planes_after[i].rms_m) << "</td></tr>";
      }
      h << "</table>";
    }
    if (!ev->discrepancy_after.empty()) {
      h << "<p>Pass-to-pass discrepancy: each point of the smaller strip against the local plane of the larger one "
           "(DiscrepancyOptions defaults), |distance| [m]:</p><table><tr><th>query / reference</th><th>points</th><th>used</th>"
           "<th>median before</th><th>median after</th><th>RMS before</th><th>RMS after</th><th>P90 before</th><th>P90 after</th></tr>";
      for (const PairDiscrepancy& a : ev->discrepancy_after) {
        DiscrepancyStats b;
        for (const PairDiscrepancy& x : ev->discrepancy_before)
          if (x.query == a.query && x.reference == a.reference) b = x.stats;
        h << "<tr><td class=l>" << esc(a.query) << " / " << esc(a.reference) << "</td><td>" << a.stats.queries << "</td><td>"
          << a.stats.used << "</td><td>" << f(b.median_m) << "</td><td>" << f(a.stats.median_m) << "</td><td>" << f(b.rms_m) << "</td><td>"
          << f(a.stats.rms_m) << "</td><td>" << f(b.p90_m) << "</td><td>" << f(a.stats.p90_m) << "</td></tr>";
      }
      h << "</table>";
      breakdownHtml(ev->breakdown_before, ev->breakdown_after, h);
    }
  }
  h << "<pre>" << esc(summary.FullReport()) << "</pre></body></html>\n";
  return h.str();
}

}  // namespace mountcal
