#include "mountcal/mounting_calibrator.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <set>
#include <sstream>

#include "mountcal/error.hpp"

namespace mountcal {

const char* toString(CalibrationMethod m) {
  switch (m) {
    case CalibrationMethod::kVtpm: return "vtpm";
    case CalibrationMethod::kPlanes: return "planes";
    case CalibrationMethod::kCorrespondences: return "correspondences";
    case CalibrationMethod::kFeatures: return "features";
  }
  return "unknown";
}

bool MountingCalibrator::Options::IsValid(std::string* error) const {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  if (!TieObservationOptions::IsValid(error) || !MountingAdjustment::Options::IsValid(error)) return false;
  if (methods.empty()) return fail("methods is empty: name at least one calibration method");
  if (threads < 0 || threads > 4096) return fail("threads must be in [0, 4096] (0: every core)");
  if (!(vtp.radius_m > 0) || !(vtp.ransac_threshold_m > 0) || vtp.ransac_iterations < 1) return fail("vtp radius, RANSAC threshold and iterations must be positive");
  if (!(vtp.max_radius_m >= vtp.radius_m)) return fail("vtp.max_radius_m must be at least vtp.radius_m");
  std::string why;
  if (!planes.IsValid(&why)) return fail("planes: " + why);
  if (!correspondence.IsValid(&why)) return fail("correspondence: " + why);
  if (!features.IsValid(&why)) return fail("features: " + why);
  return true;
}

bool MountingCalibrator::Summary::uses(CalibrationMethod m) const {
  return std::find(methods.begin(), methods.end(), toString(m)) != methods.end();
}

MountingCalibrator::Summary MountingCalibrator::calibrate(const CalibrationData& data) const {
  const auto t_start = std::chrono::steady_clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count(); };
  const Options& o = options_;
  Summary S;
  S.mounting_used = data.mounting_used;
  S.mounting = data.mounting_used;
  S.sigma.fill(std::nan(""));
  std::string why;
  if (!o.IsValid(&why)) {
    S.termination = TerminationType::kInvalidInput;
    S.message = "invalid options: " + why;
    return S;
  }
  data.requirePoses();
  std::set<CalibrationMethod> methods(o.methods.begin(), o.methods.end());
  for (CalibrationMethod m : methods) S.methods.push_back(toString(m));

  // ---- each method turns the strips (+ user input) into observation blocks -------------------
  std::unique_ptr<TieObservations> ties, control;
  std::unique_ptr<PlaneObservations> planes;
  std::unique_ptr<CorrespondenceObservations> corr;
  std::unique_ptr<FeatureObservations> features;
  std::vector<ObservationSource*> sources;
  std::vector<GroundControlPoint> free_gcps = data.gcps;  // GCPs not tied to a VTPM tie
  if (methods.count(CalibrationMethod::kVtpm)) {
    ties = std::make_unique<TieObservations>(data, data.ties, data.gcps, o, o.vtp, "ties", o.threads);
    std::set<std::string> tie_ids;
    for (const TieObservation& t : data.ties) tie_ids.insert(t.tie_id);
    free_gcps.erase(std::remove_if(free_gcps.begin(), free_gcps.end(), [&](const GroundControlPoint& g) { return tie_ids.count(g.id) > 0; }),
                    free_gcps.end());
    if (ties->observationCount() > 0) sources.push_back(ties.get());
  }
  if (!free_gcps.empty()) {
    control = TieObservations::control(data, free_gcps, o, o.vtp, o.threads);
    if (control->observationCount() > 0) sources.push_back(control.get());
  }
  if (methods.count(CalibrationMethod::kPlanes)) {
    planes = std::make_unique<PlaneObservations>(data, o.planes);
    if (planes->observationCount() > 0) sources.push_back(planes.get());
  }
  if (methods.count(CalibrationMethod::kCorrespondences)) {
    corr = std::make_unique<CorrespondenceObservations>(data, o.correspondence, o.threads);
    sources.push_back(corr.get());
  }
  if (methods.count(CalibrationMethod::kFeatures)) {
    features = std::make_unique<FeatureObservations>(data, o.features);
    if (features->observationCount() > 0) sources.push_back(features.get());
  }
  const double construction_s = elapsed();
  auto fillSections = [&] {
    if (ties) {
      const TieSection& t = ties->section();
      S.ties_used = t.ties_used;
      S.observations_used = t.observations_used;
      S.rejected = t.rejected;
      S.residuals = t.residuals;
      S.rms_before_m = t.rms_before_m;
      S.rms_after_m = t.rms_after_m;
      S.tie_sigma_xy_m = t.sigma_xy_m;
      S.tie_sigma_z_m = t.sigma_z_m;
      S.tie_sigma_estimated = t.sigma_estimated;
    }
    if (control) S.control = control->section();
    if (planes) S.planes = planes->section();
    if (corr) S.correspondences = corr->section();
    if (features) S.features = features->section();
  };
  if (sources.empty()) {
    fillSections();
    S.termination = TerminationType::kInvalidInput;
    if (ties && methods.size() == 1) {
      S.message = "no usable tie: " + std::to_string(S.rejected.size()) + " tie observations rejected (see rejected)";
    } else {
      S.message = "no usable observation: every method's input was rejected (see the rejected lists)";
    }
    S.time_s = elapsed();
    return S;
  }

