#pragma once
/// \file svg_plot.hpp
/// A minimal, dependency-free SVG line chart for reports and examples.

#include <functional>
#include <string>
#include <vector>

namespace mountcal {

/// Line chart with linear axes, ticks, grid and a legend. render() returns the SVG document.
class SvgLinePlot {
 public:
  SvgLinePlot(std::string title, std::string x_label, std::string y_label)
      : title_(std::move(title)), x_label_(std::move(x_label)), y_label_(std::move(y_label)) {}

  /// Adds one curve; xs and ys must have the same size (extra values are ignored).
  void addSeries(std::string name, std::vector<double> xs, std::vector<double> ys);

  /// The SVG document (UTF-8), `width` × `height` pixels.
  std::string render(int width = 720, int height = 440) const;

 private:
  struct Series {
    std::string name;
    std::vector<double> xs, ys;
  };
  std::string title_, x_label_, y_label_;
  std::vector<Series> series_;
};

/// A correlation matrix as a heat map: n × n cells coloured from blue (−1) through white (0) to
/// red (+1), the value written in each cell, `labels` on both axes; NaN cells grey with "—".
/// Returns an SVG element (inline in HTML).
std::string svgCorrelationHeatMap(const std::vector<std::string>& labels, const std::vector<double>& values_row_major, int cell_px = 64);

/// The colour of a correlation in the heat map ("#rrggbb").
std::string correlationColour(double c);

/// A raster as an SVG map (about 400 px a side): nx × ny cells, row 0 at the top, each coloured
/// by the class of its value — ≤ thresholds[0] green, ≤ [1] yellow, ≤ [2] orange, beyond red —
/// with NaN cells left grey. At most `max_cells` cells a side: coarser blocks take their largest
/// value. Returns an SVG element (inline in HTML).
std::string svgClassedGrid(int nx, int ny, const std::function<double(int x, int y)>& value, const std::vector<double>& thresholds,
                           int max_cells = 100);

}  // namespace mountcal
