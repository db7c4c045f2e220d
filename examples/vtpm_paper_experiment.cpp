// The first paper's experiments on simulated surveys with known truth (seed 000 §3):
//   experiment 1 — calibrate on the crossing field (760 m and 1310 m strips) with 5 ties and
//                  12 tie observations → Table 1 (tie residuals before and after);
//   experiment 2 — correct the 3200 m check block with the calibrated mounting → Table 2
//                  (check points) and Table 3 (check planes, seed eq. 13).
// Prints the three tables and the recovered mounting against the truth; returns non-zero when
// the calibration is not usable or does not improve the check data.
//
//   vtpm_paper_experiment [--seed N] [--all-ties]
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <set>
#include <string>

#include "mountcal/mountcal.hpp"

using namespace mountcal;
using namespace mountcal::simulation;

namespace {

SimulatedSurvey run(const std::string& preset, std::uint64_t seed) {
  Scene scene;
  SurveyConfig config;
  makePreset(preset, seed, &config, &scene);
  return simulate(config, scene);
}

void table(const char* title, const std::vector<std::string>& labels, const std::vector<Vec3>& a, const std::vector<Vec3>& b,
           const char* ha, const char* hb) {
  std::printf("\n%s\n%-16s %9s %9s %9s | %9s %9s %9s\n", title, "", ha, "", "", hb, "", "");
  std::printf("%-16s %9s %9s %9s | %9s %9s %9s\n", "point", "dX", "dY", "dZ", "dX", "dY", "dZ");
  Vec3 sa = Vec3::Zero(), sb = Vec3::Zero();
  for (std::size_t i = 0; i < a.size(); ++i) {
    std::printf("%-16s %+9.3f %+9.3f %+9.3f | %+9.3f %+9.3f %+9.3f\n", labels[i].c_str(), a[i].x(), a[i].y(), a[i].z(), b[i].x(), b[i].y(),
                b[i].z());
    sa += a[i].cwiseAbs2();
    sb += b[i].cwiseAbs2();
  }
  const double n = static_cast<double>(std::max<std::size_t>(a.size(), 1));
  std::printf("%-16s %9.4f %9.4f %9.4f | %9.4f %9.4f %9.4f\n", "RMS", std::sqrt(sa.x() / n), std::sqrt(sa.y() / n), std::sqrt(sa.z() / n),
              std::sqrt(sb.x() / n), std::sqrt(sb.y() / n), std::sqrt(sb.z() / n));
}

}  // namespace

int main(int argc, char** argv) {
  std::uint64_t seed = 1;
  bool all_ties = false;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--seed") && i + 1 < argc)
      seed = std::strtoull(argv[++i], nullptr, 10);
    else if (!std::strcmp(argv[i], "--all-ties"))
      all_ties = true;
    else {
      std::fprintf(stderr, "usage: %s [--seed N] [--all-ties]\n", argv[0]);
      return 2;
    }
  }
  try {
    // ---- experiment 1: the crossing field -----------------------------------------------
    const SimulatedSurvey field = run("paper-calibration-field", seed);
    CalibrationData data = toCalibrationData(field);
    if (!all_ties) data.ties = paperFiveTies(field);
    std::set<std::string> tie_ids;
    for (const auto& t : data.ties) tie_ids.insert(t.tie_id);
    std::printf("Experiment 1: %s, seed %llu, %zu strips, %zu ties, %zu tie observations\n", field.config.name.c_str(),
                static_cast<unsigned long long>(seed), field.strips.size(), tie_ids.size(), data.ties.size());
    std::printf("noise: range 2 cm, scan angle 0.001°, GNSS 1.5 cm (100 s), attitude 0.001°/0.002° (0.1 s), picking 5 cm\n");
    const MountingCalibrator::Summary S = calibrate(data);
    std::vector<std::string> labels;
    std::vector<Vec3> before, after;
    for (const TieResidual& r : S.section<VtpmSection>().residuals) {
      labels.push_back(r.tie_id + "/" + r.strip_id);
      before.push_back(r.before_m);
      after.push_back(r.after_m);
    }
    table("Table 1 — tie residuals [m] (seed eq. 8)", labels, before, after, "before", "after");
    const MountingParameters& truth = field.config.true_mounting;
    std::printf("\n%-18s %12s %12s %12s %12s\n", "parameter", "truth", "calibrated", "sigma", "error");
    const auto& names = mountingParameterNames();
    const auto t = truth.toArray(), e = S.mounting.toArray();
    for (int j = 0; j < 6; ++j) {
      const double k = j < 3 ? 1.0 : 180.0 / kPi;
      const char* unit = j < 3 ? "m" : "deg";
      std::printf("%-18s %+12.5f %+12.5f %12s %+12.5f %s%s\n", names[j].c_str(), t[j] * k, e[j] * k,
                  S.estimated[j] ? std::to_string(S.sigma[j] * k).substr(0, 8).c_str() : "-", (e[j] - t[j]) * k, unit,
                  S.estimated[j] ? "" : "  (not estimated)");
    }
    std::printf("%s\n", S.BriefReport().c_str());
    if (!S.observability_report.empty()) std::printf("%s", S.observability_report.c_str());

    // ---- experiment 2: the 3200 m check block ----------------------------------------------
    const SimulatedSurvey block = run("paper-check-block", seed);
    const CalibrationData check = toCalibrationData(block, /*use_check_points=*/true);
    const CheckPointReport cb = evaluateCheckPoints(check, block.config.nominal_mounting);
    const CheckPointReport ca = evaluateCheckPoints(check, S.mounting);
    std::printf("\nExperiment 2: %s, %zu strips at 3200 m, %zu check-point observations\n", block.config.name.c_str(), block.strips.size(),
                ca.residuals.size());
    std::vector<std::string> cl;
    std::vector<Vec3> b2, a2;
    for (std::size_t i = 0; i < ca.residuals.size() && i < cb.residuals.size(); ++i) {
      cl.push_back(ca.residuals[i].tie_id + "/" + ca.residuals[i].strip_id);
      b2.push_back(cb.residuals[i].residual_m);
      a2.push_back(ca.residuals[i].residual_m);
    }
    table("Table 2 — check-point residuals [m]", cl, b2, a2, "before", "VTPM");
    std::vector<PlaneRegion> planes;
    for (const auto& p : block.check_planes) planes.push_back({p.id, p.xmin, p.ymin, p.xmax, p.ymax});
    const auto pb = evaluateCheckPlanes(check, planes, block.config.nominal_mounting);
    const auto pa = evaluateCheckPlanes(check, planes, S.mounting);
    std::printf("\nTable 3 — check planes, RMS = sqrt(sum d^2 / (n - 3)) [m] (seed eq. 13)\n%-10s %8s %10s %10s\n", "plane", "points",
                "before", "VTPM");
    bool planes_improve = true;
    for (std::size_t i = 0; i < pa.size(); ++i) {
      std::printf("%-10s %8d %10.4f %10.4f\n", pa[i].plane_id.c_str(), pa[i].points, pb[i].rms_m, pa[i].rms_m);
      planes_improve = planes_improve && pa[i].rms_m < pb[i].rms_m;
    }
    const bool ok = S.IsSolutionUsable() && ca.rms_m.norm() < cb.rms_m.norm() && planes_improve;
    std::printf("\n%s\n", ok ? "OK: calibrated, and the check data improved." : "FAILED: see above.");
    return ok ? 0 : 1;
  } catch (const Error& e) {
    std::fprintf(stderr, "vtpm_paper_experiment: %s\n", e.what());
    return 2;
  }
}
