// The visual calibration report (issue 11): maps, histograms, profiles and intensity overlays
// drawn from the calibrated data, inline SVG and PNG in one HTML file.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <map>
#include <sstream>
#include <unordered_map>

#include "methods/common/strip_geometry.hpp"
#include "mountcal/core/error.hpp"
#include "mountcal/report/error_curves.hpp"
#include "mountcal/report/report.hpp"
#include "mountcal/report/swath_qc.hpp"
#include "mountcal/report/svg_plot.hpp"
#include "report/html_text.hpp"

namespace mountcal {

// ---- PNG and base64 ------------------------------------------------------------------------

namespace {

std::uint32_t crc32(const unsigned char* p, std::size_t n, std::uint32_t crc = 0) {
  static std::array<std::uint32_t, 256> table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  crc = ~crc;
  for (std::size_t i = 0; i < n; ++i) crc = table[(crc ^ p[i]) & 0xFF] ^ (crc >> 8);
  return ~crc;
}

void put32(std::string* s, std::uint32_t v) {
  for (int k = 3; k >= 0; --k) s->push_back(static_cast<char>((v >> (8 * k)) & 0xFF));
}

void chunk(std::string* png, const char* type, const std::string& data) {
  put32(png, static_cast<std::uint32_t>(data.size()));
  std::string body(type, 4);
  body += data;
  png->append(body);
  put32(png, crc32(reinterpret_cast<const unsigned char*>(body.data()), body.size()));
}

}  // namespace

std::string encodePng(int width, int height, const std::vector<unsigned char>& rgb) {
  // Raw scanlines (filter byte 0) in a zlib stream of stored deflate blocks (RFC 1950/1951).
  std::string raw;
  raw.reserve(static_cast<std::size_t>(height) * (3 * static_cast<std::size_t>(width) + 1));
  for (int y = 0; y < height; ++y) {
    raw.push_back('\0');
    raw.append(reinterpret_cast<const char*>(rgb.data()) + static_cast<std::size_t>(y) * 3 * width, 3 * static_cast<std::size_t>(width));
  }
  std::string z = {'\x78', '\x01'};
  for (std::size_t pos = 0; pos < raw.size() || pos == 0;) {
    const std::size_t n = std::min<std::size_t>(65535, raw.size() - pos);
    const bool last = pos + n >= raw.size();
    z.push_back(last ? '\x01' : '\x00');
    z.push_back(static_cast<char>(n & 0xFF));
    z.push_back(static_cast<char>(n >> 8));
    z.push_back(static_cast<char>(~n & 0xFF));
    z.push_back(static_cast<char>((~n >> 8) & 0xFF));
    z.append(raw, pos, n);
    pos += n;
    if (last) break;
  }
  std::uint32_t a = 1, b = 0;
  for (unsigned char c : raw) {
    a = (a + c) % 65521;
    b = (b + a) % 65521;
  }
  put32(&z, (b << 16) | a);
  std::string png = "\x89PNG\r\n\x1a\n";
  std::string ihdr;
  put32(&ihdr, static_cast<std::uint32_t>(width));
  put32(&ihdr, static_cast<std::uint32_t>(height));
  ihdr += std::string("\x08\x02\x00\x00\x00", 5);  // 8 bits, RGB, deflate, no filter, no interlace
  chunk(&png, "IHDR", ihdr);
  chunk(&png, "IDAT", z);
  chunk(&png, "IEND", "");
  return png;
}

std::string base64(const std::string& in) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((in.size() + 2) / 3 * 4);
  for (std::size_t i = 0; i < in.size(); i += 3) {
    const std::uint32_t v = (static_cast<unsigned char>(in[i]) << 16) |
                            (i + 1 < in.size() ? static_cast<unsigned char>(in[i + 1]) << 8 : 0) |
                            (i + 2 < in.size() ? static_cast<unsigned char>(in[i + 2]) : 0);
    out.push_back(k[(v >> 18) & 63]);
    out.push_back(k[(v >> 12) & 63]);
    out.push_back(i + 1 < in.size() ? k[(v >> 6) & 63] : '=');
    out.push_back(i + 2 < in.size() ? k[v & 63] : '=');
  }
  return out;
}

// ---- the drawings ------------------------------------------------------------------------------

