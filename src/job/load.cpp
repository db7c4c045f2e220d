#include "mountcal/job/load.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>

#include "mountcal/core/error.hpp"
#include "mountcal/core/georeference_model.hpp"
#include "mountcal/io/csv.hpp"
#include "mountcal/io/las.hpp"
#include "mountcal/io/pose_fields.hpp"
#include "mountcal/io/sbet.hpp"
#include "geometry/kd_tree.hpp"

namespace mountcal {

namespace detail {

/// Every strip point's plan position in the CRS in a k-d tree, with its height.
class PlanHeightIndex {
 public:
  explicit PlanHeightIndex(std::vector<double> xyz) : xyz_(std::move(xyz)) {
    const std::size_t n = xyz_.size() / 3;
    std::vector<double> xy(2 * n);
    for (std::size_t i = 0; i < n; ++i) {
      xy[2 * i] = xyz_[3 * i];
      xy[2 * i + 1] = xyz_[3 * i + 1];
    }
    tree_ = KdTree<double, 2>(std::move(xy));
  }
  double heightAt(double x, double y) const {
    const double q[2] = {x, y};
    std::size_t nearest = 0;
    double d2 = 0;
    if (tree_.nearest(q, 1, &nearest, &d2) == 0) return 0.0;
    return xyz_[3 * nearest + 2];
  }

 private:
  std::vector<double> xyz_;
  KdTree<double, 2> tree_;
};

}  // namespace detail

JobFrame::JobFrame(const std::string& crs, const Geodetic& origin)
    : crs_name_(crs), crs_(std::make_shared<io::CrsTransform>(crs)), tangent_(std::make_shared<LocalTangentFrame>(origin)) {}

Vec3 JobFrame::toLocal(const Vec3& x) const { return crs_ ? tangent_->toLocal(crs_->toGeodetic(x)) : x; }
Vec3 JobFrame::fromLocal(const Vec3& x) const { return crs_ ? crs_->fromGeodetic(tangent_->toGeodetic(x)) : x; }

double LoadedJob::crsHeightAt(double x, double y) const { return crs_heights ? crs_heights->heightAt(x, y) : 0.0; }

namespace {

/// GPS week seconds lie in [0, 604800]; adjusted standard GPS time (GPS seconds − 1e9) of
/// any date since 2011 is far larger.
bool looksLikeWeekSeconds(double t) { return t >= -1.0 && t <= 604801.0; }

/// Which records of a file a strip takes (JobStrip::split), in file order.
class SplitFilter {
 public:
  SplitFilter(const io::LasHeader& h, const JobStrip& js) : split_(js.split) {
    if (split_.active()) field_ = std::make_unique<io::PointFieldReader>(h, js.path, split_.field);
  }
  bool take(const io::LasPoint& p) {
    if (!field_) return true;
    const double v = field_->value(p);
    if (split_.part == 0) return v >= split_.min && v <= split_.max;
    if (!started_ || std::abs(v - prev_) > split_.gap) ++part_;
    started_ = true;
    prev_ = v;
    return part_ == split_.part;
  }
  int parts() const { return part_; }

 private:
  StripSplit split_;
  std::unique_ptr<io::PointFieldReader> field_;
  bool started_ = false;
  double prev_ = 0.0;
  int part_ = 0;
};

[[noreturn]] void emptySplit(const Job& job, const JobStrip& js, const SplitFilter& f) {
  std::string what = js.split.part > 0 ? "part " + std::to_string(js.split.part) + " of " + std::to_string(f.parts()) + " (gap " +
                                             std::to_string(js.split.gap) + ")"
                                       : "the range [" + std::to_string(js.split.min) + ", " + std::to_string(js.split.max) + "]";
  throw FileError(js.path, "field '" + js.split.field + "'",
                  "strip '" + js.id + "' of " + job.path + " selects " + what + ", which holds no record");
}

/// Each point's laser id from the job's sensor.laser_field, checked against the sensor's lasers.
class LaserIds {
 public:
  LaserIds(const io::LasHeader& h, const Job& job, const JobStrip& js)
      : field_(h, js.path, job.laser_field),
        path_(js.path),
        lasers_(job.sensor.type == SensorType::kMultiBeam ? job.sensor.multibeam.laserCount() : 0) {}
  std::uint16_t id(const io::LasPoint& p, std::uint64_t record) const {
    const double id = field_.value(p);
    if (!(id >= 0 && id < lasers_ && id == std::floor(id))) {
      throw FileError(path_, "record " + std::to_string(record),
                      "laser id " + std::to_string(id) + " in field '" + field_.name() + "' is not one of the " + std::to_string(lasers_) +
                          " lasers of the sensor");
    }
    return static_cast<std::uint16_t>(id);
  }

