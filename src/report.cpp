#include "mountcal/report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "mountcal/svg_plot.hpp"

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
}  // namespace

std::string htmlReport(const MountingCalibrator::Summary& S, const ResultEvaluation* ev, const std::string& title) {
  std::ostringstream h;
  h << "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>" << esc(title) << "</title><style>"
    << "body{font-family:sans-serif;margin:2em;max-width:1100px}table{border-collapse:collapse;margin:1em 0}"
    << "td,th{border:1px solid #ccc;padding:3px 8px;text-align:right}th{background:#f0f0f0}"
    << ".ok{color:#070}.bad{color:#a00}td.l{text-align:left}</style></head><body>";
  h << "<h1>" << esc(title) << "</h1>";
  h << "<p>Termination: <b class=\"" << (S.IsSolutionUsable() ? "ok" : "bad") << "\">" << toString(S.termination)
    << "</b> — " << esc(S.message) << "<br>" << S.iterations << " iterations, cost " << f(S.initial_cost, "%.5g") << " → "
    << f(S.final_cost, "%.5g") << ", " << f(S.time_s, "%.3f") << " s; " << S.ties_used << " ties, " << S.observations_used
    << " observations, " << S.rejected.size() << " rejected; variance factor σ₀² = " << f(S.variance_factor, "%.3g")
    << " (" << S.degrees_of_freedom << " degrees of freedom)</p>";
  h << "<h2>Mounting</h2><table><tr><th>parameter</th><th>used</th><th>calibrated</th><th>σ</th><th>status</th></tr>";
  const auto& names = mountingParameterNames();
  const auto used = S.mounting_used.toArray(), est = S.mounting.toArray();
  for (int j = 0; j < 6; ++j) {
    const bool lin = j < 3;
    const double k = lin ? 1.0 : 180.0 / kPi;
    const char* unit = lin ? " m" : "°";
    const bool unobs = std::find(S.unobservable.begin(), S.unobservable.end(), names[j]) != S.unobservable.end();
    h << "<tr><td class=l>" << names[j] << "</td><td>" << f(used[j] * k, "%+.5f") << unit << "</td><td>" << f(est[j] * k, "%+.5f")
      << unit << "</td><td>" << (S.estimated[j] ? f(S.sigma[j] * k, "%.5f") + unit : "—") << "</td><td class=l>"
      << (S.estimated[j] ? "estimated" : unobs ? "<span class=bad>undeterminable</span>" : "held fixed") << "</td></tr>";
  }
  h << "</table>";
  if (!S.observability_report.empty()) h << "<h2>Observability</h2><pre>" << esc(S.observability_report) << "</pre>";
  h << "<p>Condition number of the estimated block (normalised): " << f(S.condition_number, "%.3g") << "</p>";
  h << "<h2>Correlations</h2><table><tr><th></th>";
  for (int j = 0; j < 6; ++j) h << "<th>" << j << "</th>";
  h << "</tr>";
  for (int a = 0; a < 6; ++a) {
    h << "<tr><td class=l>" << a << " " << names[a] << "</td>";
    for (int b = 0; b < 6; ++b) {
      const double c = S.correlation(a, b);
      h << "<td" << (a != b && std::abs(c) > 0.9 ? " class=bad" : "") << ">" << f(c, "%+.3f") << "</td>";
    }
    h << "</tr>";
  }
  h << "</table>";
  // ---- one section per kind of observation ----------------------------------------------------
  h << "<p>Methods: " << esc([&] {
    std::string m;
    for (const auto& x : S.methods) m += (m.empty() ? "" : " + ") + x;
    return m;
  }()) << ". Observations per kind:";
  for (const auto& k : S.kinds) h << " " << esc(k.kind) << " " << k.blocks << " blocks (" << k.residuals << " residuals);";
  h << "</p>";
  if (S.uses(CalibrationMethod::kPlanes)) {
    const PlaneSection& p = S.planes;
    h << "<h2>Plane patches (" << (p.automatic ? "found automatically" : "given regions") << ")</h2><p>" << p.patches_used
      << " patches, " << p.points_used << " points, σ of a point-to-plane distance " << f(p.sigma_m) << " m; RMS before "
      << f(p.rms_before_m) << " m, after " << f(p.rms_after_m) << " m</p>";
    std::vector<double> idx, b, a;
    for (std::size_t i = 0; i < p.patches.size(); ++i) {
      idx.push_back(static_cast<double>(i + 1));
      b.push_back(p.patches[i].rms_before_m);
      a.push_back(p.patches[i].rms_after_m);
    }
    if (!idx.empty()) {
      SvgLinePlot plot("RMS distance to the patch's plane, per patch", "patch", "RMS [m]");
      plot.addSeries("before", idx, b);
      plot.addSeries("after", idx, a);
      h << plot.render(900, 320);
    }
    h << "<table><tr><th>patch</th><th>strips</th><th>points</th><th>tilt [°]</th><th>aspect [°]</th><th>RMS before [m]</th>"
         "<th>RMS after [m]</th><th></th></tr>";
    for (const PatchResidual& r : p.patches) {
      const double tilt = std::acos(std::min(1.0, std::abs(r.normal.z()))) * 180.0 / kPi;
      const double aspect = std::fmod(std::atan2(r.normal.x(), r.normal.y()) * 180.0 / kPi + 360.0, 360.0);
      h << "<tr><td class=l>" << esc(r.patch_id) << "</td><td>" << r.strips << "</td><td>" << r.points << "</td><td>" << f(tilt, "%.1f")
        << "</td><td>" << f(aspect, "%.1f") << "</td><td>" << f(r.rms_before_m) << "</td><td>" << f(r.rms_after_m) << "</td><td class=l>"
        << (r.outlier ? "<span class=bad>outlier</span>" : "") << "</td></tr>";
    }
    h << "</table>";
    if (!p.rejected.empty()) {
      h << "<details><summary>" << p.rejected.size() << " patches or strip parts rejected</summary><table><tr><th>patch</th><th>strip</th><th>reason</th></tr>";
      for (const RejectedPatch& r : p.rejected)
        h << "<tr><td class=l>" << esc(r.patch_id) << "</td><td class=l>" << esc(r.strip_id) << "</td><td class=l>" << esc(r.reason) << "</td></tr>";
      h << "</table></details>";
    }
  }
  if (S.uses(CalibrationMethod::kCorrespondences)) {
    const CorrespondenceSection& c = S.correspondences;
    h << "<h2>Automatic correspondences</h2><p>" << c.used << " point-to-plane correspondences after " << c.rounds
      << " matchings (r " << f(c.radius_m, "%.2f") << " m, point spacing " << f(c.spacing_m, "%.2f") << " m, σ " << f(c.sigma_m)
      << " m); |distance| median " << f(c.median_before_m) << " → " << f(c.median_after_m) << " m, RMS " << f(c.rms_before_m) << " → "
      << f(c.rms_after_m) << " m</p>";
    h << "<table><tr><th>strips</th><th>samples</th><th>kept</th><th>sparse</th><th>rough</th><th>far</th><th>normals</th><th>MAD</th>"
         "<th>budget</th><th>median before [m]</th><th>median after [m]</th><th>RMS before [m]</th><th>RMS after [m]</th></tr>";
    for (const auto& p : c.pairs) {
      h << "<tr><td class=l>" << esc(p.strip_a) << " / " << esc(p.strip_b) << "</td><td>" << p.samples << "</td><td>" << p.kept << "</td><td>"
        << p.rejected_sparse << "</td><td>" << p.rejected_rough << "</td><td>" << p.rejected_far << "</td><td>" << p.rejected_normal
        << "</td><td>" << p.rejected_mad << "</td><td>" << p.rejected_budget << "</td><td>" << f(p.median_before_m) << "</td><td>"
        << f(p.median_after_m) << "</td><td>" << f(p.rms_before_m) << "</td><td>" << f(p.rms_after_m) << "</td></tr>";
    }
    h << "</table>";
  }
  if (S.uses(CalibrationMethod::kFeatures)) {
    const FeatureSection& F = S.features;
    h << "<h2>High-intensity targets (the second paper's feature matching)</h2><p>" << F.targets_used << " targets, " << F.views_used
      << " strip views; centroid RMS before (" << f(F.rms_before_m.x()) << ", " << f(F.rms_before_m.y()) << ", " << f(F.rms_before_m.z())
      << ") m, after (" << f(F.rms_after_m.x()) << ", " << f(F.rms_after_m.y()) << ", " << f(F.rms_after_m.z()) << ") m</p>";
    const FeatureClosedForm& C = F.closed_form;
    if (C.valid) {
      const Vec3 cb = C.mounting.boresightDeg(), rb = S.mounting.boresightDeg();
      h << "<table><tr><th>angle</th><th>closed form [°]</th><th>σ [°]</th><th>spread of the pairs [°]</th><th>pairs</th><th>rigorous [°]</th>"
           "<th>rigorous σ [°]</th></tr>";
      const char* names[3] = {"roll", "pitch", "heading"};
      for (int a = 0; a < 3; ++a) {
        h << "<tr><td class=l>" << names[a] << "</td><td>" << f(cb(a), "%+.5f") << "</td><td>" << f(C.boresight_sigma_rad(a) * 180.0 / kPi, "%.5f")
          << "</td><td>" << f(C.boresight_spread_rad(a) * 180.0 / kPi, "%.5f") << "</td><td>" << C.pairs_used[a] << "</td><td>" << f(rb(a), "%+.5f")
          << "</td><td>" << f(S.sigma[3 + a] * 180.0 / kPi, "%.5f") << "</td></tr>";
      }
      h << "</table>";
    }
    if (!C.message.empty()) h << "<p class=bad>Closed form: " << esc(C.message) << "</p>";
    h << "<table><tr><th>target</th><th>A / B</th><th>relation</th><th>H [m]</th><th>y<sub>A</sub> [m]</th><th>D [m]</th>"
         "<th>Δ along [m]</th><th>Δ cross [m]</th><th>Δ down [m]</th><th>ICP RMS [m]</th></tr>";
    for (const FeaturePairOffset& p : F.pairs) {
      h << "<tr><td class=l>" << esc(p.target_id) << "</td><td class=l>" << esc(p.strip_a) << " / " << esc(p.strip_b) << "</td><td class=l>"
        << esc(p.relation) << "</td><td>" << f(p.height_m, "%.2f") << "</td><td>" << f(p.lateral_a_m, "%.2f") << "</td><td>"
        << f(p.line_offset_m, "%.2f") << "</td><td>" << f(p.offset_afd_m.x()) << "</td><td>" << f(p.offset_afd_m.y()) << "</td><td>"
        << f(p.offset_afd_m.z()) << "</td><td>" << f(p.icp_rms_m) << "</td></tr>";
    }
    h << "</table>";
    if (!F.rejected.empty()) {
      h << "<details open><summary>" << F.rejected.size() << " targets or strip views rejected</summary><table><tr><th>target</th><th>strip</th><th>reason</th></tr>";
      for (const RejectedFeature& r : F.rejected)
        h << "<tr><td class=l>" << esc(r.target_id) << "</td><td class=l>" << esc(r.strip_id) << "</td><td class=l>" << esc(r.reason) << "</td></tr>";
      h << "</table></details>";
    }
  }
  if (S.control.observations_used > 0) {
    const Vec3 b = S.control.rms_before_m, a = S.control.rms_after_m;
    h << "<h2>Ground control</h2><p>" << S.control.ties_used << " control points, " << S.control.observations_used
      << " point-to-surface observations; RMS before (" << f(b.x()) << ", " << f(b.y()) << ", " << f(b.z()) << ") m, after (" << f(a.x())
      << ", " << f(a.y()) << ", " << f(a.z()) << ") m</p>";
  }
  if (S.uses(CalibrationMethod::kVtpm)) {
  h << "<h2>Tie residuals (seed Table 1)</h2><p>RMS before (" << f(S.rms_before_m.x()) << ", " << f(S.rms_before_m.y()) << ", "
    << f(S.rms_before_m.z()) << ") m, after (" << f(S.rms_after_m.x()) << ", " << f(S.rms_after_m.y()) << ", " << f(S.rms_after_m.z())
    << ") m</p>";
  std::vector<double> idx, bh, ah, bv, av;
  for (std::size_t i = 0; i < S.residuals.size(); ++i) {
    const auto& r = S.residuals[i];
    idx.push_back(static_cast<double>(i + 1));
    bh.push_back(r.before_m.head<2>().norm());
    ah.push_back(r.after_m.head<2>().norm());
    bv.push_back(std::abs(r.before_m.z()));
    av.push_back(std::abs(r.after_m.z()));
  }
  SvgLinePlot plot("Residual size per tie observation", "observation", "residual [m]");
  plot.addSeries("horizontal, before", idx, bh);
  plot.addSeries("horizontal, after", idx, ah);
  plot.addSeries("vertical, before", idx, bv);
  plot.addSeries("vertical, after", idx, av);
  h << plot.render(900, 360);
  h << "<table><tr><th>tie</th><th>strip</th><th>dX before</th><th>dY before</th><th>dZ before</th><th>dX after</th><th>dY after</th><th>dZ after</th><th></th></tr>";
  for (const auto& r : S.residuals) {
    h << "<tr><td class=l>" << esc(r.tie_id) << "</td><td class=l>" << esc(r.strip_id) << "</td>";
    for (int a = 0; a < 3; ++a) h << "<td>" << f(r.before_m[a], "%+.3f") << "</td>";
    for (int a = 0; a < 3; ++a) h << "<td>" << f(r.after_m[a], "%+.3f") << "</td>";
    h << "<td class=l>" << (r.outlier ? "<span class=bad>outlier</span>" : "") << "</td></tr>";
  }
  h << "</table>";
  if (!S.rejected.empty()) {
    h << "<h2>Rejected tie observations</h2><table><tr><th>tie</th><th>strip</th><th>reason</th></tr>";
    for (const auto& r : S.rejected) h << "<tr><td class=l>" << esc(r.tie_id) << "</td><td class=l>" << esc(r.strip_id) << "</td><td class=l>" << esc(r.reason) << "</td></tr>";
    h << "</table>";
  }
  }
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
        h << "<tr><td class=l>" << esc(a.query) << " / " << esc(a.reference) << "</td><td>" << a.stats.queries << "</td><td>" << a.stats.used
          << "</td><td>" << f(b.median_m) << "</td><td>" << f(a.stats.median_m) << "</td><td>" << f(b.rms_m) << "</td><td>"
          << f(a.stats.rms_m) << "</td><td>" << f(b.p90_m) << "</td><td>" << f(a.stats.p90_m) << "</td></tr>";
      }
      h << "</table>";
    }
  }
  h << "<pre>" << esc(S.FullReport()) << "</pre></body></html>\n";
  return h.str();
}

}  // namespace mountcal