namespace {

const char* kStripColours[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf"};
const unsigned char kStripRgb[][3] = {{31, 119, 180}, {214, 39, 40}, {44, 160, 44},   {148, 103, 189},
                                      {255, 127, 14}, {140, 86, 75}, {227, 119, 194}, {23, 190, 207}};

std::string imgTag(const std::string& png, int w, int h, const std::string& cls, const std::string& alt) {
  return "<img class=\"" + cls + "\" width=\"" + std::to_string(w) + "\" height=\"" + std::to_string(h) + "\" alt=\"" +
         detail::htmlEscape(alt) + "\" src=\"data:image/png;base64," + base64(png) + "\">";
}

/// The points of strip s at mounting `m` for the listed indices (SPEC §2 eq. (1) differenced:
/// exact, p_m cancels).
std::vector<Vec3> movedPoints(const CalibrationData& data, const StripData& s, const std::vector<Vec3>& x_used,
                              const std::vector<std::size_t>& idx, const MountingParameters& m) {
  const MountingParameters& used = data.mounting_used;
  const auto m6 = m.toArray();
  const detail::MountingMotion motion(used.R_nom, used.R_bs(), used.a_b, m6.data());
  std::vector<Vec3> out(idx.size());
  std::size_t cursor = 0;
  for (std::size_t k = 0; k < idx.size(); ++k) {
    const Pose p = data.pose(s, idx[k], &cursor);
    out[k] = x_used[idx[k]] + motion.displacement(p.R_mb, s.r_s[idx[k]]);
  }
  return out;
}

struct Bounds {
  double x0 = std::numeric_limits<double>::infinity(), x1 = -std::numeric_limits<double>::infinity();
  double y0 = std::numeric_limits<double>::infinity(), y1 = -std::numeric_limits<double>::infinity();
  void add(double x, double y) { x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y); }
  bool valid() const { return x1 > x0 && y1 > y0; }
};

/// A profile: a line, its half width, the points within it per strip (indices into the strip).
struct Profile {
  std::string id;
  double x0, y0, x1, y1, half_width;
  double discrepancy_m = 0;  ///< the automatic choice's height difference between strips [m]
};

/// The report's windows at the data's scale (ReportOptions: 0 takes these) [m].
struct Windows {
  double profile_length = 30, profile_width = 1, overlay = 30, cell = 2;
};

/// From the strips' points: their median plan spacing s and their largest common extent E (the
/// shorter side of the largest intersection of two strips' plan boxes): profiles and overlay of
/// E within [20 s, 30 m], width 3 s within [4 cm, 1 m], search cells of 4 s within [0.1, 2] m.
Windows dataWindows(const std::vector<std::vector<Vec3>>& X, const ReportOptions& options) {
  std::vector<double> spacing;
  std::vector<Bounds> box(X.size());
  for (std::size_t s = 0; s < X.size(); ++s) {
    if (X[s].size() >= 3) spacing.push_back(detail::planSpacing(X[s]));
    for (const Vec3& p : X[s]) box[s].add(p.x(), p.y());
  }
  double common = 0;
  for (std::size_t a = 0; a < box.size(); ++a)
    for (std::size_t b = a + 1; b < box.size(); ++b) {
      const double w = std::min(box[a].x1, box[b].x1) - std::max(box[a].x0, box[b].x0),
                   h = std::min(box[a].y1, box[b].y1) - std::max(box[a].y0, box[b].y0);
      if (w > 0 && h > 0) common = std::max(common, std::min(w, h));
    }
  Windows w;
  if (!spacing.empty() && common > 0) {
    std::nth_element(spacing.begin(), spacing.begin() + static_cast<long>(spacing.size() / 2), spacing.end());
    const double s = std::max(spacing[spacing.size() / 2], 1e-3);
    w.profile_length = std::min(30.0, std::max(20 * s, common));
    w.profile_width = std::clamp(3 * s, 0.04, 1.0);
    w.cell = std::clamp(4 * s, 0.1, 2.0);
    w.overlay = w.profile_length;
  }
  if (options.profile_length_m > 0) w.profile_length = options.profile_length_m;
  if (options.profile_width_m > 0) w.profile_width = options.profile_width_m;
  if (options.overlay_size_m > 0) w.overlay = options.overlay_size_m;
  return w;
}

/// Places where the strips disagree most in height at the mounting used: cells (Windows::cell)
/// seen by at least two strips with 4+ points each; the largest spread of the strips' mean heights.
std::vector<Profile> automaticProfiles(const std::vector<std::vector<Vec3>>& X, const ReportOptions& options, const Windows& win) {
  if (options.automatic_profiles <= 0) return {};
  const double cell = win.cell, around_m = 2.5 * win.cell;
  struct Acc {
    double z = 0, zz = 0;
    int n = 0;
  };
  std::unordered_map<std::int64_t, std::map<std::size_t, Acc>> cells;
  auto key = [&](double x, double y) {
    return detail::PlanGrid::pack(static_cast<std::int64_t>(std::floor(x / cell)), static_cast<std::int64_t>(std::floor(y / cell)));
  };
  for (std::size_t s = 0; s < X.size(); ++s)
    for (const Vec3& p : X[s]) {
      Acc& a = cells[key(p.x(), p.y())][s];
      a.z += p.z();
      a.zz += p.z() * p.z();
      ++a.n;
    }
  struct Cand {
    double d, x, y;
  };
  std::vector<Cand> cands;
  for (const auto& [k, strips] : cells) {
    double lo = 1e300, hi = -1e300;
    int seen = 0;
    bool smooth = true;  // every strip sees one smooth surface here (not a wall, an edge, a tree)
    for (const auto& [s, a] : strips) {
      if (a.n < 4) continue;
      ++seen;
      const double mean = a.z / a.n, var = std::max(0.0, a.zz / a.n - mean * mean);
      smooth &= var < 0.25 * 0.25;
      lo = std::min(lo, mean), hi = std::max(hi, mean);
    }
    if (seen < 2 || !smooth || hi - lo > 3.0) continue;
    // PlanGrid::pack: ix in the high 32 bits, iy in the low 32 (both two's complement).
    const std::int64_t ix = static_cast<std::int32_t>(static_cast<std::uint32_t>(static_cast<std::uint64_t>(k) >> 32));
    const std::int64_t iy = static_cast<std::int32_t>(static_cast<std::uint32_t>(static_cast<std::uint64_t>(k) & 0xffffffffULL));
    cands.push_back({hi - lo, (static_cast<double>(ix) + 0.5) * cell, (static_cast<double>(iy) + 0.5) * cell});
  }
  std::sort(cands.begin(), cands.end(), [](const Cand& a, const Cand& b) {
    if (a.d != b.d) return a.d > b.d;
    return a.x != b.x ? a.x < b.x : a.y < b.y;  // deterministic order
  });
  std::vector<Profile> out;
  for (const Cand& c : cands) {
    if (static_cast<int>(out.size()) >= options.automatic_profiles) break;
    bool near = false;
    for (const Profile& p : out) near |= std::hypot(0.5 * (p.x0 + p.x1) - c.x, 0.5 * (p.y0 + p.y1) - c.y) < win.profile_length;
    if (near) continue;
    // Across the local slope: the direction in which the heights around the cell change most.
    Vec3 g = Vec3::Zero();
    std::vector<Vec3> around;
    for (const Vec3& p : X[0])
      if (std::abs(p.x() - c.x) < around_m && std::abs(p.y() - c.y) < around_m) around.push_back(p);
    if (around.size() < 6)
      for (const auto& strip : X)
        for (const Vec3& p : strip)
          if (around.size() < 2000 && std::abs(p.x() - c.x) < around_m && std::abs(p.y() - c.y) < around_m) around.push_back(p);
    if (around.size() >= 6) {
      const detail::PlaneFit f = detail::fitPlane(around.size(), [&](std::size_t i) { return around[i]; });
      g = Vec3(f.normal.x(), f.normal.y(), 0);
    }
    double ux = 1, uy = 0;
    if (g.norm() > 0.05) ux = g.x() / g.norm(), uy = g.y() / g.norm();
    const double h = 0.5 * win.profile_length;
    out.push_back(
        {"auto_" + std::to_string(out.size() + 1), c.x - h * ux, c.y - h * uy, c.x + h * ux, c.y + h * uy, 0.5 * win.profile_width, c.d});
  }
  return out;
}

/// Scatter panel of z against the distance along a profile, one colour per strip.
std::string profilePanel(const std::string& title, const std::vector<std::vector<std::pair<double, double>>>& pts,
                         const std::vector<std::string>& names, double s1, double z0, double z1) {
  const int W = 520, H = 300, L = 60, R = 10, T = 28, B = 40;
  std::ostringstream o;
  o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << W << "\" height=\"" << H
    << "\" class=\"profile\" font-family=\"sans-serif\" font-size=\"11\">"
    << "<rect x=\"" << L << "\" y=\"" << T << "\" width=\"" << W - L - R << "\" height=\"" << H - T - B
    << "\" fill=\"#fff\" stroke=\"#888\"/>"
    << "<text x=\"" << W / 2 << "\" y=\"16\" text-anchor=\"middle\" font-size=\"13\">" << detail::htmlEscape(title) << "</text>";
  if (!(z1 > z0)) z1 = z0 + 1;
  auto X = [&](double s) { return L + s / std::max(s1, 1e-9) * (W - L - R); };
  auto Y = [&](double z) { return T + (z1 - z) / (z1 - z0) * (H - T - B); };
  for (int k = 0; k <= 4; ++k) {
    const double z = z0 + (z1 - z0) * k / 4.0, s = s1 * k / 4.0;
    o << "<text x=\"" << L - 4 << "\" y=\"" << detail::formatNumber(Y(z) + 4) << "\" text-anchor=\"end\">"
      << detail::formatNumber(z, "%.2f") << "</text>"
      << "<text x=\"" << detail::formatNumber(X(s)) << "\" y=\"" << H - B + 14 << "\" text-anchor=\"middle\">"
      << detail::formatNumber(s, "%.0f") << "</text>";
  }
  o << "<text x=\"" << W / 2 << "\" y=\"" << H - 6 << "\" text-anchor=\"middle\">distance along the profile [m]</text>"
    << "<text x=\"12\" y=\"" << H / 2 << "\" transform=\"rotate(-90 12 " << H / 2 << ")\" text-anchor=\"middle\">height [m]</text>";
  for (std::size_t s = 0; s < pts.size(); ++s) {
    o << "<g fill=\"" << kStripColours[s % 8] << "\">";
    for (const auto& [d, z] : pts[s])
      o << "<circle cx=\"" << detail::formatNumber(X(d)) << "\" cy=\"" << detail::formatNumber(Y(z)) << "\" r=\"1.6\"/>";
    o << "</g>";
  }
  for (std::size_t s = 0; s < names.size(); ++s)
    o << "<rect x=\"" << L + 8 + 90 * static_cast<int>(s) << "\" y=\"" << T + 6 << "\" width=\"10\" height=\"10\" fill=\""
      << kStripColours[s % 8] << "\"/><text x=\"" << L + 22 + 90 * static_cast<int>(s) << "\" y=\"" << T + 15 << "\">strip "
      << detail::htmlEscape(names[s]) << "</text>";
  o << "</svg>";
  return o.str();
}

/// Histogram of before/after values, shared bins.
std::string histogram(const std::string& title, const std::vector<double>& before, const std::vector<double>& after) {
  double m = 0;
  for (double v : before) m = std::max(m, std::abs(v));
  for (double v : after) m = std::max(m, std::abs(v));
  if (!(m > 0)) m = 1e-3;
  const int bins = 21;
  std::vector<int> hb(bins), ha(bins);
  auto bin = [&](double v) { return std::clamp(static_cast<int>(std::floor((v + m) / (2 * m) * bins)), 0, bins - 1); };
  for (double v : before) ++hb[bin(v)];
  for (double v : after) ++ha[bin(v)];
  const int top = std::max(*std::max_element(hb.begin(), hb.end()), *std::max_element(ha.begin(), ha.end()));
  const int W = 340, H = 220, L = 36, B = 36, T = 24;
  const double bw = (W - L - 10.0) / bins;
  std::ostringstream o;
  o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << W << "\" height=\"" << H
    << "\" class=\"histogram\" font-family=\"sans-serif\" font-size=\"11\">"
    << "<text x=\"" << W / 2 << "\" y=\"15\" text-anchor=\"middle\" font-size=\"12\">" << detail::htmlEscape(title) << "</text>";
  for (int k = 0; k < bins; ++k) {
    const double hb_px = (H - T - B) * hb[k] / std::max(top, 1), ha_px = (H - T - B) * ha[k] / std::max(top, 1);
    o << "<rect x=\"" << detail::formatNumber(L + k * bw) << "\" y=\"" << detail::formatNumber(H - B - hb_px) << "\" width=\""
      << detail::formatNumber(bw * 0.5) << "\" height=\"" << detail::formatNumber(hb_px) << "\" fill=\"#d62728\"/><rect x=\""
      << detail::formatNumber(L + k * bw + bw * 0.5) << "\" y=\"" << detail::formatNumber(H - B - ha_px) << "\" width=\""
      << detail::formatNumber(bw * 0.5) << "\" height=\"" << detail::formatNumber(ha_px) << "\" fill=\"#1f77b4\"/>";
  }
  o << "<line x1=\"" << L << "\" y1=\"" << H - B << "\" x2=\"" << W - 10 << "\" y2=\"" << H - B << "\" stroke=\"#000\"/>"
    << "<text x=\"" << L << "\" y=\"" << H - B + 14 << "\">" << detail::formatNumber(-m, "%.3f") << "</text><text x=\"" << W - 10
    << "\" y=\"" << H - B + 14 << "\" text-anchor=\"end\">" << detail::formatNumber(m, "%+.3f") << "</text><text x=\"" << (L + W) / 2
    << "\" y=\"" << H - B + 14 << "\" text-anchor=\"middle\">0 [m]</text><text x=\"" << L << "\" y=\"" << H - 6
    << "\" fill=\"#d62728\">■ before</text><text x=\"" << L + 80 << "\" y=\"" << H - 6 << "\" fill=\"#1f77b4\">■ after</text><text x=\""
    << L - 4 << "\" y=\"" << T + 8 << "\" text-anchor=\"end\">" << top << "</text></svg>";
  return o.str();
}

}  // namespace

