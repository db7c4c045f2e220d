#include "mountcal/job/result.hpp"

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

#include "io/json_fields.hpp"
#include "mountcal/core/error.hpp"
#include "mountcal/methods/vtpm/vtpm.hpp"

namespace mountcal {

using nlohmann::json;

void applyLaserCorrections(CalibrationData* data, const LaserCorrections& lasers) {
  if (lasers.empty()) return;
  const std::vector<LaserCorrector> correct = laserCorrectors(lasers);
  for (StripData& s : data->strips) {
    if (s.laser.empty()) continue;
    for (std::size_t i = 0; i < s.r_s.size(); ++i) {
      if (s.laser[i] >= lasers.size())
        throw InvalidInput("strip '" + s.id + "': laser id " + std::to_string(s.laser[i]) + " has no intrinsics");
      s.r_s[i] = correct[s.laser[i]](s.r_s[i]);
    }
    s.x_m.clear();
  }
}

ResultEvaluation evaluateJob(const Job& job, const LoadedJob& loaded, const MountingParameters& mounting, bool discrepancy,
                             const LaserCorrections& lasers) {
  ResultEvaluation ev;
  CalibrationData check = loaded.data;
  check.ties = loadCheckPoints(job, loaded);
  const std::vector<PlaneRegion> planes = loadCheckPlanes(job, loaded);
  if (!check.ties.empty()) {
    ev.has_check_points = true;
    ev.check_points_before = evaluateCheckPoints(check, job.mounting_used, job.options.method<VtpmOptions>().vtp);
    ev.check_points_after = evaluateCheckPoints(check, mounting, job.options.method<VtpmOptions>().vtp);
  }
  if (!planes.empty()) {
    ev.check_planes_before = evaluateCheckPlanes(check, planes, job.mounting_used);
    ev.check_planes_after = evaluateCheckPlanes(check, planes, mounting);
  }
  if ((discrepancy || job.per_point_poses) && loaded.data.strips.size() >= 2) {
    DiscrepancyReport before = discrepancyReport(loaded.data, job.mounting_used), after;
    if (lasers.empty()) {
      after = discrepancyReport(loaded.data, mounting);
    } else {
      CalibrationData d = loaded.data;
      applyLaserCorrections(&d, lasers);
      after = discrepancyReport(d, mounting);
    }
    ev.discrepancy_before = std::move(before.pairs);
    ev.breakdown_before = std::move(before.breakdown);
    ev.discrepancy_after = std::move(after.pairs);
    ev.breakdown_after = std::move(after.breakdown);
  }
  return ev;
}

namespace {
json numOrNull(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }
json vec(const Vec3& v) { return json::array({v.x(), v.y(), v.z()}); }

/// "discrepancy_breakdown": {"by_laser": [{"class", "before", "after"}], "by_place", "by_range",
/// "by_tilt"}; a class missing before has null there.
template <typename Stats>
json breakdownJson(const DiscrepancyBreakdown& before, const DiscrepancyBreakdown& after, Stats st) {
  json out = json::object();
  for (const DiscrepancyGroupChange& g : compareBreakdowns(before, after)) {
    json rows = json::array();
    for (const DiscrepancyClassChange& c : g.classes)
      rows.push_back({{"class", c.label}, {"before", c.in_before ? st(c.before) : json(nullptr)}, {"after", st(c.after)}});
    out[g.key] = rows;
  }
  return out;
}
}  // namespace

namespace {
/// The model sensitivity and the re-solve check (issue 26): "model_sensitivity" and
/// "resolve_check" (null when no second solve ran).
void addSensitivityChecks(const MountingCalibrator::Summary& summary, json* out) {
  json& j = *out;
  json sens = json::array();
  for (const auto& ms : summary.model_sensitivity) {
    json shift = json::array(), z = json::array();
    for (int k = 0; k < 6; ++k) {
      shift.push_back(ms.shift[k] == 0.0 ? json(nullptr) : json(k < 3 ? ms.shift[k] : rad2deg(ms.shift[k])));
      z.push_back(ms.shift[k] == 0.0 ? json(nullptr) : json(ms.shift_in_sigma[k]));
    }
    json entry = {{"change", ms.change},
                  {"shift_m_deg", shift},
                  {"shift_in_sigma", z},
                  {"model_dependent", ms.model_dependent()},
                  {"text", ms.text()}};
    if (ms.solved) {  // the move of a solve without the part (ModelSensitivity::solved)
      json solved = json::array(), solved_z = json::array();
      for (int k = 0; k < 6; ++k) {
        const bool est = summary.estimated[static_cast<std::size_t>(k)];
        solved.push_back(est ? json(k < 3 ? ms.solved_shift[k] : rad2deg(ms.solved_shift[k])) : json(nullptr));
        solved_z.push_back(est ? json(ms.solved_shift_in_sigma[k]) : json(nullptr));
      }
      entry["solved_shift_m_deg"] = solved;
      entry["solved_shift_in_sigma"] = solved_z;
    }
    sens.push_back(entry);
  }
  j["model_sensitivity"] = sens;
  if (std::isnan(summary.time_offset_s))
    j["time_offset"] = nullptr;
  else
    j["time_offset"] = {{"estimate_s", summary.time_offset_s},
                        {"sigma_s", numOrNull(summary.time_offset_sigma_s)},
                        {"in_solve", summary.time_offset_in_solve},
                        {"applied", false}};
  json corr = json::array();
  for (const auto& c : summary.strip_corrections) {
    const Vec3 a0 = c.attitude_start_rad * (180.0 / kPi), a1 = c.attitude_end_rad * (180.0 / kPi);
    corr.push_back({{"strip", c.strip_id},
                    {"time_s", {c.t_start_s, c.t_end_s}},
                    {"position_start_m", vec(c.position_start_m)},
                    {"position_end_m", vec(c.position_end_m)},
                    {"attitude_start_deg", vec(a0)},
                    {"attitude_end_deg", vec(a1)},
                    {"prior_sigma_end_m", vec(c.prior_end_position_m)},
                    {"prior_sigma_end_deg", vec(c.prior_end_attitude_rad * (180.0 / kPi))}});
  }
  j["trajectory_corrections"] = corr;
  if (summary.resolve.done) {
    const auto& rc = summary.resolve;
    json shift = json::array(), z = json::array();
    for (int k = 0; k < 6; ++k) {
      shift.push_back(summary.estimated[k] ? json(k < 3 ? rc.shift[k] : rad2deg(rc.shift[k])) : json(nullptr));
      z.push_back(summary.estimated[k] ? json(rc.shift_in_sigma[k]) : json(nullptr));
    }
    j["resolve_check"] = {{"converged", rc.usable},      {"shift_m_deg", shift},    {"shift_in_sigma", z},
                          {"unsettled", rc.unsettled()}, {"rejects", rc.rejects()}, {"reject_sigma", rc.reject_sigma},
                          {"time_s", rc.time_s},         {"text", rc.text()}};
  } else {
    j["resolve_check"] = nullptr;
  }
}
}  // namespace

std::string resultJson(const MountingCalibrator::Summary& summary, const ResultEvaluation* ev) {
  const Vec3 b = summary.mounting.boresightDeg();
  json j;
  j["mounting"] = {{"lever_arm_m", vec(summary.mounting.a_b)}, {"boresight_deg", vec(b)}};
  // SPEC §2, stated where a reader of the file looks (`mountcal mounting` writes other forms).
  j["conventions"] = {{"body_frame", "x forward, y right, z down (IMU body frame)"},
                      {"lever_arm", "IMU origin to scanner origin, body axes, metres"},
                      {"boresight", "R_bore = Rz(heading) * Ry(pitch) * Rx(roll), active, right-handed, degrees; R_bs = R_bore * R_nom"},
                      {"sigma", "standard deviations in the same units (metres, degrees); null: not estimated"}};
  json sl = json::array(), sb = json::array();
  for (int i = 0; i < 3; ++i) {
    sl.push_back(numOrNull(summary.sigma[i]));
    sb.push_back(numOrNull(rad2deg(summary.sigma[3 + i])));
  }
  j["sigma"] = {{"lever_arm_m", sl}, {"boresight_deg", sb}};
  // The formal σ (observations independent, no trajectory errors in time), labelled as such.
  json fl = json::array(), fb = json::array();
  for (int i = 0; i < 3; ++i) {
    fl.push_back(numOrNull(summary.formal_sigma[i]));
    fb.push_back(numOrNull(rad2deg(summary.formal_sigma[3 + i])));
  }
  j["formal_sigma"] = {{"lever_arm_m", fl}, {"boresight_deg", fb}};
  j["sigma_model"] = summary.sigma_model;
  json corr = json::array();
  for (int a = 0; a < 6; ++a) {
    json row = json::array();
    for (int c = 0; c < 6; ++c) row.push_back(numOrNull(summary.correlation(a, c)));
    corr.push_back(row);
  }
  j["correlation"] = corr;
  j["estimated"] = {{"lever_arm", {summary.estimated[0], summary.estimated[1], summary.estimated[2]}},
                    {"boresight", {summary.estimated[3], summary.estimated[4], summary.estimated[5]}}};
  j["unobservable"] = summary.unobservable;
  j["observability_report"] = summary.observability_report;
  json offs = json::object();
  for (const auto& [id, o] : summary.strip_offsets_m) offs[id] = vec(o);
  j["strip_offsets_m"] = offs;
  j["variance_factor"] = summary.variance_factor;
  j["degrees_of_freedom"] = summary.degrees_of_freedom;
  j["solver"] = {{"termination", toString(summary.termination)},
                 {"message", summary.message},
                 {"iterations", summary.iterations},
                 {"rematch_rounds", summary.rematch_rounds},
                 {"boresight_first_restart", summary.boresight_first_restart},
                 {"initial_cost", summary.initial_cost},
                 {"final_cost", summary.final_cost},
                 {"time_s", summary.time_s},
                 {"construction_time_s", summary.construction_time_s},
                 {"solve_time_s", summary.solve_time_s},
                 {"analysis_time_s", summary.analysis_time_s}};
  j["methods"] = summary.methods;
  json kinds = json::array();
  for (const auto& k : summary.kinds) {
    json e = {{"kind", k.kind}, {"residual_blocks", k.blocks}, {"residuals", k.residuals}};
    // Where the kind's σ came from the data at the start: its own σ₀² and the factor of its share
    // in the covariance (AdjustmentSummary::KindCount).
    if (std::isfinite(k.variance_factor)) e["variance_factor"] = k.variance_factor, e["covariance_scale"] = k.covariance_scale;
    kinds.push_back(std::move(e));
  }
  j["kinds"] = kinds;
  j["covariance_source"] = summary.covariance_source;
  addSensitivityChecks(summary, &j);
  {
    const MountingCalibrator::Verdict verdict = summary.verdict();
    j["verdict"] = {{"kind", verdict.name()}, {"reasons", verdict.reasons}};
  }
  j["condition_number"] = numOrNull(summary.condition_number);
  // SPEC §4's tie keys are in every result file: null unless a method fills them (method "vtpm").
  for (const char* key : {"ties", "rms_before_m", "rms_after_m", "residuals"}) j[key] = nullptr;
  // Each method's keys (SPEC §4: "ties", "residuals", "planes", "features", "correspondences", …).
  for (const auto& section : summary.sections) {
    const json part = json::parse(section->resultJson(summary));
    for (auto it = part.begin(); it != part.end(); ++it) j[it.key()] = it.value();
  }
  if (ev) {
    json e;
    if (ev->has_check_points) {
      e["check_points"] = {{"rms_before_m", vec(ev->check_points_before.rms_m)},
                           {"rms_after_m", vec(ev->check_points_after.rms_m)},
                           {"observations", ev->check_points_after.residuals.size()}};
    }
    json planes = json::array();
    for (std::size_t i = 0; i < ev->check_planes_after.size(); ++i) {
      planes.push_back({{"plane_id", ev->check_planes_after[i].plane_id},
                        {"points", ev->check_planes_after[i].points},
                        {"rms_before_m", numOrNull(ev->check_planes_before[i].rms_m)},
                        {"rms_after_m", numOrNull(ev->check_planes_after[i].rms_m)}});
    }
    if (!planes.empty()) e["check_planes"] = planes;
    json disc = json::array();
    auto st = [](const DiscrepancyStats& s) {
      return json{{"queries", s.queries},
                  {"used", s.used},
                  {"median_m", numOrNull(s.median_m)},
                  {"rms_m", numOrNull(s.rms_m)},
                  {"p90_m", numOrNull(s.p90_m)}};
    };
    for (const PairDiscrepancy& a : ev->discrepancy_after) {
      json d = {{"query_strip", a.query}, {"reference_strip", a.reference}, {"after", st(a.stats)}};
      for (const PairDiscrepancy& b : ev->discrepancy_before)
        if (b.query == a.query && b.reference == a.reference) d["before"] = st(b.stats);
      disc.push_back(d);
    }
    if (!disc.empty()) {
      e["discrepancy"] = disc;
      e["discrepancy_breakdown"] = breakdownJson(ev->breakdown_before, ev->breakdown_after, st);
    }
    j["evaluation"] = e;
  }
  return j.dump(2) + "\n";
}

namespace {
/// A result file parsed; FileError naming the file (and the byte) when it cannot be read.
json readResultFile(const std::string& path) { return detail::parseJsonFile(path, "result"); }
}  // namespace

LaserCorrections readResultLaserCorrections(const std::string& path) {
  const json j = readResultFile(path);
  LaserCorrections out;
  if (!j.is_object() || !j.contains("intrinsics") || j["intrinsics"].is_null()) return out;
  const json& intrinsics = j["intrinsics"];
  if (!intrinsics.is_object()) throw FileError(path, "field 'intrinsics'", "expected an object of per-laser arrays");
  for (const LaserGroup& g : kLaserGroups) {
    const std::string key = std::string("laser_") + g.name + "_offset_" + g.unit;
    const bool angle = g.to_unit != 1;
    const double limit = angle ? 10 : 1;  // |value| ≤ limit in the file's unit: degrees, metres
    if (!intrinsics.contains(key)) continue;
    const json& a = intrinsics[key];
    const std::string field = "field 'intrinsics." + key + "'";
    if (!a.is_array() || a.empty() || a.size() > 4096) throw FileError(path, field, "expected an array of numbers, one per laser");
    if (!out.empty() && a.size() != out.size())
      throw FileError(path, field,
                      std::to_string(a.size()) + " lasers, where another group of the intrinsics has " + std::to_string(out.size()));
    out.resize(a.size());
    for (std::size_t i = 0; i < a.size(); ++i) {
      if (!a[i].is_number() || !std::isfinite(a[i].get<double>()) || std::abs(a[i].get<double>()) > limit) {
        throw FileError(path, field + " laser " + std::to_string(i),
                        std::string("expected a number within ±") + (angle ? "10 degrees" : "1 m"));
      }
      out[i].*g.field = angle ? deg2rad(a[i].get<double>()) : a[i].get<double>();
    }
  }
  return out;
}

MountingParameters readResultMounting(const std::string& path, const Mat3& R_nom) {
  const json j = readResultFile(path);
  if (!j.is_object() || !j.contains("mounting")) throw FileError(path, "field 'mounting'", "missing");
  const detail::Fields m(path, j["mounting"], "mounting", {"lever_arm_m", "boresight_deg"});
  MountingParameters out = MountingParameters::fromDegrees(m.leverArmM("lever_arm_m"), m.boresightDeg("boresight_deg"));
  out.R_nom = R_nom;
  return out;
}

JobCalibration calibrateJob(const Job& job, const LoadedJob& loaded, bool evaluate) {
  JobCalibration out;
  out.summary = MountingCalibrator(job.options).calibrate(loaded.data);
  if (evaluate) out.evaluation = evaluateJob(job, loaded, out.summary.mounting, false, out.summary.laserCorrections());
  out.result_json = resultJson(out.summary, out.evaluation.any() ? &out.evaluation : nullptr);
  return out;
}

}  // namespace mountcal
