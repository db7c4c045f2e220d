#include "mountcal/report/svg_plot.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

namespace mountcal {

namespace {

std::string escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '&':
        out += "&amp;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

/// A "nice" tick step (1, 2 or 5 × 10^k) giving about `target` ticks over `span`.
double niceStep(double span, int target) {
  if (!(span > 0)) return 1.0;
  const double raw = span / target;
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  const double f = raw / mag;
  return (f < 1.5 ? 1.0 : f < 3.5 ? 2.0 : f < 7.5 ? 5.0 : 10.0) * mag;
}

std::string fmt(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", std::abs(v) < 1e-12 ? 0.0 : v);
  return buf;
}

}  // namespace

void SvgLinePlot::addSeries(std::string name, std::vector<double> xs, std::vector<double> ys) {
  const std::size_t n = std::min(xs.size(), ys.size());
  xs.resize(n);
  ys.resize(n);
  series_.push_back({std::move(name), std::move(xs), std::move(ys)});
}

std::string SvgLinePlot::render(int width, int height) const {
  static const char* kColours[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf"};
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
  for (const Series& s : series_) {
    for (std::size_t i = 0; i < s.xs.size(); ++i) {
      if (!std::isfinite(s.xs[i]) || !std::isfinite(s.ys[i])) continue;
      x0 = std::min(x0, s.xs[i]);
      x1 = std::max(x1, s.xs[i]);
      y0 = std::min(y0, s.ys[i]);
      y1 = std::max(y1, s.ys[i]);
    }
  }
  if (!(x1 > x0)) {
    x0 = std::isfinite(x0) ? x0 - 1 : 0;
    x1 = x0 + 2;
  }
  if (!(y1 > y0)) {
    y0 = std::isfinite(y0) ? y0 - 1 : 0;
    y1 = y0 + 2;
  }
  const double ystep = niceStep(y1 - y0, 6), xstep = niceStep(x1 - x0, 8);
  y0 = std::floor(y0 / ystep) * ystep;
  y1 = std::ceil(y1 / ystep) * ystep;
  x0 = std::floor(x0 / xstep) * xstep;
  x1 = std::ceil(x1 / xstep) * xstep;

  const double left = 80, right = 170, top = 40, bottom = 60;
  const double pw = width - left - right, ph = height - top - bottom;
  auto X = [&](double x) { return left + (x - x0) / (x1 - x0) * pw; };
  auto Y = [&](double y) { return top + (y1 - y) / (y1 - y0) * ph; };

  std::ostringstream svg;
  svg << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << width << "\" height=\"" << height
      << "\" font-family=\"sans-serif\" font-size=\"12\">\n"
      << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
      << "<text x=\"" << width / 2 << "\" y=\"22\" text-anchor=\"middle\" font-size=\"15\">" << escape(title_) << "</text>\n";
  for (double y = y0; y <= y1 + 1e-9 * ystep; y += ystep) {
    svg << "<line x1=\"" << left << "\" x2=\"" << left + pw << "\" y1=\"" << Y(y) << "\" y2=\"" << Y(y) << "\" stroke=\"#ddd\"/><text x=\""
        << left - 6 << "\" y=\"" << Y(y) + 4 << "\" text-anchor=\"end\">" << fmt(y) << "</text>\n";
  }
  for (double x = x0; x <= x1 + 1e-9 * xstep; x += xstep) {
    svg << "<line y1=\"" << top << "\" y2=\"" << top + ph << "\" x1=\"" << X(x) << "\" x2=\"" << X(x) << "\" stroke=\"#ddd\"/><text x=\""
        << X(x) << "\" y=\"" << top + ph + 18 << "\" text-anchor=\"middle\">" << fmt(x) << "</text>\n";
  }
  svg << "<rect x=\"" << left << "\" y=\"" << top << "\" width=\"" << pw << "\" height=\"" << ph << "\" fill=\"none\" stroke=\"black\"/>\n"
      << "<text x=\"" << left + pw / 2 << "\" y=\"" << height - 15 << "\" text-anchor=\"middle\">" << escape(x_label_) << "</text>\n"
      << "<text transform=\"translate(18," << top + ph / 2 << ") rotate(-90)\" text-anchor=\"middle\">" << escape(y_label_) << "</text>\n";
  for (std::size_t k = 0; k < series_.size(); ++k) {
    const Series& s = series_[k];
    const char* colour = kColours[k % 8];
    svg << "<polyline fill=\"none\" stroke=\"" << colour << "\" stroke-width=\"2\" points=\"";
    for (std::size_t i = 0; i < s.xs.size(); ++i) {
      if (std::isfinite(s.xs[i]) && std::isfinite(s.ys[i])) {
        svg << X(s.xs[i]) << ',' << Y(s.ys[i]) << ' ';
      }
    }
    svg << "\"/>\n";
    const double ly = top + 10 + 20.0 * static_cast<double>(k);
    svg << "<line x1=\"" << left + pw + 12 << "\" x2=\"" << left + pw + 36 << "\" y1=\"" << ly << "\" y2=\"" << ly << "\" stroke=\""
        << colour << "\" stroke-width=\"2\"/><text x=\"" << left + pw + 42 << "\" y=\"" << ly + 4 << "\">" << escape(s.name) << "</text>\n";
  }
  svg << "</svg>\n";
  return svg.str();
}

std::string correlationColour(double c) {
  if (!std::isfinite(c)) return "#cccccc";
  c = std::max(-1.0, std::min(1.0, c));
  // White at 0, to (33, 102, 172) at −1 and (178, 24, 43) at +1.
  const double a = std::abs(c);
  const int r = static_cast<int>(std::lround(255 + a * ((c < 0 ? 33 : 178) - 255)));
  const int g = static_cast<int>(std::lround(255 + a * ((c < 0 ? 102 : 24) - 255)));
  const int b = static_cast<int>(std::lround(255 + a * ((c < 0 ? 172 : 43) - 255)));
  char buf[8];
  std::snprintf(buf, sizeof buf, "#%02x%02x%02x", r, g, b);
  return buf;
}

std::string svgCorrelationHeatMap(const std::vector<std::string>& labels, const std::vector<double>& v, int cell) {
  const int n = static_cast<int>(labels.size());
  const int left = 150, top = 20, w = left + n * cell + 10, h = top + n * cell + 150;
  std::ostringstream o;
  o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << w << "\" height=\"" << h << "\" viewBox=\"0 0 " << w << " " << h
    << "\" font-family=\"sans-serif\" font-size=\"12\" class=\"heatmap\">";
  for (int a = 0; a < n; ++a) {
    o << "<text x=\"" << left - 6 << "\" y=\"" << top + a * cell + cell / 2 + 4 << "\" text-anchor=\"end\">" << escape(labels[a])
      << "</text>";
    const int x = left + a * cell + cell / 2, y = top + n * cell + 8;
    o << "<text x=\"" << x << "\" y=\"" << y << "\" transform=\"rotate(60 " << x << " " << y << ")\">" << escape(labels[a]) << "</text>";
    for (int b = 0; b < n; ++b) {
      const double c = static_cast<std::size_t>(a * n + b) < v.size() ? v[static_cast<std::size_t>(a * n + b)] : std::nan("");
      char val[16];
      std::snprintf(val, sizeof val, "%+.2f", c);
      o << "<rect x=\"" << left + b * cell << "\" y=\"" << top + a * cell << "\" width=\"" << cell << "\" height=\"" << cell << "\" fill=\""
        << correlationColour(c) << "\" stroke=\"#fff\"><title>" << escape(labels[a]) << " ~ " << escape(labels[b]) << ": "
        << (std::isfinite(c) ? val : "not estimated") << "</title></rect>";
      o << "<text x=\"" << left + b * cell + cell / 2 << "\" y=\"" << top + a * cell + cell / 2 + 4 << "\" text-anchor=\"middle\" fill=\""
        << (std::isfinite(c) && std::abs(c) > 0.6 ? "#fff" : "#000") << "\">" << (std::isfinite(c) ? val : "—") << "</text>";
    }
  }
  o << "</svg>";
  return o.str();
}

std::string svgClassedGrid(int nx, int ny, const std::function<double(int x, int y)>& value, const std::vector<double>& thresholds,
                           int max_cells) {
  const int step = std::max(1, (std::max(nx, ny) + max_cells - 1) / max_cells);
  const int w = (nx + step - 1) / step, h = (ny + step - 1) / step;
  const int px = std::max(1, 400 / std::max(w, h));
  static const char* colours[] = {"#1a9850", "#fee08b", "#fc8d59", "#d73027"};
  std::ostringstream o;
  o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << w * px << "\" height=\"" << h * px << "\" style=\"background:#eee\">";
  for (int by = 0; by < h; ++by)
    for (int bx = 0; bx < w; ++bx) {
      double worst = -std::numeric_limits<double>::infinity();
      for (int y = by * step; y < std::min(ny, (by + 1) * step); ++y)
        for (int x = bx * step; x < std::min(nx, (bx + 1) * step); ++x)
          if (const double v = value(x, y); !std::isnan(v)) worst = std::max(worst, v);
      if (worst == -std::numeric_limits<double>::infinity()) continue;
      std::size_t c = 0;
      while (c < thresholds.size() && c < 3 && worst > thresholds[c]) ++c;
      o << "<rect x=\"" << bx * px << "\" y=\"" << by * px << "\" width=\"" << px << "\" height=\"" << px << "\" fill=\"" << colours[c]
        << "\"/>";
    }
  o << "</svg>";
  return o.str();
}

}  // namespace mountcal