namespace {

/// The strips' points at the mounting used (for drawing), their ids and plan extent.
struct DrawnStrips {
  std::vector<std::vector<Vec3>> X;
  std::vector<std::string> strip_ids;
  Bounds box;
  Windows windows;  ///< profiles and overlay at the data's scale (or the options')
  bool drawable() const { return box.valid() && !X.empty(); }
};

DrawnStrips drawnStrips(const CalibrationData& data, const ReportOptions& options) {
  DrawnStrips d;
  for (const StripData& s : data.strips) {
    d.X.push_back(detail::referencePoints(data, s, data.mounting_used));
    d.strip_ids.push_back(s.id);
    for (const Vec3& p : d.X.back()) d.box.add(p.x(), p.y());
  }
  d.windows = dataWindows(d.X, options);
  return d;
}

/// Warnings a user acts on: undeterminable and strongly correlated parameters, σ₀² far from 1,
/// each method's own (rejected input, outliers), an unusable solve.
std::string warningsSection(const MountingCalibrator::Summary& summary) {
  std::ostringstream v;
  const auto& names = mountingParameterNames();
  std::vector<std::string> warn;
  for (const auto& u : summary.unobservable) warn.push_back(u + " could not be determined by the data and was held at its used value");
  for (int a = 0; a < 6; ++a)
    for (int b = a + 1; b < 6; ++b)
      if (summary.estimated[a] && summary.estimated[b] && std::abs(summary.correlation(a, b)) > 0.9)
        warn.push_back(names[a] + " and " + names[b] + " are strongly correlated (" +
                       detail::formatNumber(summary.correlation(a, b), "%+.3f") + ")");
  if (summary.degrees_of_freedom > 0 && (summary.variance_factor < 0.3 || summary.variance_factor > 2.0))  // the verdict's bounds
    warn.push_back("the variance factor σ₀² = " + detail::formatNumber(summary.variance_factor, "%.3g") +
                   " is far from 1: the stated σ do not match the residuals");
  for (const auto& ms : summary.model_sensitivity)
    if (ms.model_dependent()) warn.push_back(ms.text());
  if (summary.resolve.unsettled()) warn.push_back(summary.resolve.text());
  int outliers = 0;
  for (const auto& section : summary.sections) {
    for (const std::string& w : section->warnings()) warn.push_back(w);
    outliers += section->outliers();
  }
  if (outliers) warn.push_back(std::to_string(outliers) + " observations flagged as outliers");
  if (!summary.IsSolutionUsable())
    warn.push_back(std::string("the solve is not usable: ") + toString(summary.termination) + " — " + summary.message);
  const MountingCalibrator::Verdict verdict = summary.verdict();
  v << "<h2>Verdict: " << verdict.name() << "</h2>";
  if (verdict.reasons.empty()) v << "<p class=ok>Nothing speaks against using this calibration.</p>";
  for (const auto& r : verdict.reasons) v << "<p class=warn>" << detail::htmlEscape(r) << "</p>";
  v << "<h2>Warnings</h2>";
  if (warn.empty()) v << "<p class=ok>None.</p>";
  for (const auto& w : warn) v << "<p class=warn>" << detail::htmlEscape(w) << "</p>";

  return v.str();
}

std::string correlationSection(const MountingCalibrator::Summary& summary) {
  std::ostringstream v;
  const auto& names = mountingParameterNames();
  v << "<h2>Correlations</h2>";
  std::vector<std::string> labels(names.begin(), names.end());
  std::vector<double> c(36);
  for (int a = 0; a < 6; ++a)
    for (int b = 0; b < 6; ++b) c[static_cast<std::size_t>(6 * a + b)] = summary.correlation(a, b);
  v << svgCorrelationHeatMap(labels, c);

  return v.str();
}

/// Plan view: footprints per strip (overlaps darker), regions, the methods' marks and residual
/// arrows before and after.
std::string mapSection(const CalibrationData& data, const MountingCalibrator::Summary& summary, const DrawnStrips& drawn,
                       const std::vector<PlanResidual>& plan_residuals, const ReportOptions& options) {
  std::ostringstream v;
  const auto& X = drawn.X;
  const auto& strip_ids = drawn.strip_ids;
  const Bounds& box = drawn.box;
  const int W = options.map_px;
  const double scale = W / std::max(box.x1 - box.x0, box.y1 - box.y0);
  const int Wd = std::max(1, static_cast<int>((box.x1 - box.x0) * scale)), Hd = std::max(1, static_cast<int>((box.y1 - box.y0) * scale));
  // Footprints: each strip's occupancy blended in its colour; overlaps darker.
  std::vector<float> acc(static_cast<std::size_t>(Wd) * Hd * 3, 0.0f);
  std::vector<unsigned char> count(static_cast<std::size_t>(Wd) * Hd, 0);
  for (std::size_t s = 0; s < X.size(); ++s) {
    std::vector<unsigned char> hit(static_cast<std::size_t>(Wd) * Hd, 0);
    for (const Vec3& p : X[s]) {
      const int px = std::clamp(static_cast<int>((p.x() - box.x0) * scale), 0, Wd - 1);
      const int py = std::clamp(static_cast<int>((box.y1 - p.y()) * scale), 0, Hd - 1);
      hit[static_cast<std::size_t>(py) * Wd + px] = 1;
    }
    for (std::size_t i = 0; i < hit.size(); ++i)
      if (hit[i]) {
        for (int k = 0; k < 3; ++k) acc[3 * i + k] += kStripRgb[s % 8][k];
        ++count[i];
      }
  }
  std::vector<unsigned char> rgb(acc.size(), 255);
  for (std::size_t i = 0; i < count.size(); ++i) {
    if (!count[i]) continue;
    const double alpha = std::min(0.85, 0.3 * count[i]);
    for (int k = 0; k < 3; ++k)
      rgb[3 * i + k] = static_cast<unsigned char>(std::lround(255 * (1 - alpha) + alpha * acc[3 * i + k] / count[i]));
  }
  auto PX = [&](double x) { return (x - box.x0) * scale; };
  auto PY = [&](double y) { return (box.y1 - y) * scale; };
  // Residual vectors of the methods that have them (ties at the picks), before (red) and after
  // (blue), one common scale.
  double longest = 0;
  for (const PlanResidual& r : plan_residuals) longest = std::max(longest, r.before_m.head<2>().norm());
  const double vec_scale = longest > 0 ? 0.08 * Wd / longest : 0.0;  // px per metre of residual
  v << "<h2>Plan view</h2><svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << Wd << "\" height=\"" << Hd + 40
    << "\" class=\"mapview\" font-family=\"sans-serif\" font-size=\"11\"><image width=\"" << Wd << "\" height=\"" << Hd
    << "\" href=\"data:image/png;base64," << base64(encodePng(Wd, Hd, rgb)) << "\"/>";
  for (const PlaneRegion& r : data.plane_regions)
    v << "<rect x=\"" << detail::formatNumber(PX(r.xmin)) << "\" y=\"" << detail::formatNumber(PY(r.ymax)) << "\" width=\""
      << detail::formatNumber((r.xmax - r.xmin) * scale) << "\" height=\"" << detail::formatNumber((r.ymax - r.ymin) * scale)
      << "\" fill=\"none\" stroke=\"#8c564b\"><title>plane region " << detail::htmlEscape(r.id) << "</title></rect>";
  for (const PlaneRegion& r : data.target_regions)
    v << "<rect x=\"" << detail::formatNumber(PX(r.xmin)) << "\" y=\"" << detail::formatNumber(PY(r.ymax)) << "\" width=\""
      << detail::formatNumber((r.xmax - r.xmin) * scale) << "\" height=\"" << detail::formatNumber((r.ymax - r.ymin) * scale)
      << "\" fill=\"none\" stroke=\"#000\" stroke-dasharray=\"2 2\"><title>target region " << detail::htmlEscape(r.id) << "</title></rect>";
  for (const auto& section : summary.sections)
    for (const PlanMark& p : section->planMarks())
      v << "<circle cx=\"" << detail::formatNumber(PX(p.x_m)) << "\" cy=\"" << detail::formatNumber(PY(p.y_m))
        << "\" r=\"3\" fill=\"#8c564b\"><title>" << detail::htmlEscape(p.label) << "</title></circle>";
  for (const PlanResidual& r : plan_residuals) {
    const double x = PX(r.x_m), y = PY(r.y_m);
    v << "<circle cx=\"" << detail::formatNumber(x) << "\" cy=\"" << detail::formatNumber(y) << "\" r=\"2\" fill=\"#000\"><title>"
      << detail::htmlEscape(r.label) << "</title></circle>";
    v << "<line x1=\"" << detail::formatNumber(x) << "\" y1=\"" << detail::formatNumber(y) << "\" x2=\""
      << detail::formatNumber(x + r.before_m.x() * vec_scale) << "\" y2=\"" << detail::formatNumber(y - r.before_m.y() * vec_scale)
      << "\" stroke=\"#d62728\" stroke-width=\"1.5\"/>";
    v << "<line x1=\"" << detail::formatNumber(x) << "\" y1=\"" << detail::formatNumber(y) << "\" x2=\""
      << detail::formatNumber(x + r.after_m.x() * vec_scale) << "\" y2=\"" << detail::formatNumber(y - r.after_m.y() * vec_scale)
      << "\" stroke=\"#1f77b4\" stroke-width=\"1.5\"/>";
  }
  double ref = 0;
  if (vec_scale > 0) {  // a round residual length for the legend
    const double target = longest / 2, mag = std::pow(10.0, std::floor(std::log10(target)));
    ref = (target / mag < 2 ? 1 : target / mag < 5 ? 2 : 5) * mag;
  }
  v << "<g transform=\"translate(0," << Hd + 8 << ")\">";
  for (std::size_t s = 0; s < strip_ids.size(); ++s)
    v << "<rect x=\"" << 90 * s << "\" y=\"0\" width=\"10\" height=\"10\" fill=\"" << kStripColours[s % 8] << "\"/><text x=\""
      << 90 * s + 14 << "\" y=\"9\">strip " << detail::htmlEscape(strip_ids[s]) << "</text>";
  if (ref > 0)
    v << "<line x1=\"0\" y1=\"24\" x2=\"" << detail::formatNumber(ref * vec_scale)
      << "\" y2=\"24\" stroke=\"#d62728\" stroke-width=\"2\"/><text x=\"" << detail::formatNumber(ref * vec_scale + 6)
      << "\" y=\"28\">tie residual " << detail::formatNumber(ref, "%.3g") << " m: red before, blue after (at the picks)</text>";
  v << "</g></svg><p>Map " << detail::formatNumber(box.x1 - box.x0, "%.0f") << " m × " << detail::formatNumber(box.y1 - box.y0, "%.0f")
    << " m, north up; footprints shaded per strip, overlaps darker; plane regions brown, target regions dashed.</p>";
  return v.str();
}

std::string histogramSection(const std::vector<PlanResidual>& plan_residuals) {
  std::ostringstream v;
  if (!plan_residuals.empty()) {
    v << "<h2>Residual histograms</h2><div>";
    const char* axis[3] = {"x (east)", "y (north)", "z (up)"};
    for (int a = 0; a < 3; ++a) {
      std::vector<double> b, af;
      for (const PlanResidual& r : plan_residuals) b.push_back(r.before_m[a]), af.push_back(r.after_m[a]);
      v << histogram(std::string("tie residuals, ") + axis[a], b, af);
    }
    v << "</div>";
  }

  return v.str();
}

/// Elevation profiles before and after (Fig. 10): automatic ones where the strips disagree most,
/// and the user's. `profiles` receives them (the intensity overlay looks at their middles).
std::string profilesSection(const CalibrationData& data, const MountingCalibrator::Summary& summary, const DrawnStrips& drawn,
                            const ReportOptions& options, std::vector<Profile>* profiles_out) {
  std::ostringstream v;
  const auto& X = drawn.X;
  const auto& strip_ids = drawn.strip_ids;
  const bool drawable = drawn.drawable();
  std::vector<Profile> profiles;
  if (drawable) profiles = automaticProfiles(X, options, drawn.windows);
  for (const auto& p : options.profiles) profiles.push_back({p.id, p.x0_m, p.y0_m, p.x1_m, p.y1_m, 0.5 * p.width_m});
  if (!profiles.empty()) v << "<h2>Elevation profiles across the overlaps</h2>";
  for (const Profile& pr : profiles) {
    const double len = std::hypot(pr.x1 - pr.x0, pr.y1 - pr.y0);
    if (!(len > 0)) continue;
    const double ux = (pr.x1 - pr.x0) / len, uy = (pr.y1 - pr.y0) / len;
    std::vector<std::vector<std::pair<double, double>>> before(X.size()), after(X.size());
    double z0 = 1e300, z1 = -1e300;
    for (std::size_t s = 0; s < X.size(); ++s) {
      std::vector<std::size_t> idx;
      for (std::size_t i = 0; i < X[s].size(); ++i) {
        const double dx = X[s][i].x() - pr.x0, dy = X[s][i].y() - pr.y0;
        const double along = dx * ux + dy * uy, across = -dx * uy + dy * ux;
        if (along >= -1 && along <= len + 1 && std::abs(across) <= pr.half_width + 1) idx.push_back(i);
      }
      if (idx.size() > options.max_points_per_panel) {
        std::vector<std::size_t> t;
        for (std::size_t k = 0; k < options.max_points_per_panel; ++k) t.push_back(idx[k * idx.size() / options.max_points_per_panel]);
        idx.swap(t);
      }
      const std::vector<Vec3> moved = movedPoints(data, data.strips[s], X[s], idx, summary.mounting);
      for (std::size_t k = 0; k < idx.size(); ++k) {
        for (int pass = 0; pass < 2; ++pass) {
          const Vec3& p = pass == 0 ? X[s][idx[k]] : moved[k];
          const double dx = p.x() - pr.x0, dy = p.y() - pr.y0;
          const double along = dx * ux + dy * uy, across = -dx * uy + dy * ux;
          if (along < 0 || along > len || std::abs(across) > pr.half_width) continue;
          (pass == 0 ? before : after)[s].push_back({along, p.z()});
          z0 = std::min(z0, p.z()), z1 = std::max(z1, p.z());
        }
      }
    }
    if (z0 > z1) continue;
    const double pad = 0.05 * (z1 - z0) + 0.05;
    v << "<h3>" << detail::htmlEscape(pr.id) << ": (" << detail::formatNumber(pr.x0) << ", " << detail::formatNumber(pr.y0) << ") → ("
      << detail::formatNumber(pr.x1) << ", " << detail::formatNumber(pr.y1) << "), width "
      << detail::formatNumber(2 * pr.half_width, "%.2g") << " m"
      << (pr.discrepancy_m > 0 ? ", strips " + detail::formatNumber(pr.discrepancy_m, "%.3f") + " m apart in height before" : "")
      << "</h3><div>" << profilePanel("before", before, strip_ids, len, z0 - pad, z1 + pad)
      << profilePanel("after", after, strip_ids, len, z0 - pad, z1 + pad) << "</div>";
  }

  *profiles_out = profiles;
  return v.str();
}

/// The intensities of `pts` (strip `s`'s points `inside` of the overlay window) on a P × P raster
/// around (cx, cy), gaps between points filled from their neighbours, stretched between the 2nd
/// and 98th percentiles to [0, 1].
std::vector<double> intensityRaster(const CalibrationData& data, std::size_t s, const std::vector<std::size_t>& inside,
                                    const std::vector<Vec3>& pts, double cx, double cy, double half, int P) {
  std::vector<double> sum(static_cast<std::size_t>(P) * P, 0.0), n(sum.size(), 0.0);
  for (std::size_t k = 0; k < pts.size(); ++k) {
    const int px = static_cast<int>((pts[k].x() - (cx - half)) / (2 * half) * P),
              py = static_cast<int>(((cy + half) - pts[k].y()) / (2 * half) * P);
    if (px < 0 || py < 0 || px >= P || py >= P) continue;
    const std::size_t i = static_cast<std::size_t>(py) * P + px;
    sum[i] += data.strips[s].intensity[inside[k]];
    n[i] += 1;
  }
  // An empty pixel takes the mean of its filled 8-neighbours (a gap between points), else stays empty.
  std::vector<double> img(sum.size(), -1);
  for (std::size_t i = 0; i < sum.size(); ++i)
    if (n[i] > 0) img[i] = sum[i] / n[i];
  std::vector<double> filled_img = img;
  for (int y = 0; y < P; ++y)
    for (int x = 0; x < P; ++x) {
      if (img[static_cast<std::size_t>(y) * P + x] >= 0) continue;
      double acc = 0;
      int m = 0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int xx = x + dx, yy = y + dy;
          if (xx < 0 || yy < 0 || xx >= P || yy >= P) continue;
          const double w = img[static_cast<std::size_t>(yy) * P + xx];
          if (w >= 0) acc += w, ++m;
        }
      if (m >= 3) filled_img[static_cast<std::size_t>(y) * P + x] = acc / m;
    }
  img.swap(filled_img);
  // Stretch between the 2nd and 98th percentiles.
  std::vector<double> filled;
  for (double x : img)
    if (x >= 0) filled.push_back(x);
  std::sort(filled.begin(), filled.end());
  const double lo = filled.empty() ? 0 : filled[filled.size() * 2 / 100], hi = filled.empty() ? 1 : filled[filled.size() * 98 / 100];
  for (double& x : img) x = x < 0 ? 0 : std::clamp((x - lo) / std::max(hi - lo, 1e-9), 0.0, 1.0);
  return img;
}

