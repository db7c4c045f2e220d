#include "mountcal/job.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "mountcal/error.hpp"
#include "mountcal/georeference_model.hpp"
#include "mountcal/io/csv.hpp"
#include "mountcal/io/las.hpp"
#include "mountcal/io/sbet.hpp"

namespace mountcal {

namespace {

using nlohmann::json;
namespace fs = std::filesystem;

/// Strict access to one JSON object of the job, with field paths in every message.
class Fields {
 public:
  Fields(const std::string& file, const json& j, std::string prefix, std::set<std::string> known)
      : file_(file), j_(j), prefix_(std::move(prefix)) {
    if (!j_.is_object()) fail("", "expected a JSON object");
    for (auto it = j_.begin(); it != j_.end(); ++it) {
      if (!known.count(it.key())) {
        std::string list;
        for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
        fail(it.key(), "unknown field (known here: " + list + ")");
      }
    }
  }
  [[noreturn]] void fail(const std::string& key, const std::string& msg) const {
    throw FileError(file_, "field '" + prefix_ + (prefix_.empty() || key.empty() ? "" : ".") + key + "'", msg);
  }
  bool has(const std::string& k) const { return j_.contains(k) && !j_[k].is_null(); }
  const json& at(const std::string& k) const {
    if (!has(k)) fail(k, "missing");
    return j_[k];
  }
  std::string str(const std::string& k) const {
    if (!at(k).is_string()) fail(k, "expected a string");
    return j_[k].get<std::string>();
  }
  std::string str(const std::string& k, const std::string& def) const { return has(k) ? str(k) : def; }
  double num(const std::string& k) const {
    if (!at(k).is_number()) fail(k, "expected a number");
    const double v = j_[k].get<double>();
    if (!std::isfinite(v)) fail(k, "not finite");
    return v;
  }
  double num(const std::string& k, double def) const { return has(k) ? num(k) : def; }
  Vec3 vec3(const std::string& k) const {
    const json& a = at(k);
    if (!a.is_array() || a.size() != 3) fail(k, "expected an array of 3 numbers");
    Vec3 v;
    for (int i = 0; i < 3; ++i) {
      if (!a[i].is_number()) fail(k, "expected an array of 3 numbers");
      v[i] = a[i].get<double>();
    }
    return v;
  }
  std::array<bool, 3> bool3(const std::string& k) const {
    const json& a = at(k);
    if (!a.is_array() || a.size() != 3) fail(k, "expected an array of 3 booleans");
    std::array<bool, 3> v{};
    for (int i = 0; i < 3; ++i) {
      if (!a[i].is_boolean()) fail(k, "expected an array of 3 booleans");
      v[i] = a[i].get<bool>();
    }
    return v;
  }
  Fields sub(const std::string& k, std::set<std::string> known) const {
    return Fields(file_, at(k), prefix_ + (prefix_.empty() ? "" : ".") + k, std::move(known));
  }

