#include "mountcal/job/result.hpp"

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

#include "json_fields.hpp"
#include "mountcal/error.hpp"

namespace mountcal {

using nlohmann::json;

void applyLaserElevation(CalibrationData* data, const std::vector<double>& offsets) {
  if (offsets.empty()) return;
  for (StripData& s : data->strips) {
    if (s.laser.empty()) continue;
    for (std::size_t i = 0; i < s.r_s.size(); ++i) {
      if (s.laser[i] >= offsets.size()) throw InvalidInput("strip '" + s.id + "': laser id " + std::to_string(s.laser[i]) + " has no elevation offset");
      s.r_s[i] = elevateLaserVector(s.r_s[i], offsets[s.laser[i]]);
    }
    s.x_m.clear();
  }
}

ResultEvaluation evaluateJob(const Job& job, const LoadedJob& loaded, const MountingParameters& mounting, bool discrepancy,
                             const std::vector<double>& laser_elevation_rad) {
  ResultEvaluation ev;
  CalibrationData check = loaded.data;
  check.ties = loadCheckPoints(job, loaded);
  const std::vector<PlaneRegion> planes = loadCheckPlanes(job, loaded);
  if (!check.ties.empty()) {
    ev.has_check_points = true;
    ev.check_points_before = evaluateCheckPoints(check, job.mounting_used, job.options.vtp);
    ev.check_points_after = evaluateCheckPoints(check, mounting, job.options.vtp);
  }
  if (!planes.empty()) {
    ev.check_planes_before = evaluateCheckPlanes(check, planes, job.mounting_used);
    ev.check_planes_after = evaluateCheckPlanes(check, planes, mounting);
  }
  if ((discrepancy || job.per_point_poses) && loaded.data.strips.size() >= 2) {
    ev.discrepancy_before = passDiscrepancies(loaded.data, job.mounting_used);
    if (laser_elevation_rad.empty()) {
      ev.discrepancy_after = passDiscrepancies(loaded.data, mounting);
    } else {
      CalibrationData d = loaded.data;
      applyLaserElevation(&d, laser_elevation_rad);
      ev.discrepancy_after = passDiscrepancies(d, mounting);
    }
  }
  return ev;
}

namespace {
json numOrNull(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }
json vec(const Vec3& v) { return json::array({v.x(), v.y(), v.z()}); }
}  // namespace

std::string resultJson(const MountingCalibrator::Summary& S, const ResultEvaluation* ev) {
  const Vec3 b = S.mounting.boresightDeg();
  json j;
  j["mounting"] = {{"lever_arm_m", vec(S.mounting.a_b)}, {"boresight_deg", vec(b)}};
  json sl = json::array(), sb = json::array();
  for (int i = 0; i < 3; ++i) {
    sl.push_back(numOrNull(S.sigma[i]));
    sb.push_back(numOrNull(rad2deg(S.sigma[3 + i])));
  }
  j["sigma"] = {{"lever_arm_m", sl}, {"boresight_deg", sb}};
  json corr = json::array();
  for (int a = 0; a < 6; ++a) {
    json row = json::array();
    for (int c = 0; c < 6; ++c) row.push_back(numOrNull(S.correlation(a, c)));
    corr.push_back(row);
  }
  j["correlation"] = corr;
  j["estimated"] = {{"lever_arm", {S.estimated[0], S.estimated[1], S.estimated[2]}},
                    {"boresight", {S.estimated[3], S.estimated[4], S.estimated[5]}}};
  j["unobservable"] = S.unobservable;
  j["observability_report"] = S.observability_report;
  json rejected = json::array();
  for (const RejectedTie& r : S.rejected) rejected.push_back({{"tie_id", r.tie_id}, {"strip_id", r.strip_id}, {"reason", r.reason}});
  j["ties"] = {{"used", S.ties_used}, {"observations", S.observations_used}, {"rejected", rejected}};
  j["rms_before_m"] = vec(S.rms_before_m);
  j["rms_after_m"] = vec(S.rms_after_m);
  json res = json::array();
  for (const TieResidual& r : S.residuals) {
    res.push_back({{"tie_id", r.tie_id}, {"strip_id", r.strip_id}, {"before_m", vec(r.before_m)}, {"after_m", vec(r.after_m)}, {"outlier", r.outlier}});
  }
  j["residuals"] = res;
  json offs = json::object();
  for (const auto& [id, o] : S.strip_offsets_m) offs[id] = vec(o);
  j["strip_offsets_m"] = offs;
  j["variance_factor"] = S.variance_factor;
  j["degrees_of_freedom"] = S.degrees_of_freedom;
  j["solver"] = {{"termination", toString(S.termination)}, {"message", S.message}, {"iterations", S.iterations},
                 {"rematch_rounds", S.rematch_rounds}, {"initial_cost", S.initial_cost}, {"final_cost", S.final_cost},
                 {"time_s", S.time_s}, {"construction_time_s", S.construction_time_s}, {"solve_time_s", S.solve_time_s},
                 {"analysis_time_s", S.analysis_time_s}};
  j["methods"] = S.methods;
  json kinds = json::array();
  for (const auto& k : S.kinds) kinds.push_back({{"kind", k.kind}, {"residual_blocks", k.blocks}, {"residuals", k.residuals}});
  j["kinds"] = kinds;
  j["covariance_source"] = S.covariance_source;
  j["condition_number"] = numOrNull(S.condition_number);
  if (S.uses(CalibrationMethod::kPlanes)) {
    const PlaneSection& p = S.planes;
    json patches = json::array();
    for (const PatchResidual& r : p.patches) {
      patches.push_back({{"patch_id", r.patch_id}, {"centre_m", vec(r.centre_m)}, {"normal", vec(r.normal)}, {"points", r.points},
                         {"strips", r.strips}, {"rms_before_m", r.rms_before_m}, {"rms_after_m", r.rms_after_m}, {"outlier", r.outlier}});
    }
    json rej = json::array();
    for (const RejectedPatch& r : p.rejected) rej.push_back({{"patch_id", r.patch_id}, {"strip_id", r.strip_id}, {"reason", r.reason}});
    j["planes"] = {{"automatic", p.automatic}, {"patches_used", p.patches_used}, {"points_used", p.points_used}, {"sigma_m", p.sigma_m},
                   {"rms_before_m", p.rms_before_m}, {"rms_after_m", p.rms_after_m}, {"patches", patches}, {"rejected", rej}};
  }
  if (S.uses(CalibrationMethod::kFeatures)) {
    const FeatureSection& F = S.features;
    json targets = json::array();
    for (std::size_t k = 0; k < F.target_ids.size(); ++k) {
      json views = json::array();
      for (const FeatureView& v : F.views[k]) {
        views.push_back({{"strip_id", v.strip_id}, {"points", v.points}, {"centroid_m", vec(v.centroid_m)}, {"normal", vec(v.normal)},
                         {"plane_sigma_m", v.plane_sigma_m}, {"sigma_normal_m", v.sigma_normal_m}, {"sigma_in_plane_m", v.sigma_in_plane_m},
                         {"intensity_threshold", v.threshold}});
      }
      targets.push_back({{"target_id", F.target_ids[k]}, {"views", views}});
    }
    json pairs = json::array();
    for (const FeaturePairOffset& p : F.pairs) {
      pairs.push_back({{"target_id", p.target_id}, {"strip_a", p.strip_a}, {"strip_b", p.strip_b}, {"relation", p.relation},
                       {"offset_m", vec(p.offset_m)}, {"offset_along_cross_down_m", vec(p.offset_afd_m)},
                       {"sigma_along_cross_down_m", vec(p.covariance_afd.diagonal().cwiseSqrt())}, {"height_m", p.height_m},
                       {"lateral_a_m", p.lateral_a_m}, {"line_offset_m", p.line_offset_m}, {"icp_iterations", p.icp_iterations},
                       {"icp_rms_m", p.icp_rms_m}});
    }
    json rej = json::array();
    for (const RejectedFeature& r : F.rejected) rej.push_back({{"target_id", r.target_id}, {"strip_id", r.strip_id}, {"reason", r.reason}});
    json res = json::array();
    for (const FeatureSection::Residual& r : F.residuals)
      res.push_back({{"target_id", r.target_id}, {"strip_id", r.strip_id}, {"before_m", vec(r.before_m)}, {"after_m", vec(r.after_m)}});
    const FeatureClosedForm& C = F.closed_form;
    json cf = {{"valid", C.valid}, {"message", C.message}};
    if (C.valid) {
      auto degOrNull = [&](const Vec3& v) {
        json a = json::array();
        for (int i = 0; i < 3; ++i) a.push_back(numOrNull(rad2deg(v(i))));
        return a;
      };
      auto mOrNull = [&](const Vec3& v) {
        json a = json::array();
        for (int i = 0; i < 3; ++i) a.push_back(numOrNull(v(i)));
        return a;
      };
      cf["mounting"] = {{"lever_arm_m", vec(C.mounting.a_b)}, {"boresight_deg", vec(C.mounting.boresightDeg())}};
      cf["boresight_correction_deg"] = degOrNull(C.boresight_correction_rad);
      cf["boresight_sigma_deg"] = degOrNull(C.boresight_sigma_rad);
      cf["boresight_spread_deg"] = degOrNull(C.boresight_spread_rad);
      cf["pairs_used"] = {C.pairs_used[0], C.pairs_used[1], C.pairs_used[2]};
      cf["lever_arm_estimated"] = C.lever_arm_estimated;
      cf["lever_arm_correction_m"] = mOrNull(C.lever_arm_correction_m);
      cf["lever_arm_sigma_m"] = mOrNull(C.lever_arm_sigma_m);
      cf["pitch_lever_arm_coupled"] = C.pitch_lever_arm_coupled;
    }
    j["features"] = {{"targets_used", F.targets_used}, {"views_used", F.views_used}, {"targets", targets}, {"pairs", pairs},
                     {"closed_form", cf}, {"rejected", rej}, {"residuals", res}, {"rms_before_m", vec(F.rms_before_m)},
                     {"rms_after_m", vec(F.rms_after_m)}, {"sigma_normal_m", F.sigma_normal_m}, {"sigma_in_plane_m", F.sigma_in_plane_m},
                     {"sigma_estimated", F.sigma_estimated}, {"extraction_time_s", F.extraction_time_s}, {"matching_time_s", F.matching_time_s}};
  }
  if (S.uses(CalibrationMethod::kCorrespondences)) {
    const CorrespondenceSection& c = S.correspondences;
    json pairs = json::array();
    for (const CorrespondencePairStats& p : c.pairs) {
      pairs.push_back({{"strip_a", p.strip_a}, {"strip_b", p.strip_b}, {"samples", p.samples}, {"kept", p.kept},
                       {"rejected", {{"sparse", p.rejected_sparse}, {"rough", p.rejected_rough}, {"far", p.rejected_far},
                                     {"normal", p.rejected_normal}, {"mad", p.rejected_mad}, {"budget", p.rejected_budget}}},
                       {"median_before_m", p.median_before_m}, {"rms_before_m", p.rms_before_m},
                       {"median_after_m", p.median_after_m}, {"rms_after_m", p.rms_after_m}});
    }
    j["correspondences"] = {{"used", c.used}, {"matchings", c.rounds}, {"radius_m", c.radius_m}, {"spacing_m", c.spacing_m},
                            {"sigma_m", c.sigma_m}, {"median_before_m", c.median_before_m}, {"rms_before_m", c.rms_before_m},
                            {"median_after_m", c.median_after_m}, {"rms_after_m", c.rms_after_m},
                            {"search_time_s", c.search_time_s}, {"points_searched", c.points_searched}, {"pairs", pairs}};
    if (!c.laser_elevation_deg.empty()) {
      json off = json::array(), sig = json::array(), cor = json::array(), pts = json::array();
      for (std::size_t i = 0; i < c.laser_elevation_deg.size(); ++i) {
        off.push_back(c.laser_elevation_deg[i]);
        sig.push_back(numOrNull(c.laser_elevation_sigma_deg[i]));
        cor.push_back(numOrNull(c.laser_boresight_correlation[i]));
        pts.push_back(c.laser_points[i]);
      }
      // The complete intrinsics to use from now on (apply and evaluate read them), by laser id.
      j["intrinsics"] = {{"laser_elevation_offset_deg", off}, {"laser_elevation_sigma_deg", sig},
                         {"laser_boresight_correlation", cor}, {"laser_points", pts}};
    }
  }
  if (S.control.observations_used > 0 || !S.control.rejected.empty()) {
    json rej = json::array();
    for (const RejectedTie& r : S.control.rejected) rej.push_back({{"gcp_id", r.tie_id}, {"strip_id", r.strip_id}, {"reason", r.reason}});
    json res = json::array();
    for (const TieResidual& r : S.control.residuals) {
      res.push_back({{"gcp_id", r.tie_id}, {"strip_id", r.strip_id}, {"before_m", vec(r.before_m)}, {"after_m", vec(r.after_m)}, {"outlier", r.outlier}});
    }
    j["control"] = {{"points", S.control.ties_used}, {"observations", S.control.observations_used},
                    {"rms_before_m", vec(S.control.rms_before_m)}, {"rms_after_m", vec(S.control.rms_after_m)},
                    {"residuals", res}, {"rejected", rej}};
  }
  if (ev) {
    json e;
    if (ev->has_check_points) {
      e["check_points"] = {{"rms_before_m", vec(ev->check_points_before.rms_m)}, {"rms_after_m", vec(ev->check_points_after.rms_m)},
                           {"observations", ev->check_points_after.residuals.size()}};
    }
    json planes = json::array();
    for (std::size_t i = 0; i < ev->check_planes_after.size(); ++i) {
      planes.push_back({{"plane_id", ev->check_planes_after[i].plane_id}, {"points", ev->check_planes_after[i].points},
                        {"rms_before_m", numOrNull(ev->check_planes_before[i].rms_m)}, {"rms_after_m", numOrNull(ev->check_planes_after[i].rms_m)}});
    }
    if (!planes.empty()) e["check_planes"] = planes;
    json disc = json::array();
    auto st = [](const DiscrepancyStats& s) {
      return json{{"queries", s.queries}, {"used", s.used}, {"median_m", numOrNull(s.median_m)}, {"rms_m", numOrNull(s.rms_m)}, {"p90_m", numOrNull(s.p90_m)}};
    };
    for (const PairDiscrepancy& a : ev->discrepancy_after) {
      json d = {{"query_strip", a.query}, {"reference_strip", a.reference}, {"after", st(a.stats)}};
      for (const PairDiscrepancy& b : ev->discrepancy_before)
        if (b.query == a.query && b.reference == a.reference) d["before"] = st(b.stats);
      disc.push_back(d);
    }
    if (!disc.empty()) e["discrepancy"] = disc;
    j["evaluation"] = e;
  }
  return j.dump(2) + "\n";
}

namespace {
/// A result file parsed; FileError naming the file (and the byte) when it cannot be read.
json readResultFile(const std::string& path) { return detail::parseJsonFile(path, "result"); }
}  // namespace

std::vector<double> readResultLaserElevation(const std::string& path) {
  const json j = readResultFile(path);
  std::vector<double> out;
  if (!j.is_object() || !j.contains("intrinsics") || j["intrinsics"].is_null()) return out;
  const json& intrinsics = j["intrinsics"];
  if (!intrinsics.is_object() || !intrinsics.contains("laser_elevation_offset_deg") || !intrinsics["laser_elevation_offset_deg"].is_array() ||
      intrinsics["laser_elevation_offset_deg"].size() > 4096) {
    throw FileError(path, "field 'intrinsics.laser_elevation_offset_deg'", "expected an array of numbers, one per laser");
  }
  for (const json& v : intrinsics["laser_elevation_offset_deg"]) {
    if (!v.is_number() || !std::isfinite(v.get<double>()) || std::abs(v.get<double>()) > 10) {
      throw FileError(path, "field 'intrinsics.laser_elevation_offset_deg'", "expected offsets in degrees within ±10");
    }
    out.push_back(deg2rad(v.get<double>()));
  }
  return out;
}

MountingParameters readResultMounting(const std::string& path, const Mat3& R_nom) {
  const json j = readResultFile(path);
  if (!j.is_object() || !j.contains("mounting")) throw FileError(path, "field 'mounting'", "missing");
  const detail::Fields m(path, j["mounting"], "mounting", {"lever_arm_m", "boresight_deg"});
  MountingParameters out = MountingParameters::fromDegrees(m.vec3("lever_arm_m"), m.vec3("boresight_deg"));
  out.R_nom = R_nom;
  return out;
}

}  // namespace mountcal