/// Two strips' intensities overlaid before and after (Fig. 11), where the intensity has most contrast.
std::string overlaySection(const CalibrationData& data, const MountingCalibrator::Summary& summary, const DrawnStrips& drawn,
                           const std::vector<Profile>& profiles, const ReportOptions& options) {
  std::ostringstream v;
  const auto& X = drawn.X;
  const auto& strip_ids = drawn.strip_ids;
  const Bounds& box = drawn.box;
  const bool drawable = drawn.drawable();
  bool has_intensity = false;
  for (const StripData& s : data.strips) has_intensity |= s.intensity.size() == s.r_s.size() && !s.r_s.empty();
  if (drawable && has_intensity && X.size() >= 2) {
    // Centre: where the intensity has the most contrast (markings, targets) among the places
    // seen by two strips: the ties, the target regions and the profiles' middles.
    const double half = 0.5 * drawn.windows.overlay;
    std::vector<std::pair<double, double>> centres;
    for (const TieObservation& t : data.ties)
      if (centres.size() < 200) centres.push_back({t.x_m, t.y_m});
    for (const PlaneRegion& r : data.target_regions) centres.push_back({0.5 * (r.xmin + r.xmax), 0.5 * (r.ymin + r.ymax)});
    for (const Profile& p : profiles) centres.push_back({0.5 * (p.x0 + p.x1), 0.5 * (p.y0 + p.y1)});
    if (centres.empty()) centres.push_back({0.5 * (box.x0 + box.x1), 0.5 * (box.y0 + box.y1)});
    double cx = centres.front().first, cy = centres.front().second, best_contrast = -1;
    for (const auto& [x, y] : centres) {
      int strips_seeing = 0;
      double contrast = 0;
      for (std::size_t s = 0; s < X.size(); ++s) {
        if (data.strips[s].intensity.size() != X[s].size()) continue;
        double m = 0, mm = 0;
        int n = 0;
        for (std::size_t i = 0; i < X[s].size(); i += 1 + X[s].size() / 200000) {
          if (std::abs(X[s][i].x() - x) > 0.5 * half || std::abs(X[s][i].y() - y) > 0.5 * half) continue;
          const double v = data.strips[s].intensity[i];
          m += v, mm += v * v, ++n;
        }
        if (n < 20) continue;
        ++strips_seeing;
        contrast = std::max(contrast, std::sqrt(std::max(0.0, mm / n - (m / n) * (m / n))));
      }
      if (strips_seeing >= 2 && contrast > best_contrast) best_contrast = contrast, cx = x, cy = y;
    }
    // The two strips with the most points in the window.
    std::vector<std::pair<std::size_t, std::size_t>> counts;
    std::vector<std::vector<std::size_t>> inside(X.size());
    for (std::size_t s = 0; s < X.size(); ++s) {
      if (data.strips[s].intensity.size() != X[s].size()) continue;
      for (std::size_t i = 0; i < X[s].size(); ++i)
        if (std::abs(X[s][i].x() - cx) <= half + 2 && std::abs(X[s][i].y() - cy) <= half + 2) inside[s].push_back(i);
      counts.push_back({inside[s].size(), s});
    }
    std::sort(counts.rbegin(), counts.rend());
    if (counts.size() >= 2 && counts[1].first >= 10) {
      const std::size_t A = counts[0].second, Bs = counts[1].second;
      // Pixels of about two thirds of the point spacing (at most overlay_px per side).
      std::vector<Vec3> window_a;
      for (std::size_t i : inside[A]) window_a.push_back(X[A][i]);
      const double spacing = std::max(detail::planSpacing(window_a), 0.02);
      const int P = std::clamp(static_cast<int>(2 * half / (0.67 * spacing)), 16, options.overlay_px);
      auto overlay = [&](const MountingParameters& m, bool use_used) {
        std::vector<Vec3> pa, pb;
        if (use_used) {
          for (std::size_t i : inside[A]) pa.push_back(X[A][i]);
          for (std::size_t i : inside[Bs]) pb.push_back(X[Bs][i]);
        } else {
          pa = movedPoints(data, data.strips[A], X[A], inside[A], m);
          pb = movedPoints(data, data.strips[Bs], X[Bs], inside[Bs], m);
        }
        const std::vector<double> ia = intensityRaster(data, A, inside[A], pa, cx, cy, half, P),
                                  ib = intensityRaster(data, Bs, inside[Bs], pb, cx, cy, half, P);
        std::vector<unsigned char> rgb(static_cast<std::size_t>(P) * P * 3);
        for (std::size_t i = 0; i < ia.size(); ++i) {  // strip A magenta, strip B green: aligned → grey
          rgb[3 * i] = static_cast<unsigned char>(std::lround(255 * ia[i]));
          rgb[3 * i + 1] = static_cast<unsigned char>(std::lround(255 * ib[i]));
          rgb[3 * i + 2] = static_cast<unsigned char>(std::lround(255 * ia[i]));
        }
        return encodePng(P, P, rgb);
      };
      v << "<h2>Intensity overlay</h2><p>Strip " << detail::htmlEscape(strip_ids[A]) << " in magenta, strip "
        << detail::htmlEscape(strip_ids[Bs]) << " in green (where they agree the image is grey), " << detail::formatNumber(2 * half, "%.0f")
        << " m around (" << detail::formatNumber(cx) << ", " << detail::formatNumber(cy) << "); before and after.</p><div>"
        << imgTag(overlay(data.mounting_used, true), 360, 360, "overlay-before", "intensity overlay before") << " "
        << imgTag(overlay(summary.mounting, false), 360, 360, "overlay-after", "intensity overlay after") << "</div>";
    }
  }

  return v.str();
}

