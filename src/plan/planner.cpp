#include "mountcal/plan/planner.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <thread>

#include "io/json_fields.hpp"
#include "job/stochastic_fields.hpp"
#include "mountcal/core/error.hpp"

namespace mountcal::plan {

namespace {

using detail::Fields;
using detail::json;
using simulation::FlightLine;
using simulation::MirrorPattern;
using simulation::NoiseModel;
using simulation::Scene;

using simulation::SimulatedSurvey;
using simulation::SurveyConfig;
constexpr double kInf = std::numeric_limits<double>::infinity();

double seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// [x, y] in metres.
std::array<double, 2> xy(const Fields& f, const std::string& k) {
  const json& a = f.at(k);
  if (!a.is_array() || a.size() != 2 || !a[0].is_number() || !a[1].is_number()) f.fail(k, "expected [x, y] in metres");
  const std::array<double, 2> v{a[0].get<double>(), a[1].get<double>()};
  if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || std::abs(v[0]) > 1e6 || std::abs(v[1]) > 1e6)
    f.fail(k, "expected plan coordinates within ±1000 km of the plan's origin");
  return v;
}

std::string methodOf(const Fields& f, const std::string& key, const std::string& name) {
  const Method* m = findMethod(name);
  if (!m || m->implicit()) f.fail(key, "unknown method '" + name + "' (methods: " + methodNames() + ")");
  return name;
}

}  // namespace

double swathWidth(const SurveyConfig& c, double height_m) {
  if (c.sensor == SensorType::kLine) return 2.0 * height_m * std::tan(c.line.half_fov_rad);
  const double r = 0.7 * c.multibeam.max_range_m;  // ranges near the limit are sparse
  return r > height_m ? 2.0 * std::sqrt(r * r - height_m * height_m) : height_m;
}

// ---- the plan ------------------------------------------------------------------------------

SurveyConfig Plan::surveyConfig() const {
  SurveyConfig c = survey;
  c.name = name;
  c.lines.clear();
  for (const PlannedLine& l : lines) {
    FlightLine f;
    f.id = l.id;
    f.x0_m = l.x0_m;
    f.y0_m = l.y0_m;
    f.heading_rad = std::atan2(l.x1_m - l.x0_m, l.y1_m - l.y0_m);  // clockwise from North (+y)
    f.length_m = std::hypot(l.x1_m - l.x0_m, l.y1_m - l.y0_m);
    f.height_m = l.height_m;
    f.speed_mps = l.speed_mps;
    c.lines.push_back(f);
  }
  return c;
}

Scene Plan::buildScene() const {
  Scene s;
  s.setGround(ground_z_m, ground_gx, ground_gy);
  for (const Roof& r : roofs) {
    if (r.monopitch) {
      // One face looking towards aspect (downslope there), rising size · tan(slope) across the house.
      const double high = r.eave_height_m + r.size_m * std::tan(deg2rad(r.slope_deg));
      s.addMonopitchHouse(r.id, r.x_m, r.y_m, r.size_m, r.size_m, r.eave_height_m, high, deg2rad(r.aspect_deg + 90.0));
      continue;
    }
    // A gable house whose faces look towards aspect and aspect + 180°: the ridge runs across
    // the aspect; the faces rise size/2 · tan(slope) from the eaves to the ridge.
    const double ridge = r.eave_height_m + 0.5 * r.size_m * std::tan(deg2rad(r.slope_deg));
    s.addGableHouse(r.id, r.x_m, r.y_m, r.size_m, r.size_m, r.eave_height_m, ridge, deg2rad(r.aspect_deg + 90.0));
  }
  for (const Target& t : targets) s.addGroundTarget(t.id, t.x_m, t.y_m, t.size_m, 0.0);
  s.build();
  return s;
}

double Plan::meanHeight() const {
  double h = 0;
  for (const PlannedLine& l : lines) h += l.height_m;
  return lines.empty() ? 0.0 : h / static_cast<double>(lines.size());
}