 private:
  const std::string& file_;
  const json& j_;
  std::string prefix_;
};

std::string resolve(const std::string& job_path, const std::string& p) {
  if (p.empty()) return p;
  const fs::path path(p);
  if (path.is_absolute()) return p;
  return (fs::path(job_path).parent_path() / path).lexically_normal().string();
}

}  // namespace

Job readJob(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw FileError(path, "", "cannot open the job file");
  json j;
  try {
    j = json::parse(in);
  } catch (const json::parse_error& e) {
    throw FileError(path, "byte " + std::to_string(e.byte), std::string("invalid JSON: ") + e.what());
  }
  Job job;
  job.path = path;
  const Fields top(path, j, "",
                   {"frame", "trajectory", "sensor", "mounting_used", "strips", "ties", "method", "estimate", "vtpm",
                    "solver", "output", "gcps", "check_points", "check_planes", "planes", "targets", "features"});
  const Fields frame = top.sub("frame", {"type", "crs"});
  job.frame_type = frame.str("type");
  if (job.frame_type != "local" && job.frame_type != "crs") frame.fail("type", "expected \"local\" or \"crs\"");
  if (job.frame_type == "crs") job.crs = frame.str("crs");

  const Fields traj = top.sub("trajectory", {"path", "format", "time_offset_s"});
  job.trajectory_path = resolve(path, traj.str("path"));
  job.trajectory_format = traj.str("format", "csv");
  if (job.trajectory_format != "csv" && job.trajectory_format != "sbet") traj.fail("format", "expected \"csv\" or \"sbet\"");
  job.time_offset_s = traj.num("time_offset_s", 0.0);

  const Fields sensor = top.sub("sensor", {"type", "nominal_rotation_deg", "model", "lasers", "range_offset_m",
                                           "scan_angle_scale", "scan_angle_offset_deg"});
  const std::string type = sensor.str("type");
  const Vec3 nominal = sensor.has("nominal_rotation_deg") ? sensor.vec3("nominal_rotation_deg") : Vec3::Zero();
  if (type == "line") {
    LineScannerModel m;
    m.range_offset_m = sensor.num("range_offset_m", 0.0);
    m.scan_angle_scale = sensor.num("scan_angle_scale", 1.0);
    m.scan_angle_offset_rad = deg2rad(sensor.num("scan_angle_offset_deg", 0.0));
    job.sensor = SensorModel::lineScanner(m);
  } else if (type == "multibeam") {
    if (sensor.has("lasers")) {
      const json& lasers = sensor.at("lasers");
      if (!lasers.is_array() || lasers.empty()) sensor.fail("lasers", "expected a non-empty array of lasers");
      std::vector<LaserSpec> specs;
      for (std::size_t i = 0; i < lasers.size(); ++i) {
        const Fields l(path, lasers[i], "sensor.lasers[" + std::to_string(i) + "]",
                       {"elevation_deg", "vertical_offset_m", "azimuth_offset_deg", "range_offset_m", "firing_offset_s"});
        LaserSpec s;
        s.elevation_rad = deg2rad(l.num("elevation_deg"));
        s.vertical_offset_m = l.num("vertical_offset_m", 0.0);
        s.azimuth_offset_rad = deg2rad(l.num("azimuth_offset_deg", 0.0));
        s.range_offset_m = l.num("range_offset_m", 0.0);
        s.firing_offset_s = l.num("firing_offset_s", 0.0);
        specs.push_back(s);
      }
      job.sensor = SensorModel::multiBeam(MultiBeamModel(sensor.str("model", "custom"), specs, 0.0));
    } else {
      const std::string model = sensor.str("model");
      if (model == "VLP-16") job.sensor = SensorModel::multiBeam(MultiBeamModel::VLP16());
      else if (model == "HDL-32E") job.sensor = SensorModel::multiBeam(MultiBeamModel::HDL32E());
      else sensor.fail("model", "unknown multi-beam model '" + model + "' (VLP-16, HDL-32E, or give a \"lasers\" table)");
    }
  } else if (type == "vector") {
    job.sensor = SensorModel::vectorSensor();
  } else {
    sensor.fail("type", "expected \"line\", \"multibeam\" or \"vector\"");
  }

  const Fields used = top.sub("mounting_used", {"lever_arm_m", "boresight_deg"});
  job.mounting_used = MountingParameters::fromDegrees(used.vec3("lever_arm_m"), used.vec3("boresight_deg"), nominal);

  const json& strips = top.at("strips");
  if (!strips.is_array() || strips.empty()) top.fail("strips", "expected a non-empty array of {\"id\", \"path\"}");
  std::set<std::string> ids;
  for (std::size_t i = 0; i < strips.size(); ++i) {
    const Fields s(path, strips[i], "strips[" + std::to_string(i) + "]", {"id", "path", "format"});
    JobStrip js;
    js.id = s.str("id");
    js.path = resolve(path, s.str("path"));
    js.format = s.str("format", "las");
    if (js.format != "las" && js.format != "raw_csv") s.fail("format", "expected \"las\" or \"raw_csv\"");
    if (!ids.insert(js.id).second) s.fail("id", "strip id '" + js.id + "' appears twice");
    job.strips.push_back(js);
  }
  job.ties_path = resolve(path, top.str("ties"));
  job.gcps_path = resolve(path, top.str("gcps", ""));
  job.check_points_path = resolve(path, top.str("check_points", ""));
  job.check_planes_path = resolve(path, top.str("check_planes", ""));
  job.method = top.str("method", "vtpm");
  if (job.method != "vtpm" && job.method != "planes" && job.method != "features") {
    top.fail("method", "expected \"vtpm\", \"planes\" or \"features\"");
  }
  MountingCalibrator::Options& o = job.options;
  if (top.has("estimate")) {
    const Fields e = top.sub("estimate", {"lever_arm", "boresight"});
    if (e.has("lever_arm")) {
      const auto a = e.bool3("lever_arm");
      for (int i = 0; i < 3; ++i) o.estimate[i] = a[i];
    }
    if (e.has("boresight")) {
      const auto b = e.bool3("boresight");
      for (int i = 0; i < 3; ++i) o.estimate[3 + i] = b[i];
    }
  }
  if (top.has("vtpm")) {
    const Fields v = top.sub("vtpm", {"radius_m", "max_radius_m", "ransac_threshold_m", "tie_sigma_xy_m", "tie_sigma_z_m",
                                      "strip_offset_sigma_m"});
    o.vtp.radius_m = v.num("radius_m", o.vtp.radius_m);
    o.vtp.max_radius_m = v.num("max_radius_m", std::max(o.vtp.max_radius_m, o.vtp.radius_m));
    o.vtp.ransac_threshold_m = v.num("ransac_threshold_m", o.vtp.ransac_threshold_m);
    o.tie_sigma_xy_m = v.num("tie_sigma_xy_m", o.tie_sigma_xy_m);
    o.tie_sigma_z_m = v.num("tie_sigma_z_m", o.tie_sigma_z_m);
    o.strip_offset_sigma_m = v.num("strip_offset_sigma_m", o.strip_offset_sigma_m);
  }
  if (top.has("solver")) {
    const Fields s = top.sub("solver", {"max_iterations", "loss", "loss_scale_m", "function_tolerance", "parameter_tolerance",
                                        "scale_covariance_by_variance_factor"});
    o.max_iterations = static_cast<int>(s.num("max_iterations", o.max_iterations));
    const std::string loss = s.str("loss", "trivial");
    if (loss == "trivial") o.loss = LossType::kTrivial;
    else if (loss == "huber") o.loss = LossType::kHuber;
    else if (loss == "cauchy") o.loss = LossType::kCauchy;
    else s.fail("loss", "expected \"trivial\", \"huber\" or \"cauchy\"");
    o.loss_scale_m = s.num("loss_scale_m", o.loss_scale_m);
    o.function_tolerance = s.num("function_tolerance", o.function_tolerance);
    o.parameter_tolerance = s.num("parameter_tolerance", o.parameter_tolerance);
    if (s.has("scale_covariance_by_variance_factor")) {
      if (!s.at("scale_covariance_by_variance_factor").is_boolean()) s.fail("scale_covariance_by_variance_factor", "expected a boolean");
      o.scale_covariance_by_variance_factor = s.at("scale_covariance_by_variance_factor").get<bool>();
    }
  }
  std::string why;
  if (!o.IsValid(&why)) throw FileError(path, "", "invalid calibration settings: " + why);
  if (top.has("output")) {
    const Fields out = top.sub("output", {"result", "report"});
    job.result_path = resolve(path, out.str("result", ""));
    job.report_path = resolve(path, out.str("report", ""));
  }
  return job;
}

JobFrame::JobFrame(const std::string& crs, const Geodetic& origin)
    : crs_(std::make_shared<io::CrsTransform>(crs)), tangent_(std::make_shared<LocalTangentFrame>(origin)) {}

Vec3 JobFrame::toLocal(const Vec3& x) const { return crs_ ? tangent_->toLocal(crs_->toGeodetic(x)) : x; }
Vec3 JobFrame::fromLocal(const Vec3& x) const { return crs_ ? crs_->fromGeodetic(tangent_->toGeodetic(x)) : x; }

namespace {

/// GPS week seconds lie in [0, 604800]; adjusted standard GPS time (GPS seconds − 1e9) of
/// any date since 2011 is far larger.
bool looksLikeWeekSeconds(double t) { return t >= -1.0 && t <= 604801.0; }

StripData loadLasStrip(const JobStrip& js, const GeoreferenceModel& model, const JobFrame& frame,
                       std::vector<Vec3>* x_crs) {
  io::LasReader reader(js.path);
  const io::LasHeader& h = reader.header();
  if (!h.hasGpsTime()) {
    throw FileError(js.path, "byte 104", "point format " + std::to_string(h.point_format) +
                                             " has no GPS time; a calibration needs formats 1, 3 or 6-8");
  }
  StripData s;
  s.id = js.id;
  s.time_s.reserve(static_cast<std::size_t>(h.point_count));
  s.x_m.reserve(static_cast<std::size_t>(h.point_count));
  std::vector<io::LasPoint> chunk;
  const Trajectory& T = model.trajectory();
  const bool traj_week = looksLikeWeekSeconds(T.startTime());
  std::uint64_t record = 0;
  while (reader.read(&chunk) > 0) {
    for (const io::LasPoint& p : chunk) {
      const double t = p.gps_time;
      if (!std::isfinite(t)) throw FileError(js.path, "record " + std::to_string(record), "GPS time is not finite");
      if (record == 0 && h.adjustedStandardGpsTime() == traj_week) {
        throw FileError(js.path, "byte 6",
                        std::string("time encoding mismatch: the LAS global encoding says ") +
                            (h.adjustedStandardGpsTime() ? "adjusted standard GPS time" : "GPS week seconds") +
                            " but the trajectory times look like " + (traj_week ? "GPS week seconds" : "adjusted standard GPS time"));
      }
      if (t < T.startTime() || t > T.endTime()) {
        char buf[160];
        std::snprintf(buf, sizeof buf, "GPS time %.6f s is outside the trajectory [%.3f, %.3f] s", t, T.startTime(), T.endTime());
        throw FileError(js.path, "record " + std::to_string(record), buf);
      }
      s.time_s.push_back(t);
      const Vec3 x(reader.x(p), reader.y(p), reader.z(p));
      if (x_crs) x_crs->push_back(x);
      s.x_m.push_back(frame.toLocal(x));
      ++record;
    }
  }
  // Inverse georeferencing (SPEC §2): the raw vectors that, with mounting_used, gave x_m.
  const std::size_t n = s.time_s.size();
  std::vector<double> x(3 * n), r(3 * n);
  for (std::size_t i = 0; i < n; ++i) Eigen::Map<Vec3>{&x[3 * i]} = s.x_m[i];
  model.inverse(s.time_s.data(), x.data(), r.data(), n);
  s.r_s.resize(n);
  for (std::size_t i = 0; i < n; ++i) s.r_s[i] = Eigen::Map<const Vec3>(&r[3 * i]);
  return s;
}

StripData loadRawStrip(const JobStrip& js, const SensorModel& sensor, const GeoreferenceModel& model) {
  const std::vector<RawPulse> pulses = io::readRawCsv(js.path, sensor.type);
  StripData s;
  s.id = js.id;
  s.time_s.reserve(pulses.size());
  s.r_s.reserve(pulses.size());
  const Trajectory& T = model.trajectory();
  for (std::size_t i = 0; i < pulses.size(); ++i) {
    const RawPulse& p = pulses[i];
    if (p.time_s < T.startTime() || p.time_s > T.endTime()) {
      throw FileError(js.path, "line " + std::to_string(i + 2), "time " + std::to_string(p.time_s) + " s is outside the trajectory");
    }
    try {
      s.r_s.push_back(sensor.vector(p));
    } catch (const InvalidInput& e) {
      throw FileError(js.path, "line " + std::to_string(i + 2), e.what());
    }
    s.time_s.push_back(p.time_s);
  }
  s.x_m.resize(s.r_s.size());
  std::size_t cursor = 0;
  for (std::size_t i = 0; i < s.r_s.size(); ++i) {
    s.x_m[i] = georeference(T.pose(s.time_s[i], &cursor), model.mounting().R_bs(), model.mounting().a_b, s.r_s[i]);
  }
  return s;
}

/// Height of the strip point nearest to (x, y) in the strips' own coordinates.
double nearestHeight(const std::vector<std::vector<Vec3>>& strips_crs, double x, double y) {
  double best = std::numeric_limits<double>::infinity(), z = 0.0;
  for (const auto& pts : strips_crs) {
    for (const Vec3& p : pts) {
      const double d = (p.x() - x) * (p.x() - x) + (p.y() - y) * (p.y() - y);
      if (d < best) {
        best = d;
        z = p.z();
      }
    }
  }
  return z;
}

/// Picks are plan positions in the strips' CRS; in the tangent frame a plan position moves with
/// height, so each is lifted with the height of the nearest strip point before conversion.
std::vector<TieObservation> liftTies(std::vector<TieObservation> ties, const LoadedJob& loaded) {
  if (loaded.frame.isLocal()) return ties;
  for (TieObservation& t : ties) {
    const Vec3 x = loaded.frame.toLocal(Vec3(t.x_m, t.y_m, nearestHeight(loaded.crs_strips, t.x_m, t.y_m)));
    t.x_m = x.x();
    t.y_m = x.y();
  }
  return ties;
}

}  // namespace

LoadedJob loadJobTrajectory(const Job& job) {
  LoadedJob out;
  CalibrationData& d = out.data;
  if (job.frame_type == "local") {
    if (job.trajectory_format != "csv") {
      throw FileError(job.path, "field 'trajectory.format'", "a local-frame job needs the local trajectory CSV of SPEC §4; an SBET needs \"frame\": {\"type\": \"crs\"}");
    }
    d.trajectory = std::make_shared<const Trajectory>(io::readTrajectoryCsv(job.trajectory_path, job.time_offset_s));
  } else {
    const std::vector<io::SbetRecord> records = job.trajectory_format == "sbet" ? io::readSbet(job.trajectory_path)
                                                                                 : io::readGeodeticTrajectoryCsv(job.trajectory_path);
    if (records.empty()) throw FileError(job.trajectory_path, "", "no trajectory records");
    try {
      out.frame = JobFrame(job.crs, Geodetic{records.front().lat_rad, records.front().lon_rad, 0.0});
    } catch (const InvalidInput& e) {
      throw FileError(job.path, "field 'frame.crs'", e.what());
    }
    d.trajectory = std::make_shared<const Trajectory>(
        io::sbetToTrajectory(job.trajectory_path, records, *out.frame.tangentFrame(), job.time_offset_s));
  }
  d.mounting_used = job.mounting_used;
  return out;
}

LoadedJob loadJob(const Job& job) {
  if (job.method != "vtpm") {
    throw FileError(job.path, "field 'method'", "method '" + job.method + "' is not implemented yet; use \"vtpm\"");
  }
  LoadedJob out = loadJobTrajectory(job);
  CalibrationData& d = out.data;
  const GeoreferenceModel model(d.trajectory, job.mounting_used);
  for (const JobStrip& js : job.strips) {
    if (js.format == "las") {
      out.crs_strips.emplace_back();
      d.strips.push_back(loadLasStrip(js, model, out.frame, out.frame.isLocal() ? nullptr : &out.crs_strips.back()));
    } else {
      if (!out.frame.isLocal()) throw FileError(js.path, "", "raw CSV strips are supported in local-frame jobs only");
      d.strips.push_back(loadRawStrip(js, job.sensor, model));
    }
  }
  std::vector<TieObservation> ties = io::readTiesCsv(job.ties_path);
  std::set<std::string> ids;
  for (const JobStrip& js : job.strips) ids.insert(js.id);
  for (const TieObservation& t : ties) {
    if (!ids.count(t.strip_id)) {
      throw FileError(job.ties_path, "line " + std::to_string(t.line), "tie '" + t.tie_id + "' names strip '" + t.strip_id + "', which the job does not list");
    }
  }
  d.ties = liftTies(std::move(ties), out);
  if (!job.gcps_path.empty()) {
    d.gcps = io::readGcpCsv(job.gcps_path);
    for (GroundControlPoint& g : d.gcps) {
      const Vec3 x = out.frame.toLocal(Vec3(g.x_m, g.y_m, g.z_m));
      g.x_m = x.x();
      g.y_m = x.y();
      g.z_m = x.z();
    }
  }
  return out;
}

CalibrationData loadJobData(const Job& job) { return loadJob(job).data; }

ApplyStats applyMounting(const Job& job, const MountingParameters& mounting, const std::string& out_dir,
                         std::size_t chunk_points) {
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec) throw FileError(out_dir, "", "cannot create the output folder: " + ec.message());
  const LoadedJob loaded = loadJobTrajectory(job);
  const Trajectory& T = *loaded.data.trajectory;
  const Mat3 R_bs0 = job.mounting_used.R_bs(), R_bs1 = mounting.R_bs();
  ApplyStats stats;
  for (const JobStrip& js : job.strips) {
    if (js.format != "las") throw FileError(js.path, "", "apply rewrites LAS strips; this strip is a raw CSV");
    const std::string out_path = (fs::path(out_dir) / fs::path(js.path).filename()).string();
    if (fs::exists(out_path) && fs::equivalent(out_path, js.path)) {
      throw FileError(out_path, "", "apply would overwrite its own input; choose another --out folder");
    }
    io::LasReader reader(js.path);
    const io::LasHeader& h = reader.header();
    if (!h.hasGpsTime()) throw FileError(js.path, "byte 104", "point format " + std::to_string(h.point_format) + " has no GPS time");
    io::LasWriter writer(out_path, h);
    std::vector<io::LasPoint> chunk;
    std::size_t cursor = 0;
    std::uint64_t record = 0;
    while (reader.read(&chunk, chunk_points) > 0) {
      for (io::LasPoint& p : chunk) {
        if (!(p.gps_time >= T.startTime() && p.gps_time <= T.endTime())) {
          throw FileError(js.path, "record " + std::to_string(record), "GPS time " + std::to_string(p.gps_time) + " s is outside the trajectory");
        }
        const Pose pose = T.pose(p.gps_time, &cursor);
        const Vec3 x_crs(reader.x(p), reader.y(p), reader.z(p));
        const Vec3 r_s = inverseGeoreference(pose, R_bs0, job.mounting_used.a_b, loaded.frame.toLocal(x_crs));
        const Vec3 x_new = loaded.frame.fromLocal(georeference(pose, R_bs1, mounting.a_b, r_s));
        stats.max_shift_m = std::max(stats.max_shift_m, (x_new - x_crs).norm());
        p.X = writer.quantize(0, x_new.x());
        p.Y = writer.quantize(1, x_new.y());
        p.Z = writer.quantize(2, x_new.z());
        writer.write(p);
        ++record;
      }
    }
    writer.close();
    stats.points += record;
    ++stats.strips;
  }
  return stats;
}