  // ---- one adjustment -------------------------------------------------------------------------
  const std::vector<std::string> names = S.methods;
  // The paper's closed form is the starting value of the rigorous solution (seed 002 §2.3).
  std::array<double, 6> start = data.mounting_used.toArray();
  const bool from_closed_form = features && features->section().closed_form.valid;
  if (from_closed_form) start = features->section().closed_form.mounting.toArray();
  static_cast<AdjustmentSummary&>(S) = MountingAdjustment(o).solve(data.mounting_used, sources, from_closed_form ? &start : nullptr);
  S.methods = names;
  S.construction_time_s += construction_s;
  fillSections();
  S.time_s = elapsed();
  return S;
}

// ---- reports ----------------------------------------------------------------------------------

namespace {
std::string methodList(const std::vector<std::string>& m) {
  std::string s;
  for (const auto& x : m) s += (s.empty() ? "" : "+") + x;
  return s.empty() ? "none" : s;
}
}  // namespace

std::string MountingCalibrator::Summary::BriefReport() const {
  char buf[640];
  const Vec3 b = mounting.boresightDeg();
  std::string what;
  if (uses(CalibrationMethod::kVtpm)) {
    std::snprintf(buf, sizeof buf, "%d ties / %d observations (%zu rejected); ", ties_used, observations_used, rejected.size());
    what += buf;
  }
  if (uses(CalibrationMethod::kPlanes)) {
    std::snprintf(buf, sizeof buf, "%d patches / %d points; ", planes.patches_used, planes.points_used);
    what += buf;
  }
  if (uses(CalibrationMethod::kCorrespondences)) {
    std::snprintf(buf, sizeof buf, "%d correspondences (%d matchings); ", correspondences.used, correspondences.rounds);
    what += buf;
  }
  if (uses(CalibrationMethod::kFeatures)) {
    std::snprintf(buf, sizeof buf, "%d targets / %d views / %zu pairs (%zu rejected); ", features.targets_used, features.views_used,
                  features.pairs.size(), features.rejected.size());
    what += buf;
  }
  std::snprintf(buf, sizeof buf,
                "mountcal %s: %s, %d iterations, cost %.4g -> %.4g, %slever arm (%.4f, %.4f, %.4f) m, boresight (%.5f, %.5f, %.5f) deg",
                methodList(methods).c_str(), toString(termination), iterations, initial_cost, final_cost, what.c_str(), mounting.a_b.x(),
                mounting.a_b.y(), mounting.a_b.z(), b.x(), b.y(), b.z());
  std::string out = buf;
  if (uses(CalibrationMethod::kVtpm)) {
    std::snprintf(buf, sizeof buf, "; RMS after (%.3f, %.3f, %.3f) m", rms_after_m.x(), rms_after_m.y(), rms_after_m.z());
    out += buf;
  }
  return out;
}

