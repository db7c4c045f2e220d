// Reading a scenario file (a preset with overrides) for the simulator.
#include <cmath>
#include <set>
#include <utility>
#include <vector>
#include <nlohmann/json.hpp>

#include "io/json_fields.hpp"
#include "mountcal/core/error.hpp"
#include "mountcal/simulation/survey.hpp"

namespace mountcal::simulation {

namespace {

/// "noise": a named model, or an object of NoiseModel fields (each in [0, 10000]).
void readNoise(const std::string& path, const detail::Fields& top, NoiseModel* model) {
  const nlohmann::json& n = top.at("noise");
  if (n.is_string()) {
    if (n == "none")
      *model = NoiseModel::none();
    else if (n == "realistic")
      *model = NoiseModel::realistic();
    else if (n == "navigation_drift")
      *model = NoiseModel::withNavigationDrift();
    else if (n == "navigation_drift_gauss_markov")
      *model = NoiseModel::withNavigationDrift(NoiseModel::DriftForm::kGaussMarkov);
    else
      top.fail("noise", "expected \"none\", \"realistic\", \"navigation_drift\", \"navigation_drift_gauss_markov\" or an object");
    return;
  }
  if (!n.is_object()) top.fail("noise", "expected a string or an object");
  NoiseModel& m = *model;
  const std::vector<std::pair<const char*, double*>> metres = {{"range_sigma_m", &m.range_sigma_m},
                                                               {"gnss_sigma_m", &m.gnss_sigma_m},
                                                               {"gnss_correlation_s", &m.gnss_correlation_s},
                                                               {"attitude_correlation_s", &m.attitude_correlation_s},
                                                               {"pick_sigma_m", &m.pick_sigma_m},
                                                               {"drift_position_sigma_m", &m.drift_position_sigma_m},
                                                               {"drift_position_period_min_s", &m.drift_position_period_min_s},
                                                               {"drift_position_period_max_s", &m.drift_position_period_max_s},
                                                               {"drift_attitude_period_min_s", &m.drift_attitude_period_min_s},
                                                               {"drift_attitude_period_max_s", &m.drift_attitude_period_max_s}};
  const std::vector<std::pair<const char*, double*>> degrees = {{"scan_angle_sigma_deg", &m.scan_angle_sigma_rad},
                                                                {"attitude_sigma_deg", &m.attitude_sigma_rad},
                                                                {"drift_attitude_sigma_deg", &m.drift_attitude_sigma_rad}};
  std::set<std::string> known;
  for (const auto& f : metres) known.insert(f.first);
  for (const auto& f : degrees) known.insert(f.first);
  known.insert("drift_form");
  known.insert("drift_scale_by_line");
  const detail::Fields nf(path, n, "noise", known);
  if (nf.has("drift_scale_by_line")) {
    const nlohmann::json& a = nf.at("drift_scale_by_line");
    if (!a.is_array()) nf.fail("drift_scale_by_line", "expected an array of factors, one per line");
    m.drift_scale_by_line.clear();
    for (const nlohmann::json& v : a) {
      if (!v.is_number() || !(v.get<double>() >= 0 && v.get<double>() <= 100))
        nf.fail("drift_scale_by_line", "expected factors in [0, 100]");
      m.drift_scale_by_line.push_back(v.get<double>());
    }
  }
  const std::string form = nf.str("drift_form", "band_limited");
  if (form == "gauss_markov")
    m.drift_form = NoiseModel::DriftForm::kGaussMarkov;
  else if (form != "band_limited")
    nf.fail("drift_form", "expected \"band_limited\" or \"gauss_markov\"");
  for (const auto& [k, v] : metres) *v = nf.num(k, *v, 0.0, 1e4);
  for (const auto& [k, v] : degrees) *v = deg2rad(nf.num(k, rad2deg(*v), 0.0, 1e4));
  if (!(m.drift_position_period_min_s > 0 && m.drift_position_period_min_s <= m.drift_position_period_max_s) ||
      !(m.drift_attitude_period_min_s > 0 && m.drift_attitude_period_min_s <= m.drift_attitude_period_max_s))
    top.fail("noise", "drift periods need 0 < period_min_s <= period_max_s");
}

/// A seed field: any integer a 64-bit seed takes up to 2^53 (JSON numbers are doubles); 2.5 or
/// -1 is an error naming the field.
std::uint64_t readSeed(const detail::Fields& f, const std::string& key, std::uint64_t def) {
  if (!f.has(key)) return def;
  const double seed = f.num(key);
  if (seed != std::floor(seed) || seed < 0 || seed > 9007199254740992.0) f.fail(key, "expected an integer in [0, 2^53]");
  return static_cast<std::uint64_t>(seed);
}

/// "laser_errors": {"preset", "elevation_sigma_deg", "azimuth_sigma_deg", "vertical_sigma_m",
/// "range_sigma_m", "horizontal_sigma_m", "seed"} — per-laser errors of a multi-beam sensor drawn
/// by drawLaserErrors; "preset" ("VLP-16", "HDL-32E": laserErrorPreset) sets the σ the other keys
/// do not give.
void readLaserErrors(const detail::Fields& top, SurveyConfig* config) {
  if (config->sensor != SensorType::kMultiBeam) top.fail("laser_errors", "the preset's sensor is not a multi-beam scanner");
  const detail::Fields e = top.sub("laser_errors", {"preset", "elevation_sigma_deg", "azimuth_sigma_deg", "vertical_sigma_m",
                                                    "range_sigma_m", "horizontal_sigma_m", "seed"});
  LaserErrorSigmas s;
  if (e.has("preset")) {
    const std::string name = e.str("preset");
    if (name != "VLP-16" && name != "HDL-32E") e.fail("preset", "expected \"VLP-16\" or \"HDL-32E\"");
    s = laserErrorPreset(name);
  }
  config->multibeam.laser_errors = drawLaserErrors(
      config->multibeam.model.laserCount(), readSeed(e, "seed", 1),
      deg2rad(e.num("elevation_sigma_deg", rad2deg(s.elevation_rad), 0.0, 1.0)),
      deg2rad(e.num("azimuth_sigma_deg", rad2deg(s.azimuth_rad), 0.0, 1.0)), e.num("vertical_sigma_m", s.vertical_m, 0.0, 0.1),
      e.num("range_sigma_m", s.range_m, 0.0, 0.1), e.num("horizontal_sigma_m", s.horizontal_m, 0.0, 0.1));
}

}  // namespace

void loadScenario(const std::string& path, SurveyConfig* config, Scene* scene) {
  const nlohmann::json j = detail::parseJsonFile(path, "scenario");
  const detail::Fields top(
      path, j, "",
      {"preset", "seed", "true_mounting", "nominal_mounting", "noise", "roi_radius_m", "one_height", "max_points", "laser_errors"});
  const std::string preset = top.str("preset");
  const std::uint64_t seed = readSeed(top, "seed", 1);
  try {
    makePreset(preset, seed, config, scene);
  } catch (const InvalidInput& e) {
    top.fail("preset", e.what());
  }
  // A mounting within a platform's size: a lever arm of 1e300 m would leave no point on the ground.
  auto mounting = [&](const std::string& key, MountingParameters* m) {
    if (!top.has(key)) return;
    const detail::Fields o = top.sub(key, {"lever_arm_m", "boresight_deg"});
    if (o.has("lever_arm_m")) m->a_b = o.leverArmM("lever_arm_m");
    if (o.has("boresight_deg")) m->boresight = o.boresightDeg("boresight_deg") * (kPi / 180.0);
  };
  mounting("true_mounting", &config->true_mounting);
  mounting("nominal_mounting", &config->nominal_mounting);
  // Only the lines flown at the first line's height (e.g. uav-vlp16 without its second height).
  if (top.boolean("one_height", false)) keepOneHeight(config);
  config->roi_radius_m = top.num("roi_radius_m", config->roi_radius_m, 0.0, 1e4);  // 0: whole strips
  if (top.has("noise")) readNoise(path, top, &config->noise);
  config->max_points = top.num("max_points", config->max_points, 1.0, 1e9);  // the memory budget (SurveyConfig)
  if (top.has("laser_errors")) readLaserErrors(top, config);
}

}  // namespace mountcal::simulation