/// Every strip's laser vectors r_s, evenly strided to about `count` (every one when fewer).
std::vector<Vec3> sampledBeams(const CalibrationData& data, std::size_t count) {
  std::size_t total = 0;
  for (const StripData& s : data.strips) total += s.r_s.size();
  const std::size_t step = 1 + total / count;
  std::vector<Vec3> out;
  std::size_t k = 0;
  for (const StripData& s : data.strips)
    for (const Vec3& v : s.r_s)
      if (k++ % step == 0) out.push_back(v);
  return out;
}

/// The ranges at which the error curves are drawn: the 10th, 50th and 90th percentiles of the
/// data's ranges |r_s| (rounded to two significant digits, distinct), so that a UAV's 30 m passes
/// are not shown at an aircraft's 500–2000 m; those four when the data have no ranges.
std::vector<double> curveRanges(const CalibrationData& data) {
  std::vector<double> r;
  for (const Vec3& v : sampledBeams(data, 20000))
    if (std::isfinite(v.norm()) && v.norm() > 0) r.push_back(v.norm());
  if (r.size() < 10) return {500, 1000, 1500, 2000};
  std::sort(r.begin(), r.end());
  std::vector<double> out;
  for (double q : {0.1, 0.5, 0.9}) {
    const double x = r[static_cast<std::size_t>(q * static_cast<double>(r.size() - 1))];
    const double unit = std::pow(10.0, std::floor(std::log10(x)) - 1);  // two significant digits
    const double rounded = std::max(unit, std::round(x / unit) * unit);
    if (out.empty() || rounded > out.back()) out.push_back(rounded);
  }
  return out;
}

