#include "mountcal/svg_plot.hpp"

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
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '&': out += "&amp;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
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
  static const char* kColours[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e",
                                   "#9467bd", "#8c564b", "#e377c2", "#17becf"};
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
  if (!(x1 > x0)) { x0 = std::isfinite(x0) ? x0 - 1 : 0; x1 = x0 + 2; }
  if (!(y1 > y0)) { y0 = std::isfinite(y0) ? y0 - 1 : 0; y1 = y0 + 2; }
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
  svg << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << width << "\" height=\""
      << height << "\" font-family=\"sans-serif\" font-size=\"12\">\n"
      << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
      << "<text x=\"" << width / 2 << "\" y=\"22\" text-anchor=\"middle\" font-size=\"15\">"
      << escape(title_) << "</text>\n";
  for (double y = y0; y <= y1 + 1e-9 * ystep; y += ystep) {
    svg << "<line x1=\"" << left << "\" x2=\"" << left + pw << "\" y1=\"" << Y(y) << "\" y2=\""
        << Y(y) << "\" stroke=\"#ddd\"/><text x=\"" << left - 6 << "\" y=\"" << Y(y) + 4
        << "\" text-anchor=\"end\">" << fmt(y) << "</text>\n";
  }
  for (double x = x0; x <= x1 + 1e-9 * xstep; x += xstep) {
    svg << "<line y1=\"" << top << "\" y2=\"" << top + ph << "\" x1=\"" << X(x) << "\" x2=\""
        << X(x) << "\" stroke=\"#ddd\"/><text x=\"" << X(x) << "\" y=\"" << top + ph + 18
        << "\" text-anchor=\"middle\">" << fmt(x) << "</text>\n";
  }
  svg << "<rect x=\"" << left << "\" y=\"" << top << "\" width=\"" << pw << "\" height=\"" << ph
      << "\" fill=\"none\" stroke=\"black\"/>\n"
      << "<text x=\"" << left + pw / 2 << "\" y=\"" << height - 15
      << "\" text-anchor=\"middle\">" << escape(x_label_) << "</text>\n"
      << "<text transform=\"translate(18," << top + ph / 2
      << ") rotate(-90)\" text-anchor=\"middle\">" << escape(y_label_) << "</text>\n";
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
    svg << "<line x1=\"" << left + pw + 12 << "\" x2=\"" << left + pw + 36 << "\" y1=\"" << ly
        << "\" y2=\"" << ly << "\" stroke=\"" << colour << "\" stroke-width=\"2\"/><text x=\""
        << left + pw + 42 << "\" y=\"" << ly + 4 << "\">" << escape(s.name) << "</text>\n";
  }
  svg << "</svg>\n";
  return svg.str();
}

}  // namespace mountcal
