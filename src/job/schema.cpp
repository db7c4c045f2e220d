#include "mountcal/job/schema.hpp"

#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>

#include "io/json_fields.hpp"
#include "job/stochastic_fields.hpp"
#include "mountcal/methods/method.hpp"
#include "mountcal/core/error.hpp"
#include "mountcal/io/atomic_file.hpp"
#include "mountcal/io/crs.hpp"

namespace mountcal {

using detail::Fields;
using nlohmann::json;

namespace {

const char* lossName(LossType l) {
  switch (l) {
    case LossType::kHuber:
      return "huber";
    case LossType::kCauchy:
      return "cauchy";
    default:
      return "trivial";
  }
}

/// The laser tables a job names by `sensor.model`; empty for another name.
std::optional<MultiBeamModel> namedMultiBeamModel(const std::string& model) {
  if (model == "VLP-16") return MultiBeamModel::VLP16();
  if (model == "HDL-32E") return MultiBeamModel::HDL32E();
  return std::nullopt;
}

void readSensor(const std::string& path, const Fields& top, Job* job) {
  const Fields sensor = top.sub("sensor", {"type", "nominal_rotation_deg", "model", "lasers", "range_offset_m", "scan_angle_scale",
                                           "scan_angle_offset_deg", "laser_field", "laser_table_tolerance_deg", "range_accuracy_m"});
  const std::string type = sensor.str("type");
  job->nominal_rotation_deg = sensor.has("nominal_rotation_deg") ? sensor.vec3("nominal_rotation_deg") : Vec3::Zero();
  if (type == "line") {
    LineScannerModel m;
    m.range_offset_m = sensor.num("range_offset_m", 0.0);
    m.scan_angle_scale = sensor.num("scan_angle_scale", 1.0);
    m.scan_angle_offset_rad = deg2rad(sensor.num("scan_angle_offset_deg", 0.0));
    job->sensor = SensorModel::lineScanner(m);
  } else if (type == "multibeam") {
    job->laser_field = sensor.str("laser_field", "");
    job->laser_table_tolerance_deg = sensor.num("laser_table_tolerance_deg", 5.0);
    if (!(job->laser_table_tolerance_deg >= 0 && job->laser_table_tolerance_deg <= 90))
      sensor.fail("laser_table_tolerance_deg", "expected degrees in [0, 90] (0: not checked)");
    if (sensor.has("lasers")) {
      const json& lasers = sensor.at("lasers");
      if (!lasers.is_array() || lasers.empty()) sensor.fail("lasers", "expected a non-empty array of lasers");
      std::vector<LaserSpec> specs;
      for (std::size_t i = 0; i < lasers.size(); ++i) {
        const Fields l(
            path, lasers[i], "sensor.lasers[" + std::to_string(i) + "]",
            {"elevation_deg", "vertical_offset_m", "azimuth_offset_deg", "range_offset_m", "firing_offset_s", "horizontal_offset_m"});
        LaserSpec s;
        s.elevation_rad = deg2rad(l.num("elevation_deg"));
        s.vertical_offset_m = l.num("vertical_offset_m", 0.0);
        s.azimuth_offset_rad = deg2rad(l.num("azimuth_offset_deg", 0.0));
        s.range_offset_m = l.num("range_offset_m", 0.0);
        s.firing_offset_s = l.num("firing_offset_s", 0.0);
        s.horizontal_offset_m = l.num("horizontal_offset_m", 0.0);
        specs.push_back(s);
      }
      job->sensor_model = sensor.str("model", "custom");
      job->sensor = SensorModel::multiBeam(MultiBeamModel(job->sensor_model, specs, 0.0));
    } else {
      const std::string model = sensor.str("model");
      const std::optional<MultiBeamModel> named = namedMultiBeamModel(model);
      if (!named) sensor.fail("model", "unknown multi-beam model '" + model + "' (VLP-16, HDL-32E, or give a \"lasers\" table)");
      job->sensor = SensorModel::multiBeam(*named);
      job->sensor_model = model;
    }
    // The maker's range accuracy: a named model's own (MultiBeamModel::rangeAccuracy), or given.
    if (sensor.has("range_accuracy_m")) {
      const double a = sensor.num("range_accuracy_m");
      if (!(a >= 0 && a <= 1)) sensor.fail("range_accuracy_m", "expected metres in [0, 1] (0: unknown)");
      job->sensor.multibeam.setRangeAccuracy(a);
    }
  } else if (type == "vector") {
    job->sensor = SensorModel::vectorSensor();
  } else {
    sensor.fail("type", "expected \"line\", \"multibeam\" or \"vector\"");
  }
}

/// The top-level keys of a job: the fixed ones and every registered method's.
std::set<std::string> topLevelKeys() {
  std::set<std::string> keys = {"frame",  "trajectory",   "sensor",       "mounting_used", "strips",      "ties",
                                "method", "estimate",     "stochastic",   "solver",        "pulse_noise", "output",
                                "gcps",   "check_points", "check_planes", "planes",        "targets",     "poses"};
  for (const auto& m : registeredMethods()) {
    keys.insert(m->name());
    for (const std::string& k : m->legacyOptionKeys()) keys.insert(k);
    if (!m->input().job_key.empty()) keys.insert(m->input().job_key);
  }
  return keys;
}

/// The key inside a method's options object that holds its input, when the method's input and
/// options share one job key ("planes": {"regions": "auto", …}).
constexpr const char* kInputInObject = "regions";

/// Reads one method's options object (declared by the method) into `options`.
void readMethodOptions(const Fields& f, const Method& m, std::any* options) {
  for (const OptionSpec& spec : m.options()) {
    if (!f.has(spec.key)) continue;
    switch (spec.type) {
      case OptionSpec::Type::kBoolean:
        spec.set(*options, f.boolean(spec.key, false) ? 1.0 : 0.0);
        break;
      case OptionSpec::Type::kInteger:
        spec.set(*options, f.integer(spec.key, 0, static_cast<int>(spec.min), static_cast<int>(spec.max)));
        break;
      case OptionSpec::Type::kNumber:
        spec.set(*options, f.num(spec.key, 0.0, spec.min, spec.max));
        break;
      case OptionSpec::Type::kChoice:
        spec.set(*options, f.choice(spec.key, 0, spec.choices));
        break;
    }
  }
}

/// Every registered method's options object of the job (under the method's name, or a legacy
/// key with a notice), and the input value of the methods whose input shares that key.
void readMethodSections(const std::string& path, const Fields& top, const json& j, Job* job) {
  MountingCalibrator::Options& opts = job->options;
  for (const auto& m : registeredMethods()) {
    std::string key;
    if (top.has(m->name()) && j.at(m->name()).is_object()) key = m->name();
    for (const std::string& legacy : m->legacyOptionKeys()) {
      if (!top.has(legacy)) continue;
      if (!key.empty())
        top.fail(legacy, "the options of method \"" + m->name() + "\" are given twice (\"" + key + "\" and \"" + legacy + "\")");
      key = legacy;
      job->notices.push_back("field '" + legacy + "' is deprecated: write the options of method \"" + m->name() + "\" under \"" +
                             m->name() + "\"");
    }
    if (key.empty()) continue;
    json section = j.at(key);
    if (!section.is_object()) top.fail(key, "expected an object of the options of method \"" + m->name() + "\"");
    if (m->name() == "vtpm" && section.contains("strip_offset_sigma_m")) section.erase("strip_offset_sigma_m");  // read by readStochastic
    std::set<std::string> known;
    for (const OptionSpec& spec : m->options()) known.insert(spec.key);
    const bool input_inside = m->input().job_key == key;
    if (input_inside) known.insert(kInputInObject);
    const Fields f(path, section, key, known);
    std::any& options = opts.method_options.at(m->name(), m->defaultOptions());
    readMethodOptions(f, *m, &options);
    if (input_inside && f.has(kInputInObject)) job->method_inputs[m->name()] = f.str(kInputInObject);
  }
}

}  // namespace

void detail::readTrajectoryModel(const Fields& st, StochasticOptions* options) {
  StochasticOptions& opts = *options;
  opts.time_offset_sigma_s = st.num("time_offset_sigma_s", opts.time_offset_sigma_s, 0.0, 10.0);
  opts.estimate_time_offset = st.boolean("estimate_time_offset", opts.estimate_time_offset);
  if (opts.estimate_time_offset && !(opts.time_offset_sigma_s > 0))
    st.fail("estimate_time_offset", "needs \"time_offset_sigma_s\" > 0, the time offset's prior σ");
  if (st.has("corrections")) {
    // Per-strip trajectory corrections in time (Legendre polynomials over each strip's span).
    const Fields c = st.sub("corrections", {"position_degree", "attitude_degree", "position_sigma_m", "roll_pitch_sigma_deg",
                                            "heading_sigma_deg", "priors_from_accuracy"});
    TrajectoryCorrections& tc = opts.corrections;
    tc.position_degree = c.integer("position_degree", tc.position_degree, 0, 3);
    tc.attitude_degree = c.integer("attitude_degree", tc.attitude_degree, 0, 3);
    tc.priors_from_accuracy = c.boolean("priors_from_accuracy", tc.priors_from_accuracy);
    if (tc.priors_from_accuracy)
      for (const char* key : {"position_sigma_m", "roll_pitch_sigma_deg", "heading_sigma_deg"})
        if (c.has(key))
          c.fail(key, "is the priors' own σ; with \"priors_from_accuracy\" they come from \"trajectory\" — state one or the other");
    tc.position_sigma_m = c.num("position_sigma_m", tc.position_sigma_m, 1e-6, 100.0);
    tc.roll_pitch_sigma_deg = c.num("roll_pitch_sigma_deg", tc.roll_pitch_sigma_deg, 1e-6, 10.0);
    tc.heading_sigma_deg = c.num("heading_sigma_deg", tc.heading_sigma_deg, 1e-6, 10.0);
  }
}

namespace {

/// The stochastic settings every method shares: "stochastic" (and the earlier
/// "vtpm.strip_offset_sigma_m", with a notice).
void readStochastic(const Fields& top, const json& j, Job* job) {
  MountingCalibrator::Options& opts = job->options;
  if (top.has("stochastic")) {
    const Fields st =
        top.sub("stochastic", {"strip_offset_sigma_m", "trajectory", "time_offset_sigma_s", "estimate_time_offset", "corrections"});
    opts.strip_offset_sigma_m = st.num("strip_offset_sigma_m", opts.strip_offset_sigma_m, 0.0, 1000.0);
    detail::readTrajectoryModel(st, &opts);
    if (st.has("trajectory") && st.at("trajectory").is_string()) {
      if (st.str("trajectory") != "none") st.fail("trajectory", "expected \"none\" or an object of σ and τ");
      opts.trajectory = TrajectoryAccuracy::none();
    } else if (st.has("trajectory")) {
      // Trajectory errors in time: the GNSS/INS solution's accuracy (σ, or along time its SBET's
      // smrmsg file), τ its periods.
      const Fields t =
          st.sub("trajectory", {"position_sigma_m", "position_correlation_s", "roll_pitch_sigma_deg", "heading_sigma_deg",
                                "attitude_correlation_s", "smrmsg", "offsets_within_drift", "gnss_sigma_m", "gnss_correlation_s"});
      if (t.has("smrmsg")) {
        for (const char* k : {"position_sigma_m", "roll_pitch_sigma_deg", "heading_sigma_deg", "gnss_sigma_m"})
          if (t.has(k)) t.fail(k, "the σ are given twice: \"smrmsg\" states them along time (keep the correlation times only)");
        const std::string file = t.str("smrmsg");
        if (file.empty()) t.fail("smrmsg", "expected the path of an SBET accuracy (smrmsg) file");
        job->trajectory_accuracy_path = detail::resolvePath(job->path, file);
      }
      TrajectoryAccuracy& a = opts.trajectory;
      a.position_sigma_m = t.num("position_sigma_m", a.position_sigma_m, 0.0, 100.0);
      a.position_correlation_s = t.num("position_correlation_s", a.position_correlation_s, 0.01, 86400.0);
      a.roll_pitch_sigma_deg = t.num("roll_pitch_sigma_deg", a.roll_pitch_sigma_deg, 0.0, 10.0);
      a.heading_sigma_deg = t.num("heading_sigma_deg", a.heading_sigma_deg, 0.0, 10.0);
      a.attitude_correlation_s = t.num("attitude_correlation_s", a.attitude_correlation_s, 0.01, 86400.0);
      // The position drift is the strips' whole slow error, the offsets' prior its constant part.
      a.offsets_within_drift = t.boolean("offsets_within_drift", a.offsets_within_drift);
      // The GNSS solution's own slow error beside the drift (its σ per axis and τ).
      a.gnss_sigma_m = t.num("gnss_sigma_m", a.gnss_sigma_m, 0.0, 100.0);
      a.gnss_correlation_s = t.num("gnss_correlation_s", a.gnss_correlation_s, 0.01, 86400.0);
    }
  }
  if (top.has("vtpm") && j.at("vtpm").is_object() && j.at("vtpm").contains("strip_offset_sigma_m")) {
    if (top.has("stochastic") && j.at("stochastic").contains("strip_offset_sigma_m"))
      top.fail("vtpm", "strip_offset_sigma_m is given twice (\"stochastic\" and \"vtpm\")");
    const json only = {{"strip_offset_sigma_m", j.at("vtpm").at("strip_offset_sigma_m")}};
    const Fields v(job->path, only, "vtpm", {"strip_offset_sigma_m"});
    opts.strip_offset_sigma_m = v.num("strip_offset_sigma_m", opts.strip_offset_sigma_m, 0.0, 1000.0);
    job->notices.push_back(
        "field 'vtpm.strip_offset_sigma_m' is deprecated: every method uses the strip offsets; write it as "
        "\"stochastic\": {\"strip_offset_sigma_m\": …}");
  }
}

}  // namespace

namespace {

/// "frame": local, or a projected CRS.
void readFrame(const Fields& top, Job* job) {
  const Fields frame = top.sub("frame", {"type", "crs"});
  const std::string frame_type = frame.str("type");
  if (frame_type == "local")
    job->frame_type = JobFrameType::kLocal;
  else if (frame_type == "crs")
    job->frame_type = JobFrameType::kCrs;
  else
    frame.fail("type", "expected \"local\" or \"crs\"");
  if (job->frame_type == JobFrameType::kCrs) {
    job->crs = frame.str("crs");
    bool geographic = false;
    try {
      geographic = io::CrsTransform::isGeographic(job->crs);
    } catch (const InvalidInput& e) {
      frame.fail("crs", e.what());
    }
    if (geographic)
      frame.fail("crs",
                 "'" + job->crs + "' is geographic (degrees); the strips and the job need a projected CRS in metres (e.g. a UTM zone)");
  }
}

/// Per-point "poses" from extra bytes, or the "trajectory" file.
void readPoseSource(const std::string& path, const Fields& top, Job* job) {
  if (top.has("poses")) {
    if (top.has("trajectory")) top.fail("poses", "a job takes either a \"trajectory\" or per-point \"poses\", not both");
    if (job->frame_type != JobFrameType::kLocal) {
      top.fail("poses",
               "per-point poses need \"frame\": {\"type\": \"local\"}: positions and attitudes are taken in the strips' own (projected) "
               "coordinates");
    }
    const Fields p = top.sub("poses", {"from", "position", "attitude", "attitude_unit", "convention"});
    if (p.str("from", "extra_bytes") != "extra_bytes") p.fail("from", "expected \"extra_bytes\"");
    auto names3 = [&](const std::string& k, std::array<std::string, 3>* out) {
      if (!p.has(k)) return;
      const json& a = p.at(k);
      if (!a.is_array() || a.size() != 3) p.fail(k, "expected an array of 3 attribute names");
      for (int i = 0; i < 3; ++i) {
        if (!a[i].is_string() || a[i].get<std::string>().empty()) p.fail(k, "expected an array of 3 attribute names");
        (*out)[i] = a[i].get<std::string>();
      }
    };
    job->per_point_poses = true;
    names3("position", &job->pose_fields.position);
    names3("attitude", &job->pose_fields.attitude);
    const std::string unit = p.str("attitude_unit", "rad");
    if (unit != "rad" && unit != "deg") p.fail("attitude_unit", "expected \"rad\" or \"deg\"");
    job->pose_fields.degrees = unit == "deg";
    try {
      job->pose_fields.convention = io::attitudeConventionFromString(p.str("convention"));
    } catch (const InvalidInput& e) {
      p.fail("convention", e.what());
    }
  } else {
    const Fields traj = top.sub("trajectory", {"path", "format", "time_offset_s"});
    job->trajectory_path = detail::resolvePath(path, traj.str("path"));
    const std::string format = traj.str("format", "csv");
    if (format == "csv")
      job->trajectory_format = TrajectoryFormat::kCsv;
    else if (format == "sbet")
      job->trajectory_format = TrajectoryFormat::kSbet;
    else
      traj.fail("format", "expected \"csv\" or \"sbet\"");
    job->time_offset_s = traj.num("time_offset_s", 0.0);
  }
}

/// True when two strip entries can hold the same records: the same file, and selections that
/// are not disjoint (either unsplit; the same part; overlapping ranges of one field). Parts of
/// different gaps or ranges of different fields are taken as different passes.
bool shareRecords(const JobStrip& a, const JobStrip& b) {
  if (!io::samePath(a.path, b.path)) return false;
  if (!a.split.active() || !b.split.active()) return true;
  if (a.split.field != b.split.field) return false;
  if (a.split.part > 0 || b.split.part > 0) return a.split.part == b.split.part && a.split.gap == b.split.gap;
  return a.split.min <= b.split.max && b.split.min <= a.split.max;
}

/// "strips": ids, files, formats and splits.
void readStrips(const std::string& path, const Fields& top, Job* job) {
  const json& strips = top.at("strips");
  if (!strips.is_array() || strips.empty()) top.fail("strips", "expected a non-empty array of {\"id\", \"path\"}");
  std::set<std::string> ids;
  for (std::size_t i = 0; i < strips.size(); ++i) {
    const Fields s(path, strips[i], "strips[" + std::to_string(i) + "]", {"id", "path", "format", "split"});
    JobStrip js;
    js.id = s.str("id");
    js.path = detail::resolvePath(path, s.str("path"));
    js.format = s.str("format", "las");
    if (js.format != "las" && js.format != "raw_csv") s.fail("format", "expected \"las\" or \"raw_csv\"");
    if (job->per_point_poses && js.format != "las")
      s.fail("format", "per-point poses come from LAS extra bytes; a raw CSV strip needs a trajectory");
    if (s.has("split")) {
      if (js.format != "las") s.fail("split", "only a LAS strip can be split by a field");
      const Fields sp = s.sub("split", {"field", "range", "part", "gap"});
      js.split.field = sp.str("field");
      if (js.split.field.empty()) sp.fail("field", "expected a field name");
      if (sp.has("range") == sp.has("part")) sp.fail("", "expected either \"range\": [min, max] or \"part\" (with \"gap\")");
      if (sp.has("range")) {
        const json& r = sp.at("range");
        if (!r.is_array() || r.size() != 2 || !r[0].is_number() || !r[1].is_number()) sp.fail("range", "expected [min, max]");
        js.split.min = r[0].get<double>();
        js.split.max = r[1].get<double>();
        if (!std::isfinite(js.split.min) || !std::isfinite(js.split.max) || js.split.min > js.split.max)
          sp.fail("range", "expected finite min <= max");
      } else {
        js.split.part = sp.integer("part", 0, 1, 1000000);
        js.split.gap = sp.num("gap", 1.0);
        if (!(js.split.gap >= 0)) sp.fail("gap", "expected a number >= 0");
      }
    }
    if (!ids.insert(js.id).second) s.fail("id", "strip id '" + js.id + "' appears twice");
    for (std::size_t k = 0; k < job->strips.size(); ++k)  // a pass matched with itself gives a confident, wrong boresight
      if (shareRecords(job->strips[k], js))
        s.fail("", "selects records of " + js.path + " that strips[" + std::to_string(k) + "] ('" + job->strips[k].id +
                       "') selects too: two strips must be different passes");
    job->strips.push_back(js);
  }
}

/// The input files and every method's options object.
void readInputs(const std::string& path, const Fields& top, const json& j, Job* job) {
  job->ties_path = detail::resolvePath(path, top.str("ties", ""));
  job->gcps_path = detail::resolvePath(path, top.str("gcps", ""));
  job->check_points_path = detail::resolvePath(path, top.str("check_points", ""));
  job->check_planes_path = detail::resolvePath(path, top.str("check_planes", ""));
  job->targets_path = detail::resolvePath(path, top.str("targets", ""));
  readMethodSections(path, top, j, job);
  readStochastic(top, j, job);
  for (const auto& m : registeredMethods()) {  // a method's input given as a string at its job key
    const std::string& key = m->input().job_key;
    if (key.empty() || !top.has(key) || j.at(key).is_object()) continue;
    if (job->method_inputs.count(m->name())) top.fail(key, "given twice (also as \"" + key + "." + kInputInObject + "\")");
    job->method_inputs[m->name()] = top.str(key);
  }
  if (job->method_inputs.count("planes")) {
    const std::string& planes = job->method_inputs["planes"];
    if (planes == "auto")
      job->planes_auto = true;
    else
      job->planes_path = detail::resolvePath(path, planes);
  }
}

/// Defaults that come from the data (issue 26: a job without hand tuning), set before the job's
/// own keys are read so that every key the job gives overrides them:
///  - strips cut by "split" from one recording share one continuous trajectory: no strip offsets
///    between them (their relative drift over the seconds between the parts is what
///    "stochastic.trajectory" states);
///  - a spinning multi-beam sensor: the correspondences match densely (passes over one object,
///    not airborne strips), with per-laser elevation offsets under a 0.15° prior (the order of
///    the corrections found on the Gravity HDL-32E passes);
///  - a sensor whose range accuracy is known (MultiBeamModel::rangeAccuracy: a named model's, or
///    sensor.range_accuracy_m): a plane fitted to its points whose σ exceeds 1.5 × that accuracy
///    is rough (correspondences.max_roughness_m). The radius-relative bound alone (0.2 r) let 5 cm
///    planes in on the Gravity passes, whose noise is 2 cm.
/// The robust loss of a multi-beam correspondence job is set in readJob, once the methods are known.
void applyDataDefaults(Job* job) {
  bool one_recording = job->strips.size() > 1;
  for (const JobStrip& s : job->strips) one_recording &= !s.split.field.empty() && s.path == job->strips.front().path;
  if (one_recording) job->options.strip_offset_sigma_m = 0.0;
  if (job->sensor.type == SensorType::kMultiBeam) {
    const Method* m = findMethod("correspondences");
    if (!m) return;
    std::any& o = job->options.method_options.at(m->name(), m->defaultOptions());
    const double range_accuracy_m = job->sensor.multibeam.rangeAccuracy();
    for (const OptionSpec& spec : m->options()) {
      if (spec.key == "dense") spec.set(o, 1.0);
      if (spec.key == "laser_elevation_sigma_deg") spec.set(o, 0.15);
      if (spec.key == "max_roughness_m" && range_accuracy_m > 0) spec.set(o, 1.5 * range_accuracy_m);
    }
  }
}

/// "method": a name or an array of names (SPEC §4); each named method's input is required.
void readMethods(const Fields& top, Job* job, bool require_inputs = true) {
  // ---- methods: a name or an array of names (SPEC §4) ---------------------------------------
  MountingCalibrator::Options& opts = job->options;
  std::vector<std::string> methods;
  auto addMethod = [&](const std::string& name) {
    const Method* m = findMethod(name);
    if (!m || m->implicit())
      top.fail("method", "unknown method '" + name + "' (expected one of " + methodNames() + ", or an array of them)");
    if (std::find(methods.begin(), methods.end(), name) != methods.end()) top.fail("method", "method '" + name + "' named twice");
    methods.push_back(name);
  };
  if (!top.has("method")) {
    methods.push_back(job->ties_path.empty() ? "correspondences" : "vtpm");
  } else if (top.at("method").is_array()) {
    const json& list = top.at("method");
    if (list.empty()) top.fail("method", "expected a method name or a non-empty array of them");
    for (const json& m : list) {
      if (!m.is_string()) top.fail("method", "expected an array of method names");
      addMethod(m.get<std::string>());
    }
  } else {
    addMethod(top.str("method"));
  }
  opts.methods = methods;
  for (const std::string& name : methods) {
    const Method& m = *findMethod(name);
    const MethodInput in = m.input();
    const auto given = job->method_inputs.find(name);
    if (require_inputs && in.required && !in.job_key.empty() && given == job->method_inputs.end())
      top.fail(in.job_key, "missing: method \"" + name + "\" needs " + in.doc + " (SPEC §4)");
    if (given != job->method_inputs.end()) m.adoptInput(given->second, &opts.method_options.at(name, m.defaultOptions()));
  }
}

/// The settings every method shares: "estimate", "pulse_noise", "solver".
void readSettings(const Fields& top, Job* job) {
  MountingCalibrator::Options& opts = job->options;
  if (top.has("estimate")) {
    const Fields e = top.sub("estimate", {"lever_arm", "boresight"});
    if (e.has("lever_arm")) {
      const auto a = e.bool3("lever_arm");
      for (int i = 0; i < 3; ++i) opts.estimate[i] = a[i];
    }
    if (e.has("boresight")) {
      const auto b = e.bool3("boresight");
      for (int i = 0; i < 3; ++i) opts.estimate[3 + i] = b[i];
    }
  }
  if (top.has("pulse_noise")) {
    // The per-point noise of the stochastic model (PulseNoise): navigation and scanner
    // precision as the manufacturers state them.
    const Fields n =
        top.sub("pulse_noise", {"position_m", "roll_pitch_deg", "heading_deg", "range_m", "beam_deg", "attitude_correlation_s"});
    PulseNoise& pn = opts.pulse_noise;
    pn.position_m = n.num("position_m", pn.position_m, 0.0, 10.0);
    pn.roll_pitch_deg = n.num("roll_pitch_deg", pn.roll_pitch_deg, 0.0, 10.0);
    pn.heading_deg = n.num("heading_deg", pn.heading_deg, 0.0, 10.0);
    pn.range_m = n.num("range_m", pn.range_m, 0.0, 10.0);
    pn.beam_deg = n.num("beam_deg", pn.beam_deg, 0.0, 10.0);
    pn.attitude_correlation_s = n.num("attitude_correlation_s", pn.attitude_correlation_s, 0.0, 3600.0);
  }
  if (top.has("solver")) {
    const Fields s = top.sub("solver", {"max_iterations", "loss", "loss_scale_m", "function_tolerance", "parameter_tolerance",
                                        "scale_covariance_by_variance_factor", "max_rematch_rounds", "rematch_tolerance_m",
                                        "rematch_tolerance_deg", "max_iterations_per_matching", "resolve_check", "resolve_reject_sigma"});
    opts.max_iterations = s.integer("max_iterations", opts.max_iterations, 1, 100000);
    const std::string loss = s.str("loss", lossName(opts.loss));
    if (loss == "trivial")
      opts.loss = LossType::kTrivial;
    else if (loss == "huber")
      opts.loss = LossType::kHuber;
    else if (loss == "cauchy")
      opts.loss = LossType::kCauchy;
    else
      s.fail("loss", "expected \"trivial\", \"huber\" or \"cauchy\"");
    opts.loss_scale_m = s.num("loss_scale_m", opts.loss_scale_m);
    opts.function_tolerance = s.num("function_tolerance", opts.function_tolerance);
    opts.parameter_tolerance = s.num("parameter_tolerance", opts.parameter_tolerance);
    opts.scale_covariance_by_variance_factor = s.boolean("scale_covariance_by_variance_factor", opts.scale_covariance_by_variance_factor);
    opts.max_rematch_rounds = s.integer("max_rematch_rounds", opts.max_rematch_rounds, 1, 1000);
    opts.rematch_tolerance_m = s.num("rematch_tolerance_m", opts.rematch_tolerance_m);
    opts.max_iterations_per_matching = s.integer("max_iterations_per_matching", opts.max_iterations_per_matching, 0, 100000);
    opts.rematch_tolerance_rad = deg2rad(s.num("rematch_tolerance_deg", rad2deg(opts.rematch_tolerance_rad)));
    opts.resolve_check = s.boolean("resolve_check", opts.resolve_check);
    opts.resolve_reject_sigma = s.num("resolve_reject_sigma", opts.resolve_reject_sigma, 2.0, 1e6);
  }
}

}  // namespace

/// "mounting_used.lever_arm_sigma_m": the lever arm was measured on the aircraft (tape, total
/// station) with these σ per axis: a prior observation of the used value, not a hard hold (0:
/// no prior on that axis).
void readMeasuredLeverArm(const Fields& used, Job* job) {
  if (!used.has("lever_arm_sigma_m")) return;
  const Vec3 sigma = used.vec3("lever_arm_sigma_m");
  for (int i = 0; i < 3; ++i) {
    if (sigma[i] < 0 || sigma[i] > 100) used.fail("lever_arm_sigma_m", "each σ must be in [0, 100] m (0: no prior on that axis)");
    job->options.prior_value[static_cast<std::size_t>(i)] = job->mounting_used.a_b[i];
    job->options.prior_sigma[static_cast<std::size_t>(i)] = sigma[i];
  }
}

namespace {

/// A JSON object given as text by a caller (not a file): InvalidInput naming `what` otherwise.
json parseObjectText(const std::string& text, const std::string& what) {
  json j;
  try {
    j = json::parse(text);
  } catch (const json::exception& e) {
    throw InvalidInput(what + " are not JSON: " + e.what());
  }
  if (!j.is_object()) throw InvalidInput(what + " must be a JSON object");
  return j;
}

}  // namespace

Job readJob(const std::string& path, const std::string& overrides_json) {
  json j = detail::parseJsonFile(path, "job");
  if (!overrides_json.empty()) {
    // RFC 7386 merge patch: an object merges key by key, anything else replaces, null removes.
    const json patch = parseObjectText(overrides_json, path + ": the overrides");
    if (!j.is_object()) throw FileError(path, "", "expected a JSON object (SPEC §4)");
    j.merge_patch(patch);
  }
  Job job;
  job.path = path;
  const Fields top(path, j, "", topLevelKeys());
  readFrame(top, &job);
  readPoseSource(path, top, &job);
  readSensor(path, top, &job);
  const Fields used = top.sub("mounting_used", {"lever_arm_m", "boresight_deg", "lever_arm_sigma_m"});
  job.mounting_used =
      MountingParameters::fromDegrees(used.leverArmM("lever_arm_m"), used.boresightDeg("boresight_deg"), job.nominal_rotation_deg);
  readStrips(path, top, &job);
  applyDataDefaults(&job);
  readInputs(path, top, j, &job);
  readMethods(top, &job);
  if (job.sensor.type == SensorType::kMultiBeam && job.options.methods == std::vector<std::string>{"correspondences"}) {
    // Real multi-beam passes carry moving objects and edges: a Cauchy loss from 1.5× the
    // scanner's range accuracy, 3 cm when it is unknown (the job's "solver" overrides it).
    const double accuracy_m = job.sensor.multibeam.rangeAccuracy();
    job.options.loss = LossType::kCauchy;
    job.options.loss_scale_m = accuracy_m > 0 ? 1.5 * accuracy_m : 0.03;
  }
  readSettings(top, &job);
  readMeasuredLeverArm(used, &job);
  std::string why;
  if (!job.options.IsValid(&why)) throw FileError(path, "", "invalid calibration settings: " + why);
  if (top.has("output")) {
    const Fields out = top.sub("output", {"result", "report"});
    job.result_path = detail::resolvePath(path, out.str("result", ""));
    job.report_path = detail::resolvePath(path, out.str("report", ""));
  }
  return job;
}

MountingCalibrator::Options readOptions(const std::string& json_text, const std::string& name) {
  const json j = parseObjectText(json_text, name + ": the calibration settings");
  std::set<std::string> keys = {"method", "estimate", "stochastic", "solver", "pulse_noise"};
  for (const auto& m : registeredMethods()) keys.insert(m->name());
  Job job;
  job.path = name;
  const Fields top(name, j, "", keys);
  readMethodSections(name, top, j, &job);
  readStochastic(top, j, &job);
  if (top.has("method")) readMethods(top, &job, false);
  readSettings(top, &job);
  std::string why;
  if (!job.options.IsValid(&why)) throw FileError(name, "", "invalid calibration settings: " + why);
  return job.options;
}

namespace {

/// The job's "sensor" object.
json sensorJson(const Job& job) {
  const Vec3& nom = job.nominal_rotation_deg;
  json sensor = {{"nominal_rotation_deg", {nom.x(), nom.y(), nom.z()}}};
  switch (job.sensor.type) {
    case SensorType::kLine:
      sensor["type"] = "line";
      if (job.sensor.line.range_offset_m != 0) sensor["range_offset_m"] = job.sensor.line.range_offset_m;
      if (job.sensor.line.scan_angle_scale != 1) sensor["scan_angle_scale"] = job.sensor.line.scan_angle_scale;
      if (job.sensor.line.scan_angle_offset_rad != 0) sensor["scan_angle_offset_deg"] = rad2deg(job.sensor.line.scan_angle_offset_rad);
      break;
    case SensorType::kMultiBeam: {
      sensor["type"] = "multibeam";
      const std::optional<MultiBeamModel> named = namedMultiBeamModel(job.sensor_model);
      if (named) {
        sensor["model"] = job.sensor_model;
      } else {
        sensor["model"] = job.sensor_model.empty() ? "custom" : job.sensor_model;
        json lasers = json::array();
        for (const LaserSpec& l : job.sensor.multibeam.lasers()) {
          lasers.push_back({{"elevation_deg", rad2deg(l.elevation_rad)},
                            {"vertical_offset_m", l.vertical_offset_m},
                            {"azimuth_offset_deg", rad2deg(l.azimuth_offset_rad)},
                            {"range_offset_m", l.range_offset_m},
                            {"firing_offset_s", l.firing_offset_s}});
          if (l.horizontal_offset_m != 0) lasers.back()["horizontal_offset_m"] = l.horizontal_offset_m;
        }
        sensor["lasers"] = lasers;
      }
      if (!job.laser_field.empty()) sensor["laser_field"] = job.laser_field;
      if (job.laser_table_tolerance_deg != 5.0) sensor["laser_table_tolerance_deg"] = job.laser_table_tolerance_deg;
      // A named model's own accuracy is implied; another one, or a table's, is written.
      if (job.sensor.multibeam.rangeAccuracy() != (named ? named->rangeAccuracy() : 0.0))
        sensor["range_accuracy_m"] = job.sensor.multibeam.rangeAccuracy();
      break;
    }
    case SensorType::kVector:
      sensor["type"] = "vector";
      break;
  }
  return sensor;
}

/// The calibration settings of a job file (SPEC §4): "method", "estimate", each method's options
/// that differ from its defaults, "stochastic", "pulse_noise", "solver" — into `j` (a method's input
/// already under its key joins its options object as "regions"). `accuracy_file` (the job's smrmsg,
/// as the job names it): written in place of the trajectory's σ.
void writeOptions(const MountingCalibrator::Options& opts, json* out, const std::string& accuracy_file = "") {
  json& j = *out;
  const MountingCalibrator::Options def;
  if (opts.methods.size() == 1) {
    j["method"] = opts.methods[0];
  } else {
    j["method"] = opts.methods;
  }
  j["estimate"] = {{"lever_arm", {opts.estimate[0], opts.estimate[1], opts.estimate[2]}},
                   {"boresight", {opts.estimate[3], opts.estimate[4], opts.estimate[5]}}};
  // Each method's options that differ from its defaults, under the method's name.
  for (const auto& m : registeredMethods()) {
    const std::any defaults = m->defaultOptions();
    const std::any& options = opts.method_options.at(m->name(), defaults);
    json section = json::object();
    for (const OptionSpec& spec : m->options()) {
      const double v = spec.get(options);
      if (v == spec.get(defaults)) continue;
      if (spec.type == OptionSpec::Type::kBoolean)
        section[spec.key] = v != 0;
      else if (spec.type == OptionSpec::Type::kInteger)
        section[spec.key] = static_cast<int>(v);
      else if (spec.type == OptionSpec::Type::kChoice)
        section[spec.key] = spec.choices.at(static_cast<std::size_t>(v));
      else
        section[spec.key] = v;
    }
    if (section.empty()) continue;
    if (j.contains(m->name())) {  // the input shares the key: "planes": {"regions": …, options}
      section[kInputInObject] = j[m->name()];
    }
    j[m->name()] = section;
  }
  if (opts.strip_offset_sigma_m != def.strip_offset_sigma_m) j["stochastic"]["strip_offset_sigma_m"] = opts.strip_offset_sigma_m;
  if (opts.time_offset_sigma_s != def.time_offset_sigma_s) j["stochastic"]["time_offset_sigma_s"] = opts.time_offset_sigma_s;
  if (opts.estimate_time_offset) j["stochastic"]["estimate_time_offset"] = true;
  const TrajectoryCorrections& tc = opts.corrections;
  const TrajectoryCorrections& tcd = def.corrections;
  if (tc.position_degree != tcd.position_degree || tc.attitude_degree != tcd.attitude_degree ||
      tc.position_sigma_m != tcd.position_sigma_m || tc.roll_pitch_sigma_deg != tcd.roll_pitch_sigma_deg ||
      tc.heading_sigma_deg != tcd.heading_sigma_deg || tc.priors_from_accuracy != tcd.priors_from_accuracy) {
    if (tc.priors_from_accuracy)
      j["stochastic"]["corrections"] = {
          {"position_degree", tc.position_degree}, {"attitude_degree", tc.attitude_degree}, {"priors_from_accuracy", true}};
    else
      j["stochastic"]["corrections"] = {{"position_degree", tc.position_degree},
                                        {"attitude_degree", tc.attitude_degree},
                                        {"position_sigma_m", tc.position_sigma_m},
                                        {"roll_pitch_sigma_deg", tc.roll_pitch_sigma_deg},
                                        {"heading_sigma_deg", tc.heading_sigma_deg}};
  }
  const TrajectoryAccuracy& ta = opts.trajectory;
  const TrajectoryAccuracy& td = def.trajectory;
  if (!accuracy_file.empty()) {
    j["stochastic"]["trajectory"] = {{"smrmsg", accuracy_file},
                                     {"position_correlation_s", ta.position_correlation_s},
                                     {"attitude_correlation_s", ta.attitude_correlation_s}};
  } else if (ta.position_sigma_m != td.position_sigma_m || ta.position_correlation_s != td.position_correlation_s ||
             ta.roll_pitch_sigma_deg != td.roll_pitch_sigma_deg || ta.heading_sigma_deg != td.heading_sigma_deg ||
             ta.attitude_correlation_s != td.attitude_correlation_s) {
    j["stochastic"]["trajectory"] = {{"position_sigma_m", ta.position_sigma_m},
                                     {"position_correlation_s", ta.position_correlation_s},
                                     {"roll_pitch_sigma_deg", ta.roll_pitch_sigma_deg},
                                     {"heading_sigma_deg", ta.heading_sigma_deg},
                                     {"attitude_correlation_s", ta.attitude_correlation_s}};
  }
  if (ta.offsets_within_drift) j["stochastic"]["trajectory"]["offsets_within_drift"] = true;
  if (ta.gnss_sigma_m > 0) {
    j["stochastic"]["trajectory"]["gnss_sigma_m"] = ta.gnss_sigma_m;
    j["stochastic"]["trajectory"]["gnss_correlation_s"] = ta.gnss_correlation_s;
  }
  if (opts.pulse_noise.any() || opts.pulse_noise.attitude_correlation_s > 0) {
    const PulseNoise& pn = opts.pulse_noise;
    j["pulse_noise"] = {{"position_m", pn.position_m},   {"roll_pitch_deg", pn.roll_pitch_deg},
                        {"heading_deg", pn.heading_deg}, {"range_m", pn.range_m},
                        {"beam_deg", pn.beam_deg},       {"attitude_correlation_s", pn.attitude_correlation_s}};
  }
  j["solver"] = {{"max_iterations", opts.max_iterations}, {"loss", lossName(opts.loss)}};
  if (opts.loss != LossType::kTrivial) j["solver"]["loss_scale_m"] = opts.loss_scale_m;
  if (opts.resolve_check != def.resolve_check) j["solver"]["resolve_check"] = opts.resolve_check;
  if (opts.resolve_reject_sigma != def.resolve_reject_sigma) j["solver"]["resolve_reject_sigma"] = opts.resolve_reject_sigma;
}

}  // namespace

std::string jobJson(const Job& job) {
  auto rel = [&](const std::string& p) { return detail::relativePath(job.path, p); };
  const MountingCalibrator::Options& opts = job.options;
  json j;
  j["frame"] = job.frame_type == JobFrameType::kLocal ? json{{"type", "local"}} : json{{"type", "crs"}, {"crs", job.crs}};
  if (job.per_point_poses) {
    const io::PoseFields& f = job.pose_fields;
    j["poses"] = {{"from", "extra_bytes"},
                  {"position", {f.position[0], f.position[1], f.position[2]}},
                  {"attitude", {f.attitude[0], f.attitude[1], f.attitude[2]}},
                  {"attitude_unit", f.degrees ? "deg" : "rad"},
                  {"convention", io::toString(f.convention)}};
  } else {
    j["trajectory"] = {{"path", rel(job.trajectory_path)},
                       {"format", job.trajectory_format == TrajectoryFormat::kCsv ? "csv" : "sbet"},
                       {"time_offset_s", job.time_offset_s}};
  }
  j["sensor"] = sensorJson(job);
  const Vec3 b = job.mounting_used.boresightDeg();
  j["mounting_used"] = {{"lever_arm_m", {job.mounting_used.a_b.x(), job.mounting_used.a_b.y(), job.mounting_used.a_b.z()}},
                        {"boresight_deg", {b.x(), b.y(), b.z()}}};
  if (opts.prior_sigma[0] > 0 || opts.prior_sigma[1] > 0 || opts.prior_sigma[2] > 0)
    j["mounting_used"]["lever_arm_sigma_m"] = {opts.prior_sigma[0], opts.prior_sigma[1], opts.prior_sigma[2]};
  json strips = json::array();
  for (const JobStrip& s : job.strips) {
    json e = {{"id", s.id}, {"path", rel(s.path)}};
    if (s.format != "las") e["format"] = s.format;
    if (s.split.active()) {
      e["split"] = {{"field", s.split.field}};
      if (s.split.part > 0) {
        e["split"]["part"] = s.split.part;
        e["split"]["gap"] = s.split.gap;
      } else {
        e["split"]["range"] = {s.split.min, s.split.max};
      }
    }
    strips.push_back(e);
  }
  j["strips"] = strips;
  if (!job.ties_path.empty()) j["ties"] = rel(job.ties_path);
  if (!job.gcps_path.empty()) j["gcps"] = rel(job.gcps_path);
  if (!job.check_points_path.empty()) j["check_points"] = rel(job.check_points_path);
  if (!job.check_planes_path.empty()) j["check_planes"] = rel(job.check_planes_path);
  if (!job.targets_path.empty()) j["targets"] = rel(job.targets_path);
  if (job.planes_auto)
    j["planes"] = "auto";
  else if (!job.planes_path.empty())
    j["planes"] = rel(job.planes_path);
  writeOptions(opts, &j, job.trajectory_accuracy_path.empty() ? "" : rel(job.trajectory_accuracy_path));
  json out = json::object();
  if (!job.result_path.empty()) out["result"] = rel(job.result_path);
  if (!job.report_path.empty()) out["report"] = rel(job.report_path);
  if (!out.empty()) j["output"] = out;
  return j.dump(2) + "\n";
}

std::vector<std::string> jobInputPaths(const Job& job) {
  std::vector<std::string> in = {job.path};
  for (const std::string* p : {&job.trajectory_path, &job.ties_path, &job.gcps_path, &job.check_points_path, &job.check_planes_path,
                               &job.planes_path, &job.targets_path, &job.trajectory_accuracy_path})
    if (!p->empty()) in.push_back(*p);
  for (const JobStrip& s : job.strips) in.push_back(s.path);
  return in;
}

void checkJobOutputs(const Job& job, const std::vector<std::string>& also_inputs) {
  namespace fs = std::filesystem;
  std::vector<std::string> inputs = jobInputPaths(job);
  inputs.insert(inputs.end(), also_inputs.begin(), also_inputs.end());
  const std::vector<std::pair<std::string, std::string>> outputs = {{"output.result", job.result_path}, {"output.report", job.report_path}};
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    const auto& [field, out] = outputs[i];
    if (out.empty()) continue;
    const std::string where = "field '" + field + "'";
    for (const std::string& in : inputs)
      if (io::samePath(out, in))
        throw FileError(job.path, where, out + " is also an input of the job (" + in + "); choose another output file");
    for (std::size_t k = 0; k < i; ++k)
      if (!outputs[k].second.empty() && io::samePath(out, outputs[k].second))
        throw FileError(job.path, where, out + " is also " + outputs[k].first);
    std::error_code ec;
    if (fs::is_directory(out, ec)) throw FileError(job.path, where, out + " is a folder");
    const fs::path folder = fs::path(out).parent_path();
    if (!folder.empty() && !fs::is_directory(folder, ec))
      throw FileError(job.path, where, "the folder " + folder.string() + " does not exist");
  }
}

std::string optionsJson(const MountingCalibrator::Options& options) {
  json j = json::object();
  writeOptions(options, &j);
  return j.dump(2) + "\n";
}

}  // namespace mountcal