namespace {

/// A multi-beam plan whose beams, as the scanner is installed, cannot reach the ground from the
/// lowest line within the sensor's range is refused with the geometry and what to change (the
/// simulation would find no point and say only that no beam reaches a feature). Level flight:
/// the body's z axis (SPEC §2, forward-right-down) points down.
void requireBeamsReachTheGround(const Fields& top, const Plan& p) {
  const SurveyConfig& c = p.survey;
  if (c.sensor != SensorType::kMultiBeam || p.lines.empty()) return;
  double down = -1;  // the largest downward component of a beam, over lasers and azimuths
  for (const LaserSpec& l : c.multibeam.model.lasers())
    for (int k = 0; k < 72; ++k) {
      const double a = k * kPi / 36, w = l.elevation_rad;
      down = std::max(down, (c.nominal_mounting.R_nom * Vec3(std::cos(w) * std::sin(a), std::cos(w) * std::cos(a), std::sin(w))).z());
    }
  double lowest = 1e300;
  for (const PlannedLine& l : p.lines) lowest = std::min(lowest, l.height_m);
  if (down > 0 && lowest / down <= c.multibeam.max_range_m) return;
  char reach[120];
  if (down > 0)
    std::snprintf(reach, sizeof reach, "reach the ground %.0f m away, beyond its %.0f m range", lowest / down, c.multibeam.max_range_m);
  else
    std::snprintf(reach, sizeof reach, "never reach the ground");
  char buf[500];
  std::snprintf(buf, sizeof buf,
                "as installed (sensor.nominal_rotation_deg), the %s's beams point at most %.1f deg below the horizon: from the lowest "
                "line's %.0f m they %s. Mount it on its side (e.g. \"nominal_rotation_deg\": [0, 90, 0]) or fly lower",
                c.multibeam.model.name().c_str(), rad2deg(std::asin(std::clamp(down, -1.0, 1.0))), lowest, reach);
  top.fail("sensor", buf);
}

/// The sensor of the plan.
void readPlanSensor(const std::string& /*path*/, const Fields& top, Plan& p) {
  SurveyConfig& c = p.survey;
  const Fields sensor = top.sub(
      "sensor", {"type", "prf_hz", "scan_rate_hz", "half_fov_deg", "pattern", "rotation_hz", "max_range_m", "nominal_rotation_deg"});
  const std::string type = sensor.str("type");
  // How the scanner is installed (as a job's sensor.nominal_rotation_deg): a multi-beam scanner
  // on its side sweeps the ground below; upright, its fan of ±15° looks at the horizon.
  if (sensor.has("nominal_rotation_deg")) {
    const Vec3 r = sensor.vec3("nominal_rotation_deg");
    if (r.cwiseAbs().maxCoeff() > 360.0) sensor.fail("nominal_rotation_deg", "expected angles within ±360°");
    c.nominal_mounting.R_nom = R_zyx(r * (kPi / 180.0));
  }
  if (type == "line") {
    c.sensor = SensorType::kLine;
    c.line.prf_hz = sensor.num("prf_hz", 150e3, 1e3, 5e6);
    c.line.scan_rate_hz = sensor.num("scan_rate_hz", 50.0, 1.0, 1000.0);
    c.line.half_fov_rad = deg2rad(sensor.num("half_fov_deg", 20.0, 1.0, 75.0));
    // The mirror's motion: oscillating (sinusoidal), constant speed back and forth (triangle), or
    // a rotating polygon's one way (sawtooth).
    const std::string pattern = sensor.str("pattern", "sinusoidal");
    if (pattern == "sinusoidal")
      c.line.pattern = MirrorPattern::kSinusoidal;
    else if (pattern == "triangle")
      c.line.pattern = MirrorPattern::kTriangle;
    else if (pattern == "sawtooth")
      c.line.pattern = MirrorPattern::kSawtooth;
    else
      sensor.fail("pattern", "unknown scan pattern '" + pattern + "' (patterns: sinusoidal, triangle, sawtooth)");
  } else if (type == "vlp16" || type == "hdl32e") {
    c.sensor = SensorType::kMultiBeam;
    c.multibeam.model = type == "vlp16" ? MultiBeamModel::VLP16() : MultiBeamModel::HDL32E();
    c.multibeam.rotation_hz = sensor.num("rotation_hz", 10.0, 5.0, 20.0);
    c.multibeam.max_range_m = sensor.num("max_range_m", type == "vlp16" ? 100.0 : 80.0, 5.0, 500.0);
  } else {
    sensor.fail("type", "unknown sensor '" + type + "' (sensors: line, vlp16, hdl32e)");
  }
}

/// Noise: what the survey's errors will be; the stochastic model follows it.
void readPlanNoise(const std::string& /*path*/, const Fields& top, Plan& p) {
  SurveyConfig& c = p.survey;
  NoiseModel& n = c.noise;
  n = NoiseModel::realistic();
  n.attitude_correlation_s = 0.005;  // white at the trajectory rate unless stated
  // Trajectory errors in time (the calibrator's TrajectoryAccuracy): none unless stated.
  TrajectoryAccuracy t = TrajectoryAccuracy::none();
  if (top.has("noise")) {
    if (top.at("noise").is_string()) {
      const std::string name = top.str("noise");
      if (name != "realistic") top.fail("noise", "expected \"realistic\" or an object of σ");
    } else {
      const Fields nf = top.sub("noise", {"range_sigma_m", "scan_angle_sigma_deg", "gnss_sigma_m", "gnss_correlation_s",
                                          "attitude_sigma_deg", "attitude_correlation_s", "pick_sigma_m", "drift_position_sigma_m",
                                          "drift_position_correlation_s", "drift_attitude_sigma_deg", "drift_attitude_correlation_s"});
      n.range_sigma_m = nf.num("range_sigma_m", n.range_sigma_m, 1e-4, 1.0);
      n.scan_angle_sigma_rad = deg2rad(nf.num("scan_angle_sigma_deg", rad2deg(n.scan_angle_sigma_rad), 0.0, 1.0));
      n.gnss_sigma_m = nf.num("gnss_sigma_m", n.gnss_sigma_m, 0.0, 10.0);
      n.gnss_correlation_s = nf.num("gnss_correlation_s", n.gnss_correlation_s, 1.0, 1e6);
      n.attitude_sigma_rad = deg2rad(nf.num("attitude_sigma_deg", rad2deg(n.attitude_sigma_rad), 0.0, 1.0));
      n.attitude_correlation_s = nf.num("attitude_correlation_s", n.attitude_correlation_s, 1e-3, 1e4);
      n.pick_sigma_m = nf.num("pick_sigma_m", n.pick_sigma_m, 1e-3, 10.0);
      t.position_sigma_m = nf.num("drift_position_sigma_m", 0.0, 0.0, 10.0);
      t.position_correlation_s = nf.num("drift_position_correlation_s", t.position_correlation_s, 0.1, 1e5);
      t.roll_pitch_sigma_deg = nf.num("drift_attitude_sigma_deg", 0.0, 0.0, 1.0);
      t.heading_sigma_deg = 2.0 * t.roll_pitch_sigma_deg;
      t.attitude_correlation_s = nf.num("drift_attitude_correlation_s", t.attitude_correlation_s, 0.1, 1e5);
    }
  }
  // The GNSS error (the Gauss–Markov process of gnss_sigma_m and gnss_correlation_s the simulator
  // draws) is a position error in time of its own beside any stated drift: nearly constant over an
  // airborne line of 15 s, it wanders within a UAV's line of 40 s. The strip offsets' prior is its
  // constant part, counted once (TrajectoryAccuracy::offsets_within_drift).
  t.gnss_sigma_m = n.gnss_sigma_m;
  t.gnss_correlation_s = n.gnss_correlation_s;
  t.offsets_within_drift = n.gnss_sigma_m > 0;
  p.options.trajectory = t;
}

/// Mounting: nominal = truth.
void readPlanMounting(const std::string& /*path*/, const Fields& top, Plan& p) {
  SurveyConfig& c = p.survey;
  if (top.has("mounting")) {
    const Fields m = top.sub("mounting", {"lever_arm_m", "boresight_deg"});
    if (m.has("lever_arm_m")) c.nominal_mounting.a_b = m.vec3("lever_arm_m");
    if (m.has("boresight_deg")) c.nominal_mounting.boresight = m.vec3("boresight_deg") * (kPi / 180.0);
    if (c.nominal_mounting.a_b.cwiseAbs().maxCoeff() > 50.0) m.fail("lever_arm_m", "expected components within ±50 m");
    if (c.nominal_mounting.boresight.cwiseAbs().maxCoeff() > kPi) m.fail("boresight_deg", "expected angles within ±180°");
  }
  c.true_mounting = c.nominal_mounting;
}

/// The planned lines.
void readPlanLines(const std::string& path, const Fields& top, Plan& p) {
  SurveyConfig& c = p.survey;
  const json& lines = top.at("lines");
  if (!lines.is_array() || lines.empty()) top.fail("lines", "expected a non-empty array of lines");
  if (lines.size() > 200) top.fail("lines", "more than 200 lines: a calibration flight has a few");
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const Fields l(path, lines[i], "lines[" + std::to_string(i) + "]", {"id", "start", "end", "height_m", "speed_mps"});
    PlannedLine pl;
    pl.id = l.str("id", std::to_string(i + 1));
    const auto a = xy(l, "start"), b = xy(l, "end");
    pl.x0_m = a[0], pl.y0_m = a[1], pl.x1_m = b[0], pl.y1_m = b[1];
    if (std::hypot(b[0] - a[0], b[1] - a[1]) < 10.0) l.fail("end", "a line needs at least 10 m between start and end");
    if (std::hypot(b[0] - a[0], b[1] - a[1]) > 100e3) l.fail("end", "a line longer than 100 km");
    pl.height_m = l.num("height_m", 0.0, 1.0, 10000.0);
    if (!l.has("height_m")) l.fail("height_m", "missing");
    pl.speed_mps = l.num("speed_mps", c.sensor == SensorType::kLine ? 60.0 : 5.0, 0.5, 300.0);
    for (const PlannedLine& q : p.lines)
      if (q.id == pl.id) l.fail("id", "'" + pl.id + "' is the id of another line");
    p.lines.push_back(pl);
  }
}