/// The error the survey's own beams would carry without the boresight change (Figs 1–3, at the
/// data's ranges): its beams binned by their angle about the body's forward axis
/// (beamErrorCurves), so that a multi-beam scanner is drawn over the angles it scans, not a line
/// scanner's ±30°; a line scanner's ±30° when the data hold no beams (given correspondence candidates).
std::string errorCurvesSection(const CalibrationData& data, const MountingCalibrator::Summary& summary) {
  std::ostringstream v;
  const std::vector<double> ranges = curveRanges(data);
  const Vec3 b = summary.mounting.boresight - data.mounting_used.boresight;
  std::vector<ErrorCurveSample> curves =
      beamErrorCurves(data.mounting_used.R_bs(), summary.mounting.R_bs(), sampledBeams(data, 50000), ranges);
  const bool own = !curves.empty();
  if (!own) {
    std::vector<double> angles;
    for (int a = -30; a <= 30; ++a) angles.push_back(deg2rad(a));
    curves = boresightErrorCurves(b, angles, ranges);
  }
  v << "<h2>Georeferencing error of the boresight correction (the first paper's Figs 1–3)</h2><p>The error "
    << (own ? "this survey's own beams" : "a line scanner's points (±30°; the data hold no beams)")
    << " would carry if the boresight change found here (" << detail::formatNumber(rad2deg(b.x()), "%+.4f") << "°, "
    << detail::formatNumber(rad2deg(b.y()), "%+.4f") << "°, " << detail::formatNumber(rad2deg(b.z()), "%+.4f")
    << "°) were ignored, against "
    << (own ? "the beams' angle about the body's forward axis (a line scanner's scan angle; a multi-beam scanner's spin angle "
              "when it is mounted on its side), in 2° bins of its beams"
            : "scan angle")
    << ", at this survey's ranges (the 10th, 50th and 90th percentiles of its ranges).</p><div>";
  const char* ax[3] = {"along track (x)", "across track (y)", "vertical (z)"};
  for (int a = 0; a < 3; ++a) v << errorCurveSvg(curves, a, std::string("error ") + ax[a]);
  v << "</div>";
  return v.str();
}

}  // namespace

