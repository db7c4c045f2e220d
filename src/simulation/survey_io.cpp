// Reading a scenario file (a preset with overrides) for the simulator.
#include <set>
#include <nlohmann/json.hpp>

#include "io/json_fields.hpp"
#include "mountcal/core/error.hpp"
#include "mountcal/simulation/survey.hpp"

namespace mountcal::simulation {

void loadScenario(const std::string& path, SurveyConfig* config, Scene* scene) {
  const nlohmann::json j = detail::parseJsonFile(path, "scenario");
  if (!j.is_object()) throw FileError(path, "", "a scenario is a JSON object");
  static const std::set<std::string> kKnown = {"preset", "seed",         "true_mounting", "nominal_mounting",
                                               "noise",  "roi_radius_m", "one_height"};
  for (auto it = j.begin(); it != j.end(); ++it) {
    if (!kKnown.count(it.key()))
      throw FileError(path, "field '" + it.key() + "'",
                      "unknown field (known: preset, seed, true_mounting, nominal_mounting, noise, roi_radius_m, one_height)");
  }
  if (!j.contains("preset") || !j["preset"].is_string()) throw FileError(path, "field 'preset'", "missing or not a string");
  try {
    const std::uint64_t seed = j.value("seed", 1ull);
    try {
      makePreset(j["preset"].get<std::string>(), seed, config, scene);
    } catch (const InvalidInput& e) {
      throw FileError(path, "field 'preset'", e.what());
    }
    auto vec3 = [&](const nlohmann::json& a, const std::string& field) {
      if (!a.is_array() || a.size() != 3) throw FileError(path, "field '" + field + "'", "expected an array of 3 numbers");
      return Vec3(a[0].get<double>(), a[1].get<double>(), a[2].get<double>());
    };
    auto mounting = [&](const std::string& key, MountingParameters* m) {
      if (!j.contains(key)) return;
      const auto& o = j[key];
      if (o.contains("lever_arm_m")) m->a_b = vec3(o["lever_arm_m"], key + ".lever_arm_m");
      if (o.contains("boresight_deg")) m->boresight = vec3(o["boresight_deg"], key + ".boresight_deg") * (kPi / 180.0);
    };
    mounting("true_mounting", &config->true_mounting);
    mounting("nominal_mounting", &config->nominal_mounting);
    if (j.contains("one_height")) {
      if (!j["one_height"].is_boolean()) throw FileError(path, "field 'one_height'", "expected true or false");
      // Only the lines flown at the first line's height (e.g. uav-vlp16 without its second height).
      if (j["one_height"].get<bool>()) keepOneHeight(config);
    }
    if (j.contains("roi_radius_m")) {
      config->roi_radius_m = j["roi_radius_m"].get<double>();
      if (!(config->roi_radius_m >= 0 && config->roi_radius_m <= 1e4))
        throw FileError(path, "field 'roi_radius_m'", "expected a radius in [0, 10000] m (0: whole strips)");
    }
    if (j.contains("noise")) {
      const auto& n = j["noise"];
      if (n.is_string()) {
        if (n == "none")
          config->noise = NoiseModel::none();
        else if (n == "realistic")
          config->noise = NoiseModel::realistic();
        else if (n == "navigation_drift")
          config->noise = NoiseModel::withNavigationDrift();
        else
          throw FileError(path, "field 'noise'", "expected \"none\", \"realistic\", \"navigation_drift\" or an object");
      } else if (n.is_object()) {
        NoiseModel& m = config->noise;
        for (auto it = n.begin(); it != n.end(); ++it) {
          const std::string& k = it.key();
          const double v = it.value().get<double>();
          if (!(v >= 0 && v <= 1e4)) throw FileError(path, "field 'noise." + k + "'", "expected a number in [0, 10000]");
          if (k == "range_sigma_m")
            m.range_sigma_m = v;
          else if (k == "scan_angle_sigma_deg")
            m.scan_angle_sigma_rad = deg2rad(v);
          else if (k == "gnss_sigma_m")
            m.gnss_sigma_m = v;
          else if (k == "gnss_correlation_s")
            m.gnss_correlation_s = v;
          else if (k == "attitude_sigma_deg")
            m.attitude_sigma_rad = deg2rad(v);
          else if (k == "attitude_correlation_s")
            m.attitude_correlation_s = v;
          else if (k == "pick_sigma_m")
            m.pick_sigma_m = v;
          else if (k == "drift_position_sigma_m")
            m.drift_position_sigma_m = v;
          else if (k == "drift_position_period_min_s")
            m.drift_position_period_min_s = v;
          else if (k == "drift_position_period_max_s")
            m.drift_position_period_max_s = v;
          else if (k == "drift_attitude_sigma_deg")
            m.drift_attitude_sigma_rad = deg2rad(v);
          else if (k == "drift_attitude_period_min_s")
            m.drift_attitude_period_min_s = v;
          else if (k == "drift_attitude_period_max_s")
            m.drift_attitude_period_max_s = v;
          else
            throw FileError(path, "field 'noise." + k + "'", "unknown noise field");
        }
        if (!(m.drift_position_period_min_s > 0 && m.drift_position_period_min_s <= m.drift_position_period_max_s) ||
            !(m.drift_attitude_period_min_s > 0 && m.drift_attitude_period_min_s <= m.drift_attitude_period_max_s))
          throw FileError(path, "field 'noise'", "drift periods need 0 < period_min_s <= period_max_s");
      } else {
        throw FileError(path, "field 'noise'", "expected a string or an object");
      }
    }
  } catch (const nlohmann::json::exception& e) {
    throw FileError(path, "", std::string("wrong type: ") + e.what());
  }
}

}  // namespace mountcal::simulation