/// Ground: height, slope, roofs and targets.
void readPlanGround(const std::string& path, const Fields& top, Plan& p) {
  if (top.has("ground")) {
    const Fields g = top.sub("ground", {"z_m", "slope", "roofs", "targets"});
    p.ground_z_m = g.num("z_m", 0.0, -1000.0, 9000.0);
    if (g.has("slope")) {
      const auto s = xy(g, "slope");
      if (std::abs(s[0]) > 0.5 || std::abs(s[1]) > 0.5) g.fail("slope", "expected gradients within ±0.5");
      p.ground_gx = s[0], p.ground_gy = s[1];
    }
    auto list = [&](const char* key) -> const json& {
      const json& a = g.at(key);
      if (!a.is_array()) g.fail(key, "expected an array");
      if (a.size() > 1000) g.fail(key, "more than 1000 entries");
      return a;
    };
    if (g.has("roofs")) {
      const json& a = list("roofs");
      for (std::size_t i = 0; i < a.size(); ++i) {
        const Fields r(path, a[i], "ground.roofs[" + std::to_string(i) + "]",
                       {"id", "centre", "slope_deg", "aspect_deg", "size_m", "eave_height_m", "form"});
        Plan::Roof roof;
        roof.id = r.str("id", "roof_" + std::to_string(i + 1));
        const auto c2 = xy(r, "centre");
        roof.x_m = c2[0], roof.y_m = c2[1];
        roof.slope_deg = r.num("slope_deg", 30.0, 5.0, 60.0);
        roof.aspect_deg = r.num("aspect_deg", 0.0, -360.0, 360.0);
        roof.size_m = r.num("size_m", 12.0, 4.0, 100.0);
        roof.eave_height_m = r.num("eave_height_m", 6.0, 2.0, 100.0);
        const std::string form = r.str("form", "gable");
        if (form != "gable" && form != "monopitch") r.fail("form", "unknown roof form '" + form + "' (forms: gable, monopitch)");
        roof.monopitch = form == "monopitch";
        p.roofs.push_back(roof);
      }
    }
    if (g.has("targets")) {
      const json& a = list("targets");
      for (std::size_t i = 0; i < a.size(); ++i) {
        const Fields t(path, a[i], "ground.targets[" + std::to_string(i) + "]", {"id", "centre", "size_m"});
        Plan::Target target;
        target.id = t.str("id", "target_" + std::to_string(i + 1));
        const auto c2 = xy(t, "centre");
        target.x_m = c2[0], target.y_m = c2[1];
        target.size_m = t.num("size_m", 1.5, 0.3, 20.0);
        p.targets.push_back(target);
      }
    }
  }
}

