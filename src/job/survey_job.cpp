// Writing a simulated survey as a job in the folder layout of SPEC §4 (the job layer: the
// simulator itself knows neither jobs nor methods).
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <nlohmann/json.hpp>

#include "io/json_fields.hpp"
#include "mountcal/core/error.hpp"
#include "mountcal/io/atomic_file.hpp"
#include "mountcal/io/crs.hpp"
#include "mountcal/io/csv.hpp"
#include "mountcal/io/sbet.hpp"
#include "mountcal/job/load.hpp"
#include "mountcal/job/schema.hpp"
#include "mountcal/job/survey_job.hpp"
#include "mountcal/io/las.hpp"
#include "mountcal/io/las_crs.hpp"
#include "mountcal/simulation/survey.hpp"

namespace mountcal {

using namespace simulation;

namespace {

nlohmann::json mountingJson(const MountingParameters& m) {
  const Vec3 b = m.boresightDeg();
  return {{"lever_arm_m", {m.a_b.x(), m.a_b.y(), m.a_b.z()}}, {"boresight_deg", {b.x(), b.y(), b.z()}}};
}

/// Nominal rotation of a mounting as (roll, pitch, heading) [deg] composed Rz·Ry·Rx.
std::array<double, 3> nominalDeg(const MountingParameters& m) {
  // R_nom = Rz(h) Ry(p) Rx(r): same extraction as rollPitchHeading.
  const Vec3 rph = rollPitchHeading(m.R_nom);
  return {rad2deg(rph.x()), rad2deg(rph.y()), rad2deg(rph.z())};
}

void writeStripLas(const std::string& path, const SimulatedSurvey& survey, const SimulatedStrip& strip, int source_id,
                   const JobFrame& frame, const std::string& crs) {
  io::LasHeader h;
  h.version_minor = 4;
  h.point_format = 6;
  h.point_record_length = 30;
  h.global_encoding = 0;  // GPS week seconds
  if (!crs.empty()) {     // the CRS as OGC WKT (LAS 1.4 R15 §2.5.1: bit 4 of the global encoding set)
    h.vlrs.push_back(io::wktVlr(crs));
    h.global_encoding |= 16u;
  }
  h.file_source_id = static_cast<std::uint16_t>(source_id);
  h.generating_software = "mountcal simulate";
  h.system_identifier = survey.config.name;
  std::vector<Vec3> out_points;
  out_points.reserve(strip.points_m.size());
  for (const Vec3& p : strip.points_m) out_points.push_back(frame.fromLocal(p));
  Vec3 lo = Vec3::Constant(1e300);
  for (const Vec3& p : out_points) lo = lo.cwiseMin(p);
  if (out_points.empty()) lo.setZero();
  for (int a = 0; a < 3; ++a) h.offset[a] = std::floor(lo[a] / 1000.0) * 1000.0;
  io::LasWriter w(path, h);
  io::LasPoint p;
  for (std::size_t k = 0; k < strip.points_m.size(); ++k) {
    const RawPulse& r = strip.pulses[k];
    p.X = w.quantize(0, out_points[k].x());
    p.Y = w.quantize(1, out_points[k].y());
    p.Z = w.quantize(2, out_points[k].z());
    p.intensity = static_cast<std::uint16_t>(std::lround(std::max(0.0f, r.intensity)));
    p.gps_time = r.time_s;
    p.point_source_id = static_cast<std::uint16_t>(source_id);
    p.classification = strip.kinds[k] == SurfaceKind::kVegetation                                     ? 5
                       : strip.kinds[k] == SurfaceKind::kRoof || strip.kinds[k] == SurfaceKind::kWall ? 6
                                                                                                      : 2;
    if (survey.config.sensor == SensorType::kLine) {
      io::setScanAngleDeg(w.header(), rad2deg(r.angle_rad), &p);
      p.user_data = 0;
    } else {
      p.scan_angle = 0;
      p.user_data = static_cast<std::uint8_t>(r.laser_id);
      p.scanner_channel = 0;
    }
    w.write(p);
  }
  w.close();
}

}  // namespace

namespace {

/// trajectory.sbet: position through WGS84; attitude relative to the true NED frame at each
/// sample: R_n(t)b = R_mn(t)ᵀ · R_mb, where R_mb is the simulated body attitude in the ENU frame.
void writeSimulatedSbet(const SimulatedSurvey& survey, const LocalTangentFrame& tangent, const std::string& dir) {
  std::vector<io::SbetRecord> records;
  for (const TrajectorySample& s : survey.measured_trajectory->samples()) {
    io::SbetRecord r{};
    const Geodetic g = tangent.toGeodetic(s.p_m);
    const Mat3 R_mb = s.R_mn * R_nb(s.roll, s.pitch, s.heading);
    const Vec3 rph = rollPitchHeading(tangent.R_mn(g.lat, g.lon).transpose() * R_mb);
    r.time_s = s.time_s;
    r.lat_rad = g.lat;
    r.lon_rad = g.lon;
    r.h_m = g.h;
    r.roll_rad = rph.x();
    r.pitch_rad = rph.y();
    r.platform_heading_rad = rph.z();
    r.wander_rad = 0.0;
    records.push_back(r);
  }
  io::writeSbet(dir + "/trajectory.sbet", records);
}

/// The user's inputs of the survey in the output frame: ties, check points, check planes,
/// plane regions, target regions and GCPs.
void writeSimulatedInputs(const SimulatedSurvey& survey, const JobFrame& frame, const std::string& dir, const SurveyWriteOptions& options) {
  auto toObs = [&](const std::vector<TiePick>& picks) {
    std::vector<io::TieObservation> out;
    for (const TiePick& p : picks) {
      const Vec3 x = frame.fromLocal(Vec3(p.x_m, p.y_m, p.apparent_m.z()));
      out.push_back({p.tie_id, p.strip_id, x.x(), x.y(), 0});
    }
    return out;
  };
  if (options.ties) io::writeTiesCsv(dir + "/ties.csv", toObs(survey.ties));
  io::writeTiesCsv(dir + "/check_points.csv", toObs(survey.check_points));
  auto toRegions = [&](const std::vector<PlanePatch>& patches, double inset_m) {
    std::vector<io::PlaneRegion> planes;
    for (const PlanePatch& p : patches) {
      // Corners inset so that the box stays inside the patch after the CRS's rotation.
      const Vec3 a = frame.fromLocal(Vec3(p.xmin + inset_m, p.ymin + inset_m, 0)),
                 b = frame.fromLocal(Vec3(p.xmax - inset_m, p.ymax - inset_m, 0));
      planes.push_back(!frame.isLocal() ? io::PlaneRegion{p.id, std::min(a.x(), b.x()), std::min(a.y(), b.y()), std::max(a.x(), b.x()),
                                                          std::max(a.y(), b.y())}
                                        : io::PlaneRegion{p.id, p.xmin, p.ymin, p.xmax, p.ymax});
    }
    return planes;
  };
  io::writePlanesCsv(dir + "/check_planes.csv", toRegions(survey.check_planes, 1.0));
  io::writePlanesCsv(dir + "/planes.csv", toRegions(survey.plane_regions, 0.2));
  if (!survey.target_regions.empty()) io::writePlanesCsv(dir + "/targets.csv", toRegions(survey.target_regions, 0.0));
  std::vector<io::GroundControlPoint> gcps;
  for (const FeaturePoint& f : survey.gcps) {
    const Vec3 x = frame.fromLocal(f.x_m);
    gcps.push_back({f.id, x.x(), x.y(), x.z(), 0.02, 0.02});
  }
  io::writeGcpCsv(dir + "/gcps.csv", gcps);
}

/// truth.json: the true mounting, the mounting used and the noise of the simulation.
void writeSimulatedTruth(const SimulatedSurvey& survey, const std::string& dir) {
  const SurveyConfig& c = survey.config;
  const auto nom = nominalDeg(c.nominal_mounting);
  const NoiseModel& n = c.noise;
  nlohmann::json truth = {
      {"preset", c.name},
      {"seed", c.seed},
      {"mounting", mountingJson(c.true_mounting)},
      {"mounting_used", mountingJson(c.nominal_mounting)},
      {"nominal_rotation_deg", nom},
      {"noise",
       {{"range_sigma_m", n.range_sigma_m},
        {"scan_angle_sigma_deg", rad2deg(n.scan_angle_sigma_rad)},
        {"gnss_sigma_m", n.gnss_sigma_m},
        {"gnss_correlation_s", n.gnss_correlation_s},
        {"attitude_sigma_deg", rad2deg(n.attitude_sigma_rad)},
        {"heading_sigma_deg", 2 * rad2deg(n.attitude_sigma_rad)},
        {"attitude_correlation_s", n.attitude_correlation_s},
        {"pick_sigma_m", n.pick_sigma_m}}},
      {"strips", survey.strips.size()},
      {"ties", survey.ties.size()},
      {"check_points", survey.check_points.size()},
  };
  if (!c.multibeam.laser_errors.empty()) {  // by laser id: how the real sensor differs from its table
    nlohmann::json e = {{"elevation_deg", nlohmann::json::array()},
                        {"azimuth_deg", nlohmann::json::array()},
                        {"vertical_offset_m", nlohmann::json::array()},
                        {"range_offset_m", nlohmann::json::array()},
                        {"horizontal_offset_m", nlohmann::json::array()}};
    for (const LaserSpec& l : c.multibeam.laser_errors) {
      e["elevation_deg"].push_back(rad2deg(l.elevation_rad));
      e["azimuth_deg"].push_back(rad2deg(l.azimuth_offset_rad));
      e["vertical_offset_m"].push_back(l.vertical_offset_m);
      e["range_offset_m"].push_back(l.range_offset_m);
      e["horizontal_offset_m"].push_back(l.horizontal_offset_m);
    }
    truth["laser_errors"] = e;
  }
  io::writeFileAtomically(dir + "/truth.json", truth.dump(2) + "\n");
}

/// job.json (and job_features.json when the survey has targets), through the job schema.
void writeSimulatedJobs(const SimulatedSurvey& survey, Job job, const SurveyWriteOptions& options) {
  const SurveyConfig& c = survey.config;
  const std::string dir = std::filesystem::path(job.path).parent_path().string();
  auto at = [&](const std::string& name) { return (std::filesystem::path(dir) / name).lexically_normal().string(); };
  const auto nom = nominalDeg(c.nominal_mounting);
  job.nominal_rotation_deg = Vec3(nom[0], nom[1], nom[2]);
  if (c.sensor == SensorType::kLine) {
    job.sensor = SensorModel::lineScanner();
  } else {
    job.sensor = SensorModel::multiBeam(c.multibeam.model);
    job.sensor_model = c.multibeam.model.name();
    job.laser_field = "user_data";  // each point's laser id, as writeStrip stores it
  }
  job.mounting_used = c.nominal_mounting;
  job.check_points_path = at("check_points.csv");
  job.check_planes_path = at("check_planes.csv");
  job.planes_path = at("planes.csv");
  if (options.ties) {
    job.ties_path = at("ties.csv");
    job.options.methods = {"vtpm"};
  } else {
    // No ties: the job calibrates automatically, by point-to-plane correspondences.
    job.options.methods = {"correspondences"};
  }
  job.options.estimate = {true, true, false, true, true, true};
  job.result_path = at("result.json");
  job.report_path = at("report.html");
  io::writeFileAtomically(job.path, jobJson(job));
  if (!survey.target_regions.empty()) {
    // The same survey for the second paper's method: high-intensity targets in their regions.
    Job fj = job;
    fj.path = at("job_features.json");
    fj.targets_path = at("targets.csv");
    fj.ties_path.clear();
    fj.options.methods = {"features"};
    fj.result_path = at("result_features.json");
    fj.report_path = at("report_features.html");
    io::writeFileAtomically(fj.path, jobJson(fj));
  }
}

}  // namespace

void writeSurvey(const SimulatedSurvey& survey, const std::string& dir, const SurveyWriteOptions& options) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw FileError(dir, "", "cannot create the output folder: " + ec.message());
  const SurveyConfig& c = survey.config;
  JobFrame frame;  // simulated ENU → output coordinates: identity, or through WGS84 into the CRS
  // The job.json, written through the job schema (job/schema.hpp).
  Job job;
  job.path = (std::filesystem::path(dir) / "job.json").string();
  auto at = [&](const std::string& name) { return (std::filesystem::path(dir) / name).lexically_normal().string(); };
  // The simulated ENU frame is placed on WGS84 under the CRS point (500000, 4000000) of the
  // requested CRS, or of UTM zone 11 N for a local job — so that an SBET can always be written.
  const std::string placement_crs = options.crs.empty() ? "EPSG:32611" : options.crs;
  checkSurveyWriteOptions(options);
  const io::CrsTransform placement(placement_crs);
  const LocalTangentFrame tangent(placement.toGeodetic(Vec3(500000.0, 4000000.0, 0.0)));
  writeSimulatedSbet(survey, tangent, dir);
  if (options.crs.empty()) {
    io::writeTrajectoryCsv(dir + "/trajectory.csv", *survey.measured_trajectory);
    job.trajectory_path = at("trajectory.csv");
    job.trajectory_format = TrajectoryFormat::kCsv;
  } else {
    frame = JobFrame(options.crs, tangent.origin());
    job.frame_type = JobFrameType::kCrs;
    job.crs = options.crs;
    job.trajectory_path = at("trajectory.sbet");
    job.trajectory_format = TrajectoryFormat::kSbet;
  }
  for (std::size_t k = 0; k < survey.strips.size(); ++k) {
    const SimulatedStrip& s = survey.strips[k];
    const std::string strip_file = "strip_" + s.id + (options.laz ? ".laz" : ".las");
    writeStripLas(dir + "/" + strip_file, survey, s, static_cast<int>(k + 1), frame, options.crs);
    io::writeRawCsv(dir + "/raw_" + s.id + ".csv", c.sensor, s.pulses);
    job.strips.push_back({s.id, at(strip_file), "las", {}});
  }
  writeSimulatedInputs(survey, frame, dir, options);
  writeSimulatedJobs(survey, job, options);
  writeSimulatedTruth(survey, dir);
}

void checkSurveyWriteOptions(const SurveyWriteOptions& options) {
  if (!options.crs.empty() && io::CrsTransform::isGeographic(options.crs)) {
    throw InvalidInput("CRS '" + options.crs +
                       "' is geographic (degrees): strips are written in a projected CRS in metres, e.g. a UTM zone (EPSG:326xx)");
  }
}

std::string stripWithoutPoints(const simulation::SimulatedSurvey& survey) {
  for (const auto& s : survey.strips)
    if (s.points_m.empty()) return s.id;
  return "";
}

}  // namespace mountcal