std::string MountingCalibrator::Summary::FullReport() const {
  std::ostringstream r;
  char buf[320];
  r << "mountcal — mounting calibration (" << methodList(methods) << ")\n\n";
  r << "Termination: " << toString(termination) << " (" << message << ")\n";
  std::snprintf(buf, sizeof buf, "Iterations %d, cost %.6g -> %.6g, %.3f s (construction %.3f, solve %.3f, analysis %.3f)\n",
                iterations, initial_cost, final_cost, time_s, construction_time_s, solve_time_s, analysis_time_s);
  r << buf;
  for (const auto& k : kinds) r << "  " << k.kind << ": " << k.blocks << " residual blocks, " << k.residuals << " residuals\n";
  std::snprintf(buf, sizeof buf, "Ties %d, observations %d, rejected %zu, degrees of freedom %d, variance factor %.4g\n\n",
                ties_used, observations_used, rejected.size(), degrees_of_freedom, variance_factor);
  r << buf;
  r << "parameter            used            estimated       sigma\n";
  const auto& names = mountingParameterNames();
  const auto used = mounting_used.toArray(), est = mounting.toArray();
  for (int j = 0; j < 6; ++j) {
    const bool lin = j < 3;
    const double k = lin ? 1.0 : 180.0 / kPi;
    const char* unit = lin ? "m  " : "deg";
    std::string sig = estimated[j] ? "" : "fixed";
    if (estimated[j]) {
      std::snprintf(buf, sizeof buf, "%.6f %s", sigma[j] * k, unit);
      sig = buf;
    } else if (std::find(unobservable.begin(), unobservable.end(), names[j]) != unobservable.end()) {
      sig = "undeterminable";
    }
    std::snprintf(buf, sizeof buf, "%-18s %+12.6f %s %+12.6f %s  %s\n", names[j].c_str(), used[j] * k, unit, est[j] * k, unit, sig.c_str());
    r << buf;
  }
  if (!observability_report.empty()) r << "\nObservability:\n" << observability_report;
  std::snprintf(buf, sizeof buf, "\nCondition number of the estimated block (normalised): %.3g\n", condition_number);
  r << buf;
  r << "\nCorrelations:\n";
  for (int a = 0; a < 6; ++a) {
    for (int b = 0; b < 6; ++b) {
      if (std::isnan(correlation(a, b))) r << "      -";
      else {
        std::snprintf(buf, sizeof buf, " %+6.3f", correlation(a, b));
        r << buf;
      }
    }
    r << "   " << names[a] << "\n";
  }
  if (uses(CalibrationMethod::kVtpm)) {
    std::snprintf(buf, sizeof buf, "\nTies: RMS before (%.4f, %.4f, %.4f) m, after (%.4f, %.4f, %.4f) m\n", rms_before_m.x(),
                  rms_before_m.y(), rms_before_m.z(), rms_after_m.x(), rms_after_m.y(), rms_after_m.z());
    r << buf;
    std::snprintf(buf, sizeof buf, "Tie sigma %s: horizontal %.4f m, vertical %.4f m\n",
                  tie_sigma_estimated ? "estimated from the residuals (variance components)" : "as stated", tie_sigma_xy_m, tie_sigma_z_m);
    r << buf;
    for (const RejectedTie& t : rejected) r << "rejected tie " << t.tie_id << " on strip " << t.strip_id << ": " << t.reason << "\n";
    for (const TieResidual& t : residuals)
      if (t.outlier) r << "outlier: tie " << t.tie_id << " on strip " << t.strip_id << ", residual " << t.after_m.norm() << " m\n";
  }
  if (control.observations_used > 0 || !control.rejected.empty()) {
    std::snprintf(buf, sizeof buf, "\nGround control: %d points, %d observations; RMS after (%.4f, %.4f, %.4f) m\n", control.ties_used,
                  control.observations_used, control.rms_after_m.x(), control.rms_after_m.y(), control.rms_after_m.z());
    r << buf;
    for (const RejectedTie& t : control.rejected) r << "rejected control point " << t.tie_id << " on strip " << t.strip_id << ": " << t.reason << "\n";
  }
  if (uses(CalibrationMethod::kPlanes)) {
    std::snprintf(buf, sizeof buf, "\nPlanes (%s): %d patches, %d points, sigma %.4f m; RMS before %.4f m, after %.4f m\n",
                  planes.automatic ? "found automatically" : "given regions", planes.patches_used, planes.points_used, planes.sigma_m,
                  planes.rms_before_m, planes.rms_after_m);
    r << buf;
    r << "  patch                 strips points  tilt[deg] aspect[deg]  RMS before [m]  after [m]\n";
    for (const PatchResidual& p : planes.patches) {
      const double tilt = rad2deg(std::acos(std::min(1.0, std::abs(p.normal.z()))));
      const double aspect = std::fmod(rad2deg(std::atan2(p.normal.x(), p.normal.y())) + 360.0, 360.0);
      std::snprintf(buf, sizeof buf, "  %-22s %5d %6d %9.1f %10.1f %15.4f %10.4f%s\n", p.patch_id.c_str(), p.strips, p.points, tilt, aspect,
                    p.rms_before_m, p.rms_after_m, p.outlier ? "  outlier" : "");
      r << buf;
    }
    for (const RejectedPatch& p : planes.rejected)
      r << "rejected patch " << p.patch_id << (p.strip_id.empty() ? "" : " on strip " + p.strip_id) << ": " << p.reason << "\n";
  }
  if (uses(CalibrationMethod::kFeatures)) {
    const FeatureSection& F = features;
    std::snprintf(buf, sizeof buf,
                  "\nFeatures (seed 002): %d targets, %d views; centre RMS before (%.4f, %.4f, %.4f) m, after (%.4f, %.4f, %.4f) m; "
                  "sigma %s: along the normal %.4f m, in the plane %.4f m; extraction %.3f s, matching %.3f s\n",
                  F.targets_used, F.views_used, F.rms_before_m.x(), F.rms_before_m.y(), F.rms_before_m.z(), F.rms_after_m.x(),
                  F.rms_after_m.y(), F.rms_after_m.z(), F.sigma_estimated ? "estimated (variance components)" : "as stated",
                  F.sigma_normal_m, F.sigma_in_plane_m, F.extraction_time_s, F.matching_time_s);
    r << buf;
    r << "  target        A     B     relation   H [m]   y_A [m]   D [m]   offset along/cross/down [m]      ICP it  RMS [m]\n";
    for (const FeaturePairOffset& p : F.pairs) {
      std::snprintf(buf, sizeof buf, "  %-12s %-5s %-5s %-9s %7.2f %8.2f %7.2f   %+8.4f %+8.4f %+8.4f   %6d %8.4f\n", p.target_id.c_str(),
                    p.strip_a.c_str(), p.strip_b.c_str(), p.relation.c_str(), p.height_m, p.lateral_a_m, p.line_offset_m,
                    p.offset_afd_m.x(), p.offset_afd_m.y(), p.offset_afd_m.z(), p.icp_iterations, p.icp_rms_m);
      r << buf;
    }
    const FeatureClosedForm& C = F.closed_form;
    if (C.valid) {
      const Vec3 cb = C.mounting.boresightDeg(), rb = mounting.boresightDeg();
      r << "Closed form (SPEC §2, seed 002 eqs. 8-10) versus the rigorous adjustment:\n"
           "  angle     closed form [deg]  sigma [deg]  spread [deg]  pairs   rigorous [deg]\n";
      const char* names[3] = {"roll", "pitch", "heading"};
      for (int a = 0; a < 3; ++a) {
        std::snprintf(buf, sizeof buf, "  %-8s %+17.5f %12.5f %13.5f %6d %+16.5f\n", names[a], cb(a), rad2deg(C.boresight_sigma_rad(a)),
                      rad2deg(C.boresight_spread_rad(a)), C.pairs_used[a], rb(a));
        r << buf;
      }
      if (C.lever_arm_estimated) {
        std::snprintf(buf, sizeof buf, "  lever arm x, y (two heights): %+.4f, %+.4f m (sigma %.4f, %.4f m)\n", C.mounting.a_b.x(), C.mounting.a_b.y(),
                      C.lever_arm_sigma_m.x(), C.lever_arm_sigma_m.y());
        r << buf;
      }
    }
    if (!C.message.empty()) r << "  closed form: " << C.message << "\n";
    for (const RejectedFeature& t : F.rejected)
      r << "rejected target " << t.target_id << (t.strip_id.empty() ? "" : " on strip " + t.strip_id) << ": " << t.reason << "\n";
  }
  if (uses(CalibrationMethod::kCorrespondences)) {
    const auto& c = correspondences;
    std::snprintf(buf, sizeof buf,
                  "\nCorrespondences: %d used after %d matchings (r %.2f m, spacing %.2f m, sigma %.4f m); |distance| median %.4f -> %.4f m, "
                  "RMS %.4f -> %.4f m\n",
                  c.used, c.rounds, c.radius_m, c.spacing_m, c.sigma_m, c.median_before_m, c.median_after_m, c.rms_before_m, c.rms_after_m);
    r << buf;
    r << "  pair        samples  kept  sparse rough  far normal  MAD budget   median before/after [m]   RMS before/after [m]\n";
    for (const auto& p : c.pairs) {
      std::snprintf(buf, sizeof buf, "  %-5s %-5s %7d %5d %7d %5d %4d %6d %4d %6d   %10.4f %10.4f   %10.4f %10.4f\n", p.strip_a.c_str(),
                    p.strip_b.c_str(), p.samples, p.kept, p.rejected_sparse, p.rejected_rough, p.rejected_far, p.rejected_normal,
                    p.rejected_mad, p.rejected_budget, p.median_before_m, p.median_after_m, p.rms_before_m, p.rms_after_m);
      r << buf;
    }
    if (!c.laser_elevation_deg.empty()) {
      r << "Per-laser elevation offsets (by laser id; mean held at 0; sigma a priori, the mounting's sigma above eliminates them):\n"
           "  laser  offset [deg]  sigma [deg]  max|corr| with boresight  points\n";
      for (std::size_t i = 0; i < c.laser_elevation_deg.size(); ++i) {
        std::snprintf(buf, sizeof buf, "  %5zu  %+12.4f  %11.4f  %24.2f  %6d\n", i, c.laser_elevation_deg[i], c.laser_elevation_sigma_deg[i],
                      c.laser_boresight_correlation[i], c.laser_points[i]);
        r << buf;
      }
    }
  }
  return r.str();
}

MountingCalibrator::Summary calibrate(const CalibrationData& data, const MountingCalibrator::Options& options) {
  return MountingCalibrator(options).calibrate(data);
}

}  // namespace mountcal