/// Ground control: ids of features (targets' centres and corners, roof points).
void readPlanGcps(const std::string& path, const Fields& top, Plan& p) {
  const Scene scene = p.buildScene();
  if (top.has("gcps")) {
    const json& a = top.at("gcps");
    if (!a.is_array()) top.fail("gcps", "expected an array of feature ids or {\"id\", \"sigma_xy_m\", \"sigma_z_m\"}");
    for (std::size_t i = 0; i < a.size(); ++i) {
      PlannedGcp gcp;
      const std::string key = "gcps[" + std::to_string(i) + "]";
      if (a[i].is_string()) {
        gcp.feature_id = a[i].get<std::string>();
      } else {
        const Fields gf(path, a[i], key, {"id", "sigma_xy_m", "sigma_z_m"});
        gcp.feature_id = gf.str("id");
        gcp.sigma_xy_m = gf.num("sigma_xy_m", gcp.sigma_xy_m, 1e-4, 10.0);
        gcp.sigma_z_m = gf.num("sigma_z_m", gcp.sigma_z_m, 1e-4, 10.0);
      }
      const auto& fs = scene.features();
      if (std::none_of(fs.begin(), fs.end(), [&](const simulation::FeaturePoint& f) { return f.id == gcp.feature_id; })) {
        std::string ids;
        for (const auto& f : fs) ids += (ids.empty() ? "" : ", ") + f.id;
        top.fail(key, "no ground feature '" + gcp.feature_id + "' (features: " + (ids.empty() ? "none" : ids) + ")");
      }
      p.gcps.push_back(gcp);
    }
  }
}

