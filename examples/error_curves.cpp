// The first paper's Figs 1–3: how a 0.1° boresight misalignment displaces line-scanner points,
// as a function of scan angle and range. Writes fig_errors.csv and fig1_x.svg, fig2_y.svg,
// fig3_z.svg into --out DIR (default: the current directory) and prints a short table.
//
//   error_curves [--out DIR] [--boresight-deg DEG]
#include <cstdio>
#include <cstring>
#include <string>

#include "mountcal/mountcal.hpp"

int main(int argc, char** argv) {
  using namespace mountcal;
  std::string out = ".";
  double delta_deg = 0.1;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--out") && i + 1 < argc) {
      out = argv[++i];
    } else if (!std::strcmp(argv[i], "--boresight-deg") && i + 1 < argc) {
      delta_deg = std::atof(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: %s [--out DIR] [--boresight-deg DEG]\n", argv[0]);
      return 2;
    }
  }
  std::vector<double> angles, ranges{500, 1000, 1500, 2000};
  for (int a = -45; a <= 45; ++a) angles.push_back(deg2rad(a));
  const Vec3 bore = Vec3::Constant(deg2rad(delta_deg));
  const auto samples = boresightErrorCurves(bore, angles, ranges);
  try {
    writeErrorCurves(out, samples, delta_deg);
  } catch (const Error& e) {
    std::fprintf(stderr, "error_curves: %s\n", e.what());
    return 2;
  }
  std::printf("Boresight error of a line scanner, ω = φ = κ = %.3f°, body axes [m]\n", delta_deg);
  std::printf("%8s %8s %10s %10s %10s\n", "range_m", "theta", "x_along", "y_cross", "z_vert");
  for (const auto& s : samples) {
    const int a = static_cast<int>(std::lround(rad2deg(s.scan_angle_rad)));
    if (a % 15 != 0) continue;
    std::printf("%8.0f %7d° %10.3f %10.3f %10.3f\n", s.range_m, a, s.exact_b.x(), s.exact_b.y(), s.exact_b.z());
  }
  std::printf("wrote %s/fig_errors.csv, fig1_x.svg, fig2_y.svg, fig3_z.svg\n", out.c_str());
  return 0;
}