std::vector<TieObservation> loadCheckPoints(const Job& job, const LoadedJob& loaded) {
  if (job.check_points_path.empty()) return {};
  return liftTies(io::readTiesCsv(job.check_points_path), loaded);
}

std::vector<PlaneRegion> loadCheckPlanes(const Job& job, const LoadedJob& loaded) {
  if (job.check_planes_path.empty()) return {};
  std::vector<PlaneRegion> regions = io::readPlanesCsv(job.check_planes_path);
  if (loaded.frame.isLocal()) return regions;
  for (PlaneRegion& r : regions) {
    // The region's bounding box in the computation frame (meridian convergence turns it slightly).
    const double z = nearestHeight(loaded.crs_strips, 0.5 * (r.xmin + r.xmax), 0.5 * (r.ymin + r.ymax));
    double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
    for (double x : {r.xmin, r.xmax}) {
      for (double y : {r.ymin, r.ymax}) {
        const Vec3 l = loaded.frame.toLocal(Vec3(x, y, z));
        x0 = std::min(x0, l.x());
        y0 = std::min(y0, l.y());
        x1 = std::max(x1, l.x());
        y1 = std::max(y1, l.y());
      }
    }
    r = {r.id, x0, y0, x1, y1};
  }
  return regions;
}

ResultEvaluation evaluateJob(const Job& job, const LoadedJob& loaded, const MountingParameters& mounting) {
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
                 {"initial_cost", S.initial_cost}, {"final_cost", S.final_cost}, {"time_s", S.time_s}};
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
    j["evaluation"] = e;
  }
  return j.dump(2) + "\n";
}

MountingParameters readResultMounting(const std::string& path, const Mat3& R_nom) {
  std::ifstream in(path);
  if (!in) throw FileError(path, "", "cannot open the result file");
  json j;
  try {
    j = json::parse(in);
  } catch (const json::parse_error& e) {
    throw FileError(path, "byte " + std::to_string(e.byte), "invalid JSON");
  }
  if (!j.is_object() || !j.contains("mounting")) throw FileError(path, "field 'mounting'", "missing");
  const Fields m(path, j["mounting"], "mounting", {"lever_arm_m", "boresight_deg"});
  MountingParameters out = MountingParameters::fromDegrees(m.vec3("lever_arm_m"), m.vec3("boresight_deg"));
  out.R_nom = R_nom;
  return out;
}

}  // namespace mountcal