/// Methods and the stochastic model.
void readPlanMethods(const std::string& path, const Fields& top, Plan& p) {
  SurveyConfig& c = p.survey;
  NoiseModel& n = c.noise;
  MountingCalibrator::Options& opts = p.options;
  opts.methods.clear();
  if (top.has("method")) {
    const json& m = top.at("method");
    if (m.is_string()) {
      opts.methods.push_back(methodOf(top, "method", m.get<std::string>()));
    } else if (m.is_array() && !m.empty()) {
      for (const json& x : m) {
        if (!x.is_string()) top.fail("method", "expected a method name or an array of them");
        opts.methods.push_back(methodOf(top, "method", x.get<std::string>()));
      }
    } else {
      top.fail("method", "expected a method name or an array of them");
    }
  } else {
    opts.methods = {"vtpm"};
  }
  opts.estimate.fill(true);
  if (top.has("estimate")) {
    const Fields e = top.sub("estimate", {"lever_arm", "boresight"});
    if (e.has("lever_arm")) {
      const auto b = e.bool3("lever_arm");
      for (int k = 0; k < 3; ++k) opts.estimate[k] = b[k];
    }
    if (e.has("boresight")) {
      const auto b = e.bool3("boresight");
      for (int k = 0; k < 3; ++k) opts.estimate[3 + k] = b[k];
    }
  }
  static const json kNone = json::object();
  const Fields sig =
      top.has("sigma") ? top.sub("sigma", {"tie_xy_m", "tie_z_m", "plane_m", "strip_offset_m"}) : Fields(path, kNone, "sigma", {});
  // Every method's observation σ from the plan's noise.
  NoiseHint noise;
  noise.pick_sigma_xy_m = sig.num("tie_xy_m", std::max(n.pick_sigma_m, 1e-3), 1e-4, 10.0);
  noise.pick_sigma_z_m = sig.num("tie_z_m", 0.002, 1e-4, 10.0);  // beyond the pulse noise of the plan's noise model
  noise.point_sigma_m = sig.num("plane_m", std::max(n.range_sigma_m, 0.005), 1e-4, 1.0);
  for (const auto& m : registeredMethods()) m->adoptNoise(noise, &opts.method_options.at(m->name(), m->defaultOptions()));
  opts.strip_offset_sigma_m = sig.num("strip_offset_m", n.gnss_sigma_m, 0.0, 10.0);
  // The trajectory model the calibration will use, as in a job: per-strip corrections in time and
  // the time offset (at one speed it is an along-track lever arm: the prediction says so).
  if (top.has("stochastic"))
    detail::readTrajectoryModel(top.sub("stochastic", {"corrections", "time_offset_sigma_s", "estimate_time_offset"}), &opts);
  opts.pulse_noise.range_m = n.range_sigma_m;
  opts.pulse_noise.beam_deg = rad2deg(n.scan_angle_sigma_rad);
  opts.pulse_noise.roll_pitch_deg = rad2deg(n.attitude_sigma_rad);
  opts.pulse_noise.heading_deg = 2.0 * rad2deg(n.attitude_sigma_rad);
  opts.pulse_noise.attitude_correlation_s = n.attitude_correlation_s > 0.05 ? n.attitude_correlation_s : 0.0;
  std::string why;
  if (!opts.IsValid(&why)) throw FileError(path, "", "the stochastic model the plan gives is invalid: " + why);
}

}  // namespace

Plan readPlan(const std::string& path) {
  const json j = detail::parseJsonFile(path, "plan");
  const Fields top(path, j, "",
                   {"name", "sensor", "noise", "mounting", "lines", "ground", "gcps", "method", "estimate", "sigma", "stochastic",
                    "roi_radius_m", "trajectory_rate_hz"});
  Plan p;
  p.path = path;
  p.name = top.str("name", "plan");
  SurveyConfig& c = p.survey;
  c = SurveyConfig{};
  c.seed = 1;
  c.roi_radius_m = top.num("roi_radius_m", 10.0, 0.5, 200.0);
  // The planner's memory budget: the points within roi_radius_m of the features, for the plan
  // and for each candidate (as many at once as there are cores). A plan over a village stores
  // about 10⁵; 2·10⁶ is a plan flown at walking pace (about 0.4 GB per survey in the planner).
  c.max_points = 2e6;
  c.trajectory_rate_hz = top.num("trajectory_rate_hz", 200.0, 1.0, 2000.0);

  readPlanSensor(path, top, p);
  readPlanNoise(path, top, p);
  readPlanMounting(path, top, p);
  readPlanLines(path, top, p);
  readPlanGround(path, top, p);
  readPlanGcps(path, top, p);
  readPlanMethods(path, top, p);
  requireBeamsReachTheGround(top, p);
  return p;
}

