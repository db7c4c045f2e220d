// The planner's HTML report: one self-contained page (inline SVG, no scripts, no network).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

#include "mountcal/plan/planner.hpp"
#include "mountcal/report/svg_plot.hpp"
#include "report/html_text.hpp"

namespace mountcal::plan {

namespace {

std::string sigmaCell(int j, double s) {
  if (!std::isfinite(s)) return "—";
  return j < 3 ? detail::formatNumber(s, "%.4f m") : detail::formatNumber(rad2deg(s), "%.5f°");
}

/// Plan view: footprints, lines with their direction, roofs, targets, ground control; the
/// lines of `extra` (a suggestion) dashed.
std::string planView(const Plan& plan, const Plan* extra) {
  static const char* kColours[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22"};
  const Plan& all = extra ? *extra : plan;
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
  auto grow = [&](double x, double y, double r) {
    x0 = std::min(x0, x - r), x1 = std::max(x1, x + r), y0 = std::min(y0, y - r), y1 = std::max(y1, y + r);
  };
  for (const PlannedLine& l : all.lines) {
    const double w = 0.5 * swathWidth(all.survey, l.height_m);
    grow(l.x0_m, l.y0_m, w);
    grow(l.x1_m, l.y1_m, w);
  }
  for (const auto& r : all.roofs) grow(r.x_m, r.y_m, r.size_m);
  for (const auto& t : all.targets) grow(t.x_m, t.y_m, t.size_m);
  const double W = 760, margin = 30;
  const double scale = (W - 2 * margin) / std::max({x1 - x0, y1 - y0, 1.0});
  const double H = (y1 - y0) * scale + 2 * margin + 30;
  auto X = [&](double x) { return margin + (x - x0) * scale; };
  auto Y = [&](double y) { return margin + (y1 - y) * scale; };
  std::ostringstream o;
  o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << W << "\" height=\"" << detail::formatNumber(H, "%.0f") << "\" viewBox=\"0 0 "
    << W << " " << detail::formatNumber(H, "%.0f") << "\" font-family=\"sans-serif\" font-size=\"12\" class=\"planview\">"
    << "<defs><marker id=\"arrow\" viewBox=\"0 0 10 10\" refX=\"9\" refY=\"5\" markerWidth=\"7\" markerHeight=\"7\" orient=\"auto\">"
    << "<path d=\"M0,0 L10,5 L0,10 z\" fill=\"#333\"/></marker></defs>"
    << "<rect x=\"0\" y=\"0\" width=\"" << W << "\" height=\"" << detail::formatNumber(H, "%.0f") << "\" fill=\"#fafafa\"/>";
  for (std::size_t i = 0; i < all.lines.size(); ++i) {
    const PlannedLine& l = all.lines[i];
    const bool added = i >= plan.lines.size();
    const double len = std::hypot(l.x1_m - l.x0_m, l.y1_m - l.y0_m);
    const double rx = (l.y1_m - l.y0_m) / len, ry = -(l.x1_m - l.x0_m) / len, w = 0.5 * swathWidth(all.survey, l.height_m);
    const char* col = added ? "#ff7f0e" : kColours[i % 8];
    o << "<polygon points=\"" << detail::formatNumber(X(l.x0_m - w * rx)) << "," << detail::formatNumber(Y(l.y0_m - w * ry)) << " "
      << detail::formatNumber(X(l.x1_m - w * rx)) << "," << detail::formatNumber(Y(l.y1_m - w * ry)) << " "
      << detail::formatNumber(X(l.x1_m + w * rx)) << "," << detail::formatNumber(Y(l.y1_m + w * ry)) << " "
      << detail::formatNumber(X(l.x0_m + w * rx)) << "," << detail::formatNumber(Y(l.y0_m + w * ry)) << "\" fill=\"" << col
      << "\" fill-opacity=\"0.12\" stroke=\"" << col << "\" stroke-opacity=\"0.5\"" << (added ? " stroke-dasharray=\"6 4\"" : "") << "/>";
    o << "<line x1=\"" << detail::formatNumber(X(l.x0_m)) << "\" y1=\"" << detail::formatNumber(Y(l.y0_m)) << "\" x2=\""
      << detail::formatNumber(X(l.x1_m)) << "\" y2=\"" << detail::formatNumber(Y(l.y1_m)) << "\" stroke=\"" << col
      << "\" stroke-width=\"2\" marker-end=\"url(#arrow)\"" << (added ? " stroke-dasharray=\"8 5\"" : "") << "/>";
    o << "<text x=\"" << detail::formatNumber(X(l.x0_m) + 4) << "\" y=\"" << detail::formatNumber(Y(l.y0_m) - 4) << "\" fill=\"" << col
      << "\">" << detail::htmlEscape(l.id) << " (" << detail::formatNumber(l.height_m, "%.0f") << " m)</text>";
  }
  for (const auto& r : all.roofs) {
    const double s = std::max(r.size_m * scale, 4.0);
    o << "<rect x=\"" << detail::formatNumber(X(r.x_m) - s / 2) << "\" y=\"" << detail::formatNumber(Y(r.y_m) - s / 2) << "\" width=\""
      << detail::formatNumber(s) << "\" height=\"" << detail::formatNumber(s) << "\" fill=\"#8c564b\" transform=\"rotate("
      << detail::formatNumber(r.aspect_deg) << " " << detail::formatNumber(X(r.x_m)) << " " << detail::formatNumber(Y(r.y_m))
      << ")\"><title>roof " << detail::htmlEscape(r.id) << ": slope " << detail::formatNumber(r.slope_deg) << "°, aspect "
      << detail::formatNumber(r.aspect_deg) << "°</title></rect>";
  }
  for (const auto& t : all.targets) {
    const double s = std::max(t.size_m * scale, 4.0);
    o << "<rect x=\"" << detail::formatNumber(X(t.x_m) - s / 2) << "\" y=\"" << detail::formatNumber(Y(t.y_m) - s / 2) << "\" width=\""
      << detail::formatNumber(s) << "\" height=\"" << detail::formatNumber(s) << "\" fill=\"#111\"><title>target "
      << detail::htmlEscape(t.id) << "</title></rect>";
  }
  const simulation::Scene scene = all.buildScene();
  for (const PlannedGcp& g : all.gcps)
    for (const auto& f : scene.features())
      if (f.id == g.feature_id) {
        const double x = X(f.x_m.x()), y = Y(f.x_m.y());
        o << "<polygon points=\"" << detail::formatNumber(x) << "," << detail::formatNumber(y - 8) << " " << detail::formatNumber(x - 7)
          << "," << detail::formatNumber(y + 5) << " " << detail::formatNumber(x + 7) << "," << detail::formatNumber(y + 5)
          << "\" fill=\"none\" stroke=\"#2ca02c\" stroke-width=\"2\"><title>ground control " << detail::htmlEscape(f.id)
          << "</title></polygon>";
      }
  // Scale bar: a round length near a fifth of the width.
  const double target = (x1 - x0) / 5;
  const double mag = std::pow(10.0, std::floor(std::log10(std::max(target, 1.0))));
  const double bar = (target / mag < 2 ? 1 : target / mag < 5 ? 2 : 5) * mag;
  o << "<line x1=\"" << margin << "\" y1=\"" << detail::formatNumber(H - 15) << "\" x2=\"" << detail::formatNumber(margin + bar * scale)
    << "\" y2=\"" << detail::formatNumber(H - 15) << "\" stroke=\"#000\" stroke-width=\"3\"/><text x=\""
    << detail::formatNumber(margin + bar * scale + 6) << "\" y=\"" << detail::formatNumber(H - 11) << "\">"
    << detail::formatNumber(bar, "%.0f") << " m</text><text x=\"" << detail::formatNumber(W - margin) << "\" y=\""
    << detail::formatNumber(H - 11) << "\" text-anchor=\"end\">N ↑ · footprints shaded · ▲ ground control · ■ targets, roofs</text></svg>";
  return o.str();
}

}  // namespace

std::string planReportHtml(const Plan& plan, const PlanAnalysis& a) {
  const auto& names = mountingParameterNames();
  const Prediction& p = a.base;
  std::ostringstream h;
  h << "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>mountcal plan — " << detail::htmlEscape(plan.name) << "</title><style>"
    << "body{font-family:sans-serif;margin:2em;max-width:1100px}table{border-collapse:collapse;margin:1em 0}"
    << "td,th{border:1px solid #ccc;padding:3px 8px;text-align:right}th{background:#f0f0f0}td.l{text-align:left}"
    << ".bad{color:#a00}.ok{color:#070}.warn{background:#fff4e0;border-left:4px solid #e69500;padding:6px 10px}"
    << "@media print{body{margin:0}}</style></head><body>";
  h << "<h1>Calibration flight plan — " << detail::htmlEscape(plan.name) << "</h1>";
  h << "<p>" << plan.lines.size() << " lines, " << plan.roofs.size() << " roofs, " << plan.targets.size() << " targets, "
    << plan.gcps.size() << " ground control points; methods:";
  for (const std::string& m : plan.options.methods) h << " " << m;
  h << ". Predicted from a simulation of the plan without noise and the adjustment at the truth with the plan's "
       "stochastic model ("
    << p.strips << " strips, " << p.observations << " observation blocks, " << detail::formatNumber(p.seconds, "%.1f") << " s).</p>";
  h << "<h2>Plan view</h2>" << planView(plan, a.suggestions.empty() ? nullptr : &a.suggestions.front().plan);
  if (!a.suggestions.empty())
    h << "<p>Dashed, orange: the best addition (" << detail::htmlEscape(a.suggestions.front().description) << ").</p>";
  h << "<h2>What the plan determines</h2><table><tr><th>parameter</th><th>determined</th><th>predicted σ</th></tr>";
  for (int j = 0; j < 6; ++j) {
    const bool undet = std::find(p.undeterminable.begin(), p.undeterminable.end(), names[j]) != p.undeterminable.end();
    h << "<tr><td class=l>" << names[j] << "</td><td class=l>"
      << (p.determined[j] ? "<span class=ok>yes</span>"
          : undet         ? "<span class=bad>undeterminable</span>"
                          : "held fixed")
      << "</td><td>" << (p.determined[j] ? sigmaCell(j, p.sigma[j]) : "—") << "</td></tr>";
  }
  h << "</table><p>Condition number of the determined block: " << detail::formatNumber(p.condition_number, "%.3g") << "</p>";
  std::vector<std::string> warnings;
  for (const auto& u : p.undeterminable) warnings.push_back(u + " cannot be determined by this plan");
  for (int x = 0; x < 6; ++x)
    for (int y = x + 1; y < 6; ++y)
      if (p.determined[x] && p.determined[y] && std::abs(p.correlation(x, y)) > 0.9)
        warnings.push_back(names[x] + " and " + names[y] + " are strongly correlated (" +
                           detail::formatNumber(p.correlation(x, y), "%+.3f") + ")");
  for (const auto& w : warnings) h << "<p class=warn>" << detail::htmlEscape(w) << "</p>";
  if (!p.observability.empty()) h << "<pre>" << detail::htmlEscape(p.observability) << "</pre>";
  h << "<h2>Correlations</h2>";
  std::vector<std::string> labels(names.begin(), names.end());
  std::vector<double> c(36);
  for (int x = 0; x < 6; ++x)
    for (int y = 0; y < 6; ++y) c[static_cast<std::size_t>(6 * x + y)] = p.correlation(x, y);
  h << svgCorrelationHeatMap(labels, c);
  if (!a.suggestions.empty() && p.weakest >= 0) {
    h << "<h2>What to add</h2><p>Weakest parameter: <b>" << names[p.weakest] << "</b>"
      << (p.determined[p.weakest] ? " (σ " + sigmaCell(p.weakest, p.sigma[p.weakest]) + ")" : std::string(" (undeterminable)"))
      << ". Each candidate addition simulated and adjusted; best first.</p><table><tr><th>#</th><th>addition</th><th>σ of "
      << names[p.weakest] << "</th><th>still undeterminable</th></tr>";
    int k = 1;
    for (const Suggestion& s : a.suggestions) {
      std::string u;
      for (const auto& x : s.prediction.undeterminable) u += (u.empty() ? "" : ", ") + x;
      h << "<tr><td>" << k++ << "</td><td class=l><b>" << detail::htmlEscape(s.kind) << "</b>: " << detail::htmlEscape(s.description)
        << "</td><td>" << (std::isfinite(s.weakest_sigma) ? sigmaCell(p.weakest, s.weakest_sigma) : "undeterminable") << "</td><td class=l>"
        << detail::htmlEscape(u.empty() ? "—" : u) << "</td></tr>";
    }
    h << "</table>";
  }
  h << "</body></html>";
  return h.str();
}

}  // namespace mountcal::plan