std::string visualReport(const MountingCalibrator::Summary& summary, const CalibrationData& data, const ResultEvaluation* ev,
                         const ReportOptions& options) {
  std::vector<PlanResidual> plan_residuals;  // every method's residual arrows
  for (const auto& section : summary.sections) {
    std::vector<PlanResidual> r = section->planResiduals(data);
    plan_residuals.insert(plan_residuals.end(), r.begin(), r.end());
  }
  std::ostringstream v;  // the visual sections, inserted after the mounting table
  v << warningsSection(summary) << correlationSection(summary);
  const DrawnStrips drawn = drawnStrips(data, options);
  if (!drawn.drawable()) v << "<p>No strip points: no map, profiles or overlays.</p>";
  if (drawn.drawable()) v << mapSection(data, summary, drawn, plan_residuals, options);
  v << histogramSection(plan_residuals);
  std::vector<Profile> profiles;
  v << profilesSection(data, summary, drawn, options, &profiles);
  v << overlaySection(data, summary, drawn, profiles, options);
  v << errorCurvesSection(data, summary);
  if (options.swath_qc && drawn.drawable()) {
    // The swath QC (docs/swath-qc.md) at the job's mounting and the result's.
    try {
      SwathQcOptions qo;
      qo.point_to_plane = false;  // the dZ measures only: the report stays quick (`mountcal qc` has all)
      v << swathQcSection(swathQc(data, summary.mounting_used, summary.mounting, qo, summary.laserCorrections()));
    } catch (const InvalidInput& e) {
      v << "<h2>Swath QC</h2><p>Not measured: " << detail::htmlEscape(e.what()) << "</p>";
    }
  }
  std::string html = htmlReport(summary, ev, options.title);
  const std::string style =
      ".warn{background:#fff4e0;border-left:4px solid #e69500;padding:6px 10px}svg,img{max-width:100%}img{image-rendering:pixelated}"
      "@media print{body{margin:0}h2{page-break-after:avoid}}.pass{color:#1a9850}.fail{color:#d73027}";
  const std::size_t st = html.find("</style>");
  if (st != std::string::npos) html.insert(st, style);
  // After the mounting table (the first table of the document).
  const std::size_t at = html.find("</table>");
  html.insert(at == std::string::npos ? html.size() : at + 8, v.str());
  return html;
}

}  // namespace mountcal