// ---- prediction ------------------------------------------------------------------------------

namespace {
/// A plan that cannot be predicted: FileError naming the plan file (InvalidInput naming the plan
/// when it was built in code).
[[noreturn]] void refusePlan(const Plan& plan, const std::string& why) {
  if (!plan.path.empty()) throw FileError(plan.path, "", why);
  throw InvalidInput("plan '" + plan.name + "': " + why);
}
}  // namespace

Prediction predict(const Plan& plan) {
  const auto t0 = std::chrono::steady_clock::now();
  SurveyConfig c = plan.surveyConfig();
  c.noise = NoiseModel::none();
  c.true_mounting = c.nominal_mounting;
  const Scene scene = plan.buildScene();
  SimulatedSurvey s;
  try {
    s = simulation::simulate(c, scene);
  } catch (const InvalidInput& e) {  // e.g. more pulses than the simulator's budget
    refusePlan(plan, e.what());
  }
  std::size_t on_ground = 0;
  for (const simulation::SimulatedStrip& strip : s.strips) on_ground += strip.points_m.size();
  if (on_ground == 0)
    refusePlan(plan,
               "no beam of the planned lines reaches the ground within roi_radius_m of a roof, target or check plane: "
               "the lines must pass over the features (ground.roofs, ground.targets)");
  CalibrationData d = simulation::toCalibrationData(s);
  for (const PlannedGcp& g : plan.gcps)
    for (const simulation::FeaturePoint& f : scene.features())
      if (f.id == g.feature_id) d.gcps.push_back({f.id, f.x_m.x(), f.x_m.y(), f.x_m.z(), g.sigma_xy_m, g.sigma_z_m});
  const MountingCalibrator::Summary summary = calibrate(d, plan.options);

  Prediction p;
  p.strips = static_cast<int>(s.strips.size());
  std::map<std::string, std::set<std::string>> seen_by;  // feature → the strips that pick it
  for (const auto* picks : {&s.ties, &s.check_points})
    for (const simulation::TiePick& t : *picks) seen_by[t.tie_id].insert(t.strip_id);
  const std::set<std::string> ignored(c.ignored_feature_ids.begin(), c.ignored_feature_ids.end());
  for (const simulation::FeaturePoint& f : scene.features())
    if (!ignored.count(f.id) && seen_by[f.id].size() < 2) p.untied.push_back(f.id);
  for (const auto& k : summary.kinds) p.observations += k.blocks;
  p.determined = summary.estimated;
  p.sigma = summary.sigma;
  p.correlation = summary.correlation;
  p.condition_number = summary.condition_number;
  p.undeterminable = summary.unobservable;
  p.observability = summary.observability_report;
  if (summary.termination == TerminationType::kInvalidInput || summary.termination == TerminationType::kFailure) {
    refusePlan(plan, "the planned survey gives no usable adjustment: " + summary.message);
  }
  // The weakest parameter: the first undeterminable one, else the largest effect on the ground.
  const double H = plan.meanHeight();
  double worst = -1;
  for (int j = 0; j < 6; ++j) {
    if (!plan.options.estimate[j]) continue;
    const double g = !p.determined[j] || !std::isfinite(p.sigma[j]) ? kInf : (j < 3 ? p.sigma[j] : p.sigma[j] * H);
    if (g > worst) {
      worst = g;
      p.weakest = j;
    }
  }
  p.weakest_ground_sigma_m = worst < 0 ? 0.0 : worst;
  p.seconds = seconds(t0);
  return p;
}

// ---- candidates ------------------------------------------------------------------------------