 private:
  io::PointFieldReader field_;
  std::string path_;
  int lasers_;
};

/// A strip whose points carry their own sensor pose (JobStrip of a job with "poses").
StripData loadPosedLasStrip(const Job& job, const JobStrip& js) {
  io::LasReader reader(js.path);
  const io::LasHeader& h = reader.header();
  const io::PoseFieldReader poses(h, js.path, job.pose_fields);
  SplitFilter filter(h, js);
  std::unique_ptr<LaserIds> laser;
  if (!job.laser_field.empty()) laser = std::make_unique<LaserIds>(h, job, js);
  StripData s;
  s.id = js.id;
  std::vector<io::LasPoint> chunk;
  std::uint64_t record = 0;
  const Mat3 R_bs = job.mounting_used.R_bs();
  while (reader.read(&chunk) > 0) {
    for (const io::LasPoint& p : chunk) {
      const std::uint64_t rec = record++;
      if (!filter.take(p)) continue;
      const Pose pose = poses.pose(p, rec);
      const Vec3 x(reader.x(p), reader.y(p), reader.z(p));
      const Vec3 r = inverseGeoreference(pose, R_bs, job.mounting_used.a_b, x);  // SPEC §2 inverse
      if (!(r.norm() < 1e4)) {
        throw FileError(js.path, "record " + std::to_string(rec),
                        "the point lies " + std::to_string(r.norm()) + " m from its sensor position; are the pose fields right?");
      }
      s.time_s.push_back(h.hasGpsTime() ? p.gps_time : 0.0);
      s.x_m.push_back(x);
      s.r_s.push_back(r);
      s.poses.push_back(pose);
      s.intensity.push_back(p.intensity);
      if (laser) s.laser.push_back(laser->id(p, rec));
    }
  }
  if (s.time_s.empty()) {
    if (js.split.active()) emptySplit(job, js, filter);
    throw FileError(js.path, "", "strip '" + js.id + "' has no points");
  }
  return s;
}

/// Refuses a point outside the header's bounds (with a margin for writers that round them):
/// a scale or offset that puts points kilometres away. Headers with all-zero bounds (left
/// unset by some writers) are not checked.
class BoundsCheck {
 public:
  BoundsCheck(const io::LasHeader& h, const std::string& path) : h_(h), path_(path) {
    for (int a = 0; a < 3; ++a) active_ = active_ || h.min[a] != 0.0 || h.max[a] != 0.0;
  }
  void check(const Vec3& x, std::uint64_t record) const {
    if (!active_) return;
    for (int a = 0; a < 3; ++a) {
      const double margin = std::max(1.0, 1e-3 * (h_.max[a] - h_.min[a])) + 2 * h_.scale[a];
      if (!(x[a] >= h_.min[a] - margin && x[a] <= h_.max[a] + margin)) {
        char buf[200];
        std::snprintf(buf, sizeof buf,
                      "the point's %c = %.6g lies outside the header's bounds [%.3f, %.3f]: a wrong scale or offset in the header?",
                      "xyz"[a], x[a], h_.min[a], h_.max[a]);
        throw FileError(path_, "record " + std::to_string(record), buf);
      }
    }
  }