namespace {

std::string fmt(const char* f, double a, double b = 0, double c = 0, double d = 0) {
  char buf[256];
  std::snprintf(buf, sizeof buf, f, a, b, c, d);
  return buf;
}

std::vector<Suggestion> candidates(const Plan& plan, const PlannerOptions& options) {
  std::vector<Suggestion> out;
  const PlannedLine& first = plan.lines.front();
  const double dx = first.x1_m - first.x0_m, dy = first.y1_m - first.y0_m, len = std::hypot(dx, dy);
  const double ux = dx / len, uy = dy / len;  // along the first line
  const double rx = uy, ry = -ux;             // to its right
  const double mx = 0.5 * (first.x0_m + first.x1_m), my = 0.5 * (first.y0_m + first.y1_m);
  auto unique = [&](const std::string& base) {
    std::string id = base;
    for (int k = 2; std::any_of(plan.lines.begin(), plan.lines.end(), [&](const PlannedLine& l) { return l.id == id; }); ++k)
      id = base + "_" + std::to_string(k);
    return id;
  };
  {  // A second height: the first line again, higher.
    Suggestion s;
    s.kind = "second height";
    s.plan = plan;
    PlannedLine l = first;
    l.id = unique(first.id + "_high");
    l.height_m = first.height_m * options.second_height_factor;
    s.plan.lines.push_back(l);
    s.description = "fly line " + first.id + " again at " + fmt("%.0f m", l.height_m) + " (line " + l.id + ")";
    out.push_back(std::move(s));
  }
  {  // A same-direction line offset sideways.
    Suggestion s;
    s.kind = "offset line";
    s.plan = plan;
    const double D = options.offset_fraction * swathWidth(plan.survey, first.height_m);
    PlannedLine l = first;
    l.id = unique(first.id + "_offset");
    l.x0_m += D * rx, l.y0_m += D * ry, l.x1_m += D * rx, l.y1_m += D * ry;
    s.plan.lines.push_back(l);
    s.description = "fly line " + first.id + " in the same direction " + fmt("%.0f m", D) +
                    " to its right: " + fmt("(%.0f, %.0f) → (%.0f, %.0f)", l.x0_m, l.y0_m, l.x1_m, l.y1_m) + " (line " + l.id + ")";
    out.push_back(std::move(s));
  }
  {  // A crossing line through the first line's middle.
    Suggestion s;
    s.kind = "crossing line";
    s.plan = plan;
    PlannedLine l = first;
    l.id = unique(first.id + "_cross");
    l.x0_m = mx - 0.5 * len * rx, l.y0_m = my - 0.5 * len * ry;
    l.x1_m = mx + 0.5 * len * rx, l.y1_m = my + 0.5 * len * ry;
    s.plan.lines.push_back(l);
    s.description = "fly a crossing line " + fmt("(%.0f, %.0f) → (%.0f, %.0f)", l.x0_m, l.y0_m, l.x1_m, l.y1_m) + " at " +
                    fmt("%.0f m", l.height_m) + " (line " + l.id + ")";
    out.push_back(std::move(s));
  }
  {  // Ground control: a target not yet surveyed, nearest the first line's middle; else a new one.
    Suggestion s;
    s.kind = "ground control";
    s.plan = plan;
    const Scene scene = plan.buildScene();
    const simulation::FeaturePoint* best = nullptr;
    double best_d = kInf;
    for (const auto& f : scene.features()) {
      if (std::any_of(plan.gcps.begin(), plan.gcps.end(), [&](const PlannedGcp& g) { return g.feature_id == f.id; })) continue;
      if (f.kind != simulation::SurfaceKind::kMarking && f.kind != simulation::SurfaceKind::kGround) continue;
      const double d = std::hypot(f.x_m.x() - mx, f.x_m.y() - my);
      if (d < best_d) best_d = d, best = &f;
    }
    PlannedGcp g;
    if (best) {
      g.feature_id = best->id;
      s.description = "survey " + best->id + fmt(" at (%.1f, %.1f) as a ground control point (σ 2 cm)", best->x_m.x(), best->x_m.y());
    } else {
      Plan::Target t;
      t.id = "gcp_target";
      t.x_m = mx + 0.25 * swathWidth(plan.survey, first.height_m) * rx;
      t.y_m = my + 0.25 * swathWidth(plan.survey, first.height_m) * ry;
      t.size_m = std::max(1.5, 0.003 * first.height_m);
      s.plan.targets.push_back(t);
      g.feature_id = t.id;
      s.description =
          "lay a " + fmt("%.1f m", t.size_m) + " ground target at " + fmt("(%.1f, %.1f)", t.x_m, t.y_m) + " and survey its centre (σ 2 cm)";
    }
    s.plan.gcps.push_back(g);
    out.push_back(std::move(s));
  }
  return out;
}

}  // namespace