 private:
  const io::LasHeader& h_;
  std::string path_;
  bool active_ = false;
};

/// The laser ranges a strip's points imply: a scanner measures metres to kilometres; ranges of
/// tens of kilometres mean that strips and trajectory do not describe the same place.
void checkRanges(const StripData& s, const std::string& path) {
  constexpr double kMaxRange = 20000.0;  // m: beyond any airborne or terrestrial scanner
  for (std::size_t i = 0; i < s.r_s.size(); ++i) {
    const double r = s.r_s[i].norm();
    if (!(r <= kMaxRange)) {
      char buf[240];
      std::snprintf(buf, sizeof buf,
                    "the point at GPS time %.6f s lies %.3g m from the sensor: strips and trajectory do not agree in space "
                    "(a wrong CRS or zone, another trajectory, or wrong lever arm units?)",
                    s.time_s[i], r);
      throw FileError(path, "strip '" + s.id + "'", buf);
    }
  }
}

StripData loadLasStrip(const Job& job, const JobStrip& js, const GeoreferenceModel& model, const JobFrame& frame,
                       std::vector<double>* xyz_crs) {
  io::LasReader reader(js.path);
  const io::LasHeader& h = reader.header();
  if (!h.hasGpsTime()) {
    throw FileError(js.path, "byte 104",
                    "point format " + std::to_string(h.point_format) + " has no GPS time; a calibration needs formats 1, 3 or 6-8");
  }
  SplitFilter filter(h, js);
  std::unique_ptr<LaserIds> laser;
  if (!job.laser_field.empty()) laser = std::make_unique<LaserIds>(h, job, js);
  StripData s;
  s.id = js.id;
  s.time_s.reserve(static_cast<std::size_t>(h.point_count));
  s.x_m.reserve(static_cast<std::size_t>(h.point_count));
  std::vector<io::LasPoint> chunk;
  const Trajectory& T = model.trajectory();
  const bool traj_week = looksLikeWeekSeconds(T.startTime());
  const BoundsCheck bounds(h, js.path);
  std::uint64_t record = 0;
  while (reader.read(&chunk) > 0) {
    for (const io::LasPoint& p : chunk) {
      if (!filter.take(p)) {
        ++record;
        continue;
      }
      const double t = p.gps_time;
      if (!std::isfinite(t)) throw FileError(js.path, "record " + std::to_string(record), "GPS time is not finite");
      if (s.time_s.empty() && h.adjustedStandardGpsTime() == traj_week) {
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
      s.intensity.push_back(p.intensity);
      if (laser) s.laser.push_back(laser->id(p, record));
      const Vec3 x(reader.x(p), reader.y(p), reader.z(p));
      bounds.check(x, record);
      if (xyz_crs) xyz_crs->insert(xyz_crs->end(), {x.x(), x.y(), x.z()});
      s.x_m.push_back(frame.toLocal(x));
      ++record;
    }
  }
  if (js.split.active() && s.time_s.empty()) emptySplit(job, js, filter);
  if (s.time_s.empty()) throw FileError(js.path, "", "strip '" + js.id + "' has no points");
  // The pulse times place the points on the trajectory: one time for every point is no time.
  if (s.time_s.size() > 1 && std::all_of(s.time_s.begin(), s.time_s.end(), [&](double t) { return t == s.time_s.front(); })) {
    throw FileError(js.path, "",
                    "every point of strip '" + js.id + "' has the GPS time " + std::to_string(s.time_s.front()) +
                        " s: the times are not the pulse times");
  }
  // Inverse georeferencing (SPEC §2): the raw vectors that, with mounting_used, gave x_m.
  const std::size_t n = s.time_s.size();
  std::vector<double> x(3 * n), r(3 * n);
  for (std::size_t i = 0; i < n; ++i) Eigen::Map<Vec3>{&x[3 * i]} = s.x_m[i];
  model.inverse(s.time_s.data(), x.data(), r.data(), n);
  s.r_s.resize(n);
  for (std::size_t i = 0; i < n; ++i) s.r_s[i] = Eigen::Map<const Vec3>(&r[3 * i]);
  checkRanges(s, js.path);
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
    s.intensity.push_back(p.intensity);
  }
  s.x_m.resize(s.r_s.size());
  std::size_t cursor = 0;
  for (std::size_t i = 0; i < s.r_s.size(); ++i) {
    s.x_m[i] = georeference(T.pose(s.time_s[i], &cursor), model.mounting().R_bs(), model.mounting().a_b, s.r_s[i]);
  }
  return s;
}

/// Picks are plan positions in the strips' CRS; in the tangent frame a plan position moves with
/// height, so each is lifted with the height of the nearest strip point before conversion.
/// Ties or check points, each naming a strip of the job (else FileError naming the line).
std::vector<TieObservation> readPicks(const Job& job, const std::string& path, const std::string& what) {
  std::vector<TieObservation> picks = io::readTiesCsv(path);
  std::set<std::string> ids;
  for (const JobStrip& js : job.strips) ids.insert(js.id);
  for (const TieObservation& t : picks) {
    if (!ids.count(t.strip_id)) {
      throw FileError(path, "line " + std::to_string(t.line),
                      what + " '" + t.tie_id + "' names strip '" + t.strip_id + "', which the job does not list");
    }
  }
  return picks;
}

std::vector<TieObservation> liftPicks(std::vector<TieObservation> ties, const LoadedJob& loaded) {
  if (loaded.frame.isLocal()) return ties;
  for (TieObservation& t : ties) {
    const Vec3 x = loaded.frame.toLocal(Vec3(t.x_m, t.y_m, loaded.crsHeightAt(t.x_m, t.y_m)));
    t.x_m = x.x();
    t.y_m = x.y();
  }
  return ties;
}

/// A region's bounding box in the computation frame (meridian convergence turns it slightly).
std::vector<PlaneRegion> liftRegions(std::vector<PlaneRegion> regions, const LoadedJob& loaded) {
  if (loaded.frame.isLocal()) return regions;
  for (PlaneRegion& r : regions) {
    const double z = loaded.crsHeightAt(0.5 * (r.xmin + r.xmax), 0.5 * (r.ymin + r.ymax));
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
    r = {r.id, x0, y0, x1, y1, r.line};
  }
  return regions;
}

/// Regions must lie on the data: each within the strips' extent widened by 100 m. A region of
/// ±10⁶ m would have the region grid visit every cell of it (minutes) and then take the whole
/// field as one "planar" patch. Throws FileError naming the file and the region's line.
std::vector<PlaneRegion> regionsOnData(std::vector<PlaneRegion> regions, const std::string& path, const CalibrationData& d) {
  constexpr double kMargin = 100.0;  // [m]
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  for (const StripData& s : d.strips)
    for (const Vec3& x : s.x_m) {
      x0 = std::min(x0, x.x()), y0 = std::min(y0, x.y());
      x1 = std::max(x1, x.x()), y1 = std::max(y1, x.y());
    }
  if (!(x1 >= x0)) return regions;  // no points: nothing to compare with (the methods say so)
  for (const PlaneRegion& r : regions) {
    if (r.xmin < x0 - kMargin || r.ymin < y0 - kMargin || r.xmax > x1 + kMargin || r.ymax > y1 + kMargin) {
      char why[256];
      std::snprintf(why, sizeof why,
                    "region '%s' (%.0f m x %.0f m) reaches beyond the strips' extent (%.0f m x %.0f m) by more than %.0f m; "
                    "give the box of one surface",
                    r.id.c_str(), r.xmax - r.xmin, r.ymax - r.ymin, x1 - x0, y1 - y0, kMargin);
      throw FileError(path, "line " + std::to_string(r.line), why);
    }
  }
  return regions;
}

}  // namespace

LoadedJob loadJobTrajectory(const Job& job) {
  LoadedJob out;
  CalibrationData& d = out.data;
  if (job.per_point_poses) {  // no trajectory: every strip point carries its pose
    d.mounting_used = job.mounting_used;
    return out;
  }
  if (job.frame_type == JobFrameType::kLocal) {
    if (job.trajectory_format != TrajectoryFormat::kCsv) {
      throw FileError(job.path, "field 'trajectory.format'",
                      "a local-frame job needs the local trajectory CSV of SPEC §4; an SBET needs \"frame\": {\"type\": \"crs\"}");
    }
    d.trajectory = std::make_shared<const Trajectory>(io::readTrajectoryCsv(job.trajectory_path, job.time_offset_s));
  } else {
    const std::vector<io::SbetRecord> records = job.trajectory_format == TrajectoryFormat::kSbet
                                                    ? io::readSbet(job.trajectory_path)
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

int LaserTableCheck::beyond(double tolerance_deg) const {
  return static_cast<int>(
      std::count_if(lasers.begin(), lasers.end(), [&](const Laser& l) { return std::abs(l.median_deviation_deg) > tolerance_deg; }));
}

LaserTableCheck checkLaserTable(const CalibrationData& data, const MultiBeamModel& model) {
  std::vector<std::vector<double>> dev(static_cast<std::size_t>(model.laserCount()));
  for (const StripData& st : data.strips) {
    if (st.laser.size() != st.r_s.size()) continue;
    for (std::size_t i = 0; i < st.r_s.size(); ++i) {
      const int id = st.laser[i];
      if (id >= model.laserCount()) continue;
      const LaserSpec& l = model.laser(id);
      const Vec3 r = st.r_s[i] - Vec3(0, 0, l.vertical_offset_m);
      const double h = std::hypot(r.x(), r.y());
      if (!(h > 0 || r.z() != 0)) continue;
      dev[static_cast<std::size_t>(id)].push_back(rad2deg(std::atan2(r.z(), h) - l.elevation_rad));
    }
  }
  LaserTableCheck c;
  for (std::size_t id = 0; id < dev.size(); ++id) {
    std::vector<double>& d = dev[id];
    if (d.size() < 50) continue;
    std::nth_element(d.begin(), d.begin() + static_cast<long>(d.size() / 2), d.end());
    LaserTableCheck::Laser l{static_cast<int>(id), d.size(), d[d.size() / 2]};
    if (std::abs(l.median_deviation_deg) > c.worst_abs_deviation_deg || c.worst_laser < 0) {
      c.worst_abs_deviation_deg = std::abs(l.median_deviation_deg);
      c.worst_laser = l.id;
    }
    c.lasers.push_back(l);
  }
  return c;
}

namespace {
/// Refuses a multi-beam job whose points' laser directions disagree with its table
/// (Job::laser_table_tolerance_deg), naming the worst laser and what to check.
void requireLaserTable(const Job& job, const CalibrationData& d) {
  if (job.sensor.type != SensorType::kMultiBeam || !(job.laser_table_tolerance_deg > 0)) return;
  const MultiBeamModel& model = job.sensor.multibeam;
  const LaserTableCheck c = checkLaserTable(d, model);
  if (c.lasers.empty() || c.worst_abs_deviation_deg <= job.laser_table_tolerance_deg) return;
  const LaserTableCheck::Laser& w = *std::find_if(c.lasers.begin(), c.lasers.end(), [&](const auto& l) { return l.id == c.worst_laser; });
  char buf[600];
  std::snprintf(buf, sizeof buf,
                "the points' laser directions disagree with the %s laser table: laser %d lies %+.2f deg from its elevation %.2f deg "
                "(median over %zu points), %d of %zu lasers beyond %.3g deg. Check sensor.nominal_rotation_deg, the attitude unit "
                "(poses.attitude_unit or the trajectory's), sensor.laser_field and sensor.model; a mounting this far from level "
                "needs a larger sensor.laser_table_tolerance_deg (0: not checked)",
                model.name().c_str(), w.id, w.median_deviation_deg, rad2deg(model.laser(w.id).elevation_rad), w.points,
                c.beyond(job.laser_table_tolerance_deg), c.lasers.size(), job.laser_table_tolerance_deg);
  throw FileError(job.path, "field 'sensor'", buf);
}
}  // namespace

namespace {
/// The job's smrmsg as a series in the strips' time scale (the trajectory's time_offset_s added),
/// refused when a strip's time span lies wholly outside the file's (another flight's file, or
/// week seconds against another time scale); a strip partly beyond it takes its end record's σ.
std::shared_ptr<const TrajectoryAccuracySeries> loadTrajectoryAccuracy(const Job& job, const CalibrationData& d) {
  const std::string& path = job.trajectory_accuracy_path;
  auto series = std::make_shared<TrajectoryAccuracySeries>(io::smrmsgToAccuracy(io::readSmrmsg(path), job.time_offset_s));
  for (const StripData& s : d.strips) {
    if (s.time_s.empty()) continue;
    const auto [lo, hi] = std::minmax_element(s.time_s.begin(), s.time_s.end());
    if (*hi < series->time_s.front() || *lo > series->time_s.back()) {
      char why[240];
      std::snprintf(why, sizeof why, "its times %.3f–%.3f s do not reach strip '%s''s times %.3f–%.3f s", series->time_s.front(),
                    series->time_s.back(), s.id.c_str(), *lo, *hi);
      throw FileError(path, "", why);
    }
  }
  return series;
}
}  // namespace

LoadedJob loadJob(const Job& job) {
  LoadedJob out = loadJobTrajectory(job);
  CalibrationData& d = out.data;
  std::vector<double> xyz_crs;
  if (job.per_point_poses) {
    for (const JobStrip& js : job.strips) d.strips.push_back(loadPosedLasStrip(job, js));
  }
  const std::unique_ptr<const GeoreferenceModel> model_ptr =
      job.per_point_poses ? nullptr : std::make_unique<const GeoreferenceModel>(d.trajectory, job.mounting_used);
  for (const JobStrip& js : job.per_point_poses ? std::vector<JobStrip>{} : job.strips) {
    const GeoreferenceModel& model = *model_ptr;
    if (js.format == "las") {
      d.strips.push_back(loadLasStrip(job, js, model, out.frame, out.frame.isLocal() ? nullptr : &xyz_crs));
    } else {
      if (!out.frame.isLocal()) throw FileError(js.path, "", "raw CSV strips are supported in local-frame jobs only");
      d.strips.push_back(loadRawStrip(js, job.sensor, model));
    }
  }
  if (!out.frame.isLocal()) out.crs_heights = std::make_shared<const detail::PlanHeightIndex>(std::move(xyz_crs));
  requireLaserTable(job, d);
  if (!job.trajectory_accuracy_path.empty()) d.trajectory_accuracy = loadTrajectoryAccuracy(job, d);
  if (!job.ties_path.empty()) d.ties = liftPicks(readPicks(job, job.ties_path, "tie"), out);
  if (!job.planes_path.empty()) d.plane_regions = regionsOnData(liftRegions(io::readPlanesCsv(job.planes_path), out), job.planes_path, d);
  if (!job.targets_path.empty())
    d.target_regions = regionsOnData(liftRegions(io::readPlanesCsv(job.targets_path), out), job.targets_path, d);
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

std::vector<TieObservation> loadCheckPoints(const Job& job, const LoadedJob& loaded) {
  if (job.check_points_path.empty()) return {};
  return liftPicks(readPicks(job, job.check_points_path, "check point"), loaded);
}

std::vector<PlaneRegion> loadCheckPlanes(const Job& job, const LoadedJob& loaded) {
  if (job.check_planes_path.empty()) return {};
  return regionsOnData(liftRegions(io::readPlanesCsv(job.check_planes_path), loaded), job.check_planes_path, loaded.data);
}

}  // namespace mountcal