PlanAnalysis analysePlan(const Plan& plan, const PlannerOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  if (plan.lines.empty()) throw InvalidInput("plan '" + plan.name + "': no lines");
  PlanAnalysis a;
  a.base = predict(plan);
  if (options.try_candidates && a.base.weakest >= 0) {
    a.suggestions = candidates(plan, options);
    // Each candidate is an independent simulation and adjustment: run them side by side.
    std::vector<std::exception_ptr> errors(a.suggestions.size());
    std::vector<std::thread> threads;
    const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
    for (std::size_t first = 0; first < a.suggestions.size(); first += cores) {
      threads.clear();
      for (std::size_t i = first; i < std::min(a.suggestions.size(), first + cores); ++i) {
        threads.emplace_back([&, i] {
          try {
            a.suggestions[i].prediction = predict(a.suggestions[i].plan);
          } catch (...) {
            errors[i] = std::current_exception();
          }
        });
      }
      for (std::thread& t : threads) t.join();
    }
    // A candidate the simulator refuses (e.g. beyond its pulse budget) is not suggested; any other
    // failure is the planner's and is raised.
    std::vector<Suggestion> kept;
    for (std::size_t i = 0; i < a.suggestions.size(); ++i) {
      if (errors[i]) {
        try {
          std::rethrow_exception(errors[i]);
        } catch (const Error&) {
          continue;
        }
      }
      kept.push_back(std::move(a.suggestions[i]));
    }
    a.suggestions = std::move(kept);
    const int w = a.base.weakest;
    for (Suggestion& s : a.suggestions)
      s.weakest_sigma = s.prediction.determined[w] && std::isfinite(s.prediction.sigma[w]) ? s.prediction.sigma[w] : kInf;
    std::stable_sort(a.suggestions.begin(), a.suggestions.end(), [](const Suggestion& x, const Suggestion& y) {
      if (x.weakest_sigma != y.weakest_sigma) return x.weakest_sigma < y.weakest_sigma;
      return x.prediction.undeterminable.size() < y.prediction.undeterminable.size();
    });
  }
  a.seconds = seconds(t0);
  return a;
}

namespace {
std::string sigmaText(int j, double sigma) {
  if (!std::isfinite(sigma)) return "—";
  return j < 3 ? fmt("%.4f m", sigma) : fmt("%.5f°", rad2deg(sigma));
}
}  // namespace

std::string PlanAnalysis::text() const {
  std::ostringstream t;
  const auto& names = mountingParameterNames();
  const Prediction& p = base;
  t << "predicted from " << p.strips << " simulated strips, " << p.observations << " observation blocks, in " << fmt("%.1f s", p.seconds)
    << "\n";
  t << "  parameter            determined  sigma\n";
  for (int j = 0; j < 6; ++j) {
    char line[160];
    const bool undet = std::find(p.undeterminable.begin(), p.undeterminable.end(), names[j]) != p.undeterminable.end();
    std::snprintf(line, sizeof line, "  %-20s %-11s %s\n", names[j].c_str(),
                  p.determined[j] ? "yes"
                  : undet         ? "NO"
                                  : "held",
                  p.determined[j] ? sigmaText(j, p.sigma[j]).c_str() : "—");
    t << line;
  }
  t << "  condition number " << fmt("%.3g", p.condition_number) << "\n";
  if (!p.untied.empty()) {
    t << "  no tie (fewer than two lines see it: under a roof, behind a wall or outside the swaths):";
    for (const std::string& id : p.untied) t << " " << id;
    t << "\n";
  }
  for (int a = 0; a < 6; ++a)
    for (int b = a + 1; b < 6; ++b)
      if (p.determined[a] && p.determined[b] && std::abs(p.correlation(a, b)) > 0.9)
        t << "  strongly correlated: " << names[a] << " ~ " << names[b] << fmt(" %+.3f", p.correlation(a, b)) << "\n";
  if (!p.observability.empty()) {
    std::istringstream lines(p.observability);
    for (std::string l; std::getline(lines, l);) t << "  " << l << "\n";
  }
  if (p.weakest >= 0 && !suggestions.empty()) {
    t << "weakest: " << names[p.weakest]
      << (p.determined[p.weakest]
              ? " (sigma " + sigmaText(p.weakest, p.sigma[p.weakest]) + fmt(", %.3f m on the ground)", p.weakest_ground_sigma_m)
              : std::string(" (undeterminable)"))
      << "\ncandidate additions, best first (sigma of " << names[p.weakest] << " with each):\n";
    int k = 1;
    for (const Suggestion& s : suggestions) {
      t << "  " << k++ << ". " << s.kind << ": " << s.description << "\n     -> " << names[p.weakest] << " "
        << (std::isfinite(s.weakest_sigma) ? sigmaText(p.weakest, s.weakest_sigma) : std::string("still undeterminable"));
      if (!s.prediction.undeterminable.empty()) {
        std::string u;
        for (const auto& x : s.prediction.undeterminable) u += (u.empty() ? "" : ", ") + x;
        t << "; undeterminable: " << u;
      }
      t << "\n";
    }
  }
  t << fmt("planned in %.1f s\n", seconds);
  return t.str();
}

}  // namespace mountcal::plan
