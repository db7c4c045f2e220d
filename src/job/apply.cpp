#include "mountcal/job/apply.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>

#include "core/parallel.hpp"
#include "mountcal/core/error.hpp"
#include "mountcal/core/georeference_model.hpp"
#include "mountcal/io/atomic_file.hpp"
#include "mountcal/io/las.hpp"
#include "mountcal/io/pose_fields.hpp"
#include "mountcal/job/load.hpp"
#include "mountcal/core/sensor_model.hpp"

namespace mountcal {

namespace fs = std::filesystem;

namespace {

/// Every input LAS file once, in job order, and the output path of each in `out_dir`; throws
/// FileError before anything is written when an output would overwrite an input or another
/// output, or when the result needs a field the job does not name.
void planOutputs(const Job& job, const std::string& out_dir, const LaserCorrections& lasers, StripFormat format,
                 const std::vector<std::string>& also_inputs, std::vector<std::string>* inputs_out, std::vector<std::string>* outputs_out) {
  std::vector<std::string>& inputs = *inputs_out;
  std::vector<std::string>& outputs = *outputs_out;
  if (!lasers.empty() && job.laser_field.empty()) {
    throw FileError(job.path, "field 'sensor.laser_field'",
                    "the result has per-laser intrinsics; the job must name the field holding each point's laser id");
  }
  // Every input file once, in job order; every output checked against every input first.
  for (const JobStrip& js : job.strips) {
    if (js.format != "las") throw FileError(js.path, "", "apply rewrites LAS strips; this strip is a raw CSV");
    bool seen = false;
    for (const std::string& in : inputs) seen = seen || io::samePath(in, js.path);
    if (!seen) inputs.push_back(js.path);
  }
  std::map<std::string, std::string> by_name;
  for (const std::string& in : inputs) {
    fs::path file = fs::path(in).filename();
    if (format != StripFormat::same_as_input) file.replace_extension(format == StripFormat::laz ? ".laz" : ".las");
    const std::string name = file.string();
    auto [it, fresh] = by_name.emplace(name, in);
    if (!fresh)
      throw FileError(in, "",
                      "has the same file name as " + it->second + "; apply would write both to " + (fs::path(out_dir) / name).string());
    outputs.push_back((fs::path(out_dir) / name).string());
    std::vector<std::string> every_input = jobInputPaths(job);
    every_input.insert(every_input.end(), also_inputs.begin(), also_inputs.end());
    for (const std::string& other : every_input) {
      if (io::samePath(outputs.back(), other))
        throw FileError(outputs.back(), "", "apply would overwrite an input (" + other + "); choose another --out folder");
    }
  }
}

/// The reader of the job's per-point pose fields; null when the poses come from the trajectory,
/// which needs the points' GPS time.
std::unique_ptr<io::PoseFieldReader> poseReader(const Job& job, const io::LasHeader& h, const std::string& in_path) {
  if (job.per_point_poses) return std::make_unique<io::PoseFieldReader>(h, in_path, job.pose_fields);
  if (!h.hasGpsTime()) throw FileError(in_path, "byte 104", "point format " + std::to_string(h.point_format) + " has no GPS time");
  return nullptr;
}

/// One input file re-georeferenced into its output: from the mounting the job used to `mounting`.
class FileApplier {
 public:
  FileApplier(const Job& job, const LoadedJob& loaded, const MountingParameters& mounting, const LaserCorrections& lasers,
              const std::string& in_path, const std::string& out_path, std::size_t chunk_points)
      : job_(job),
        loaded_(loaded),
        mounting_(mounting),
        lasers_(laserCorrectors(lasers)),
        in_path_(in_path),
        chunk_points_(chunk_points),
        frame_(loaded.frame.forAnotherThread()),
        reader_(in_path),
        poses_(poseReader(job, reader_.header(), in_path)),
        laser_(lasers.empty() ? nullptr : std::make_unique<io::PointFieldReader>(reader_.header(), in_path, job.laser_field)),
        writer_(out_path, reader_.header()) {}

  /// Rewrites the file into a temporary file beside its output; returns the statistics and, in
  /// `temporary`, that file's name (the caller places or removes it).
  ApplyStats run(std::string* temporary) {
    ApplyStats stats;
    // With a trajectory and no per-laser offsets, each chunk goes through the batch
    // georeferencing (attitude expanded once per trajectory interval, exact within 1e-9 m):
    // inverse with the mounting used, forward with the new one.
    const std::uint64_t points = !poses_ && !laser_ && loaded_.data.trajectory ? rewriteRecords(&stats) : rewritePoints(&stats);
    *temporary = writer_.closeToTemporary();
    stats.points = points;
    stats.strips = 1;
    return stats;
  }

 private:
  /// The batch path works on the records as stored: X, Y, Z and the GPS time are read from
  /// their bytes, the new X, Y, Z written back, every other byte (extra bytes included) passes
  /// through untouched. Returns the records written.
  std::uint64_t rewriteRecords(ApplyStats* stats_out) {
    ApplyStats& stats = *stats_out;
    const io::LasHeader& h = reader_.header();
    const Trajectory* T = loaded_.data.trajectory.get();
    const GeoreferenceModel used_model(loaded_.data.trajectory, job_.mounting_used);
    const GeoreferenceModel new_model(loaded_.data.trajectory, mounting_);
    std::uint64_t record = 0;
    std::vector<std::uint8_t> records;
    std::vector<double> times, xyz_crs, xyz, xyz_new;
    std::vector<std::int32_t> XYZ_new;
    double max_shift2 = 0;  // the largest squared shift: one square root per file
    const std::size_t len = h.point_record_length;
    const io::LasRecordLayout layout(h.point_format);
    const double s0 = h.scale[0], s1 = h.scale[1], s2 = h.scale[2], o0 = h.offset[0], o1 = h.offset[1], o2 = h.offset[2];
    const double t_start = T->startTime(), t_end = T->endTime();
    // Points per batch: the arrays stay in the caches' reach. The records are read a batch at a
    // time too, so that they are still in the cache when processed and written (reading whole
    // chunks of a million records made each record travel through memory three times, and two
    // threads then waited on the memory bus).
    constexpr std::size_t kBatch = 1u << 16;
    while (reader_.readRaw(&records, std::min(chunk_points_, kBatch)) > 0) {
      const std::size_t in_chunk = records.size() / len;
      for (std::size_t k0 = 0; k0 < in_chunk; k0 += kBatch) {
        const std::size_t n = std::min(kBatch, in_chunk - k0);
        std::uint8_t* block = records.data() + k0 * len;
        times.resize(n);
        xyz_crs.resize(3 * n);
        xyz_new.resize(3 * n);
        XYZ_new.resize(3 * n);
        // The records' times and coordinates in the CRS, as arrays.
        for (std::size_t k = 0; k < n; ++k) {
          const std::uint8_t* r = block + k * len;
          std::int32_t X[3];
          io::LasRecordLayout::integers(r, X);
          times[k] = layout.gpsTime(r);
          xyz_crs[3 * k] = X[0] * s0 + o0;
          xyz_crs[3 * k + 1] = X[1] * s1 + o1;
          xyz_crs[3 * k + 2] = X[2] * s2 + o2;
        }
        for (std::size_t k = 0; k < n; ++k) {
          if (!(times[k] >= t_start && times[k] <= t_end)) {
            throw FileError(in_path_, "record " + std::to_string(record + k),
                            "GPS time " + std::to_string(times[k]) + " s is outside the trajectory");
          }
        }
        const double* x_local = xyz_crs.data();
        if (!frame_.isLocal()) {
          xyz.resize(3 * n);
          for (std::size_t k = 0; k < n; ++k) {
            const Vec3 x = frame_.toLocal(Vec3(xyz_crs[3 * k], xyz_crs[3 * k + 1], xyz_crs[3 * k + 2]));
            xyz[3 * k] = x.x(), xyz[3 * k + 1] = x.y(), xyz[3 * k + 2] = x.z();
          }
          x_local = xyz.data();
        }
        reGeoreference(used_model, new_model, times.data(), x_local, xyz_new.data(), n);  // files run in parallel, not points
        if (!frame_.isLocal()) {
          for (std::size_t k = 0; k < n; ++k) {
            const Vec3 x = frame_.fromLocal(Vec3(xyz_new[3 * k], xyz_new[3 * k + 1], xyz_new[3 * k + 2]));
            xyz_new[3 * k] = x.x(), xyz_new[3 * k + 1] = x.y(), xyz_new[3 * k + 2] = x.z();
          }
        }
        for (std::size_t k = 0; k < n; ++k) {
          const double dx = xyz_new[3 * k] - xyz_crs[3 * k], dy = xyz_new[3 * k + 1] - xyz_crs[3 * k + 1],
                       dz = xyz_new[3 * k + 2] - xyz_crs[3 * k + 2];
          max_shift2 = std::max(max_shift2, dx * dx + dy * dy + dz * dz);
        }
        writer_.quantize(xyz_new.data(), XYZ_new.data(), n, record);
        for (std::size_t k = 0; k < n; ++k) io::LasRecordLayout::setIntegers(block + k * len, &XYZ_new[3 * k]);
        writer_.writeRaw(block, n);
        record += n;
      }
    }
    stats.max_shift_m = std::max(stats.max_shift_m, std::sqrt(max_shift2));
    return record;
  }

  /// Point by point, through per-point poses or per-laser offsets. Returns the points written.
  std::uint64_t rewritePoints(ApplyStats* stats_out) {
    ApplyStats& stats = *stats_out;
    const Trajectory* T = loaded_.data.trajectory.get();
    const Mat3 R_bs0 = job_.mounting_used.R_bs(), R_bs1 = mounting_.R_bs();
    std::vector<io::LasPoint> chunk;
    std::size_t cursor = 0;
    std::uint64_t record = 0;
    while (reader_.read(&chunk, chunk_points_) > 0) {
      for (io::LasPoint& p : chunk) {
        Pose pose;
        if (poses_) {
          pose = poses_->pose(p, record);
        } else {
          if (!(p.gps_time >= T->startTime() && p.gps_time <= T->endTime())) {
            throw FileError(in_path_, "record " + std::to_string(record),
                            "GPS time " + std::to_string(p.gps_time) + " s is outside the trajectory");
          }
          pose = T->pose(p.gps_time, &cursor);
        }
        const Vec3 x_crs(reader_.x(p), reader_.y(p), reader_.z(p));
        Vec3 r_s = inverseGeoreference(pose, R_bs0, job_.mounting_used.a_b, frame_.toLocal(x_crs));
        if (laser_) {
          const double id = laser_->value(p);
          if (!(id >= 0 && id < static_cast<double>(lasers_.size()))) {
            throw FileError(in_path_, "record " + std::to_string(record),
                            "laser id " + std::to_string(id) + " has no intrinsics in the result");
          }
          r_s = lasers_[static_cast<std::size_t>(id)](r_s);
        }
        const Vec3 x_new = frame_.fromLocal(georeference(pose, R_bs1, mounting_.a_b, r_s));
        stats.max_shift_m = std::max(stats.max_shift_m, (x_new - x_crs).norm());
        p.X = writer_.quantize(0, x_new.x());
        p.Y = writer_.quantize(1, x_new.y());
        p.Z = writer_.quantize(2, x_new.z());
        writer_.write(p);
        ++record;
      }
    }
    return record;
  }

  const Job& job_;
  const LoadedJob& loaded_;
  const MountingParameters& mounting_;
  std::vector<LaserCorrector> lasers_;
  const std::string& in_path_;
  const std::size_t chunk_points_;
  const JobFrame frame_;
  io::LasReader reader_;
  std::unique_ptr<io::PoseFieldReader> poses_;   // per-point poses, when the job has them
  std::unique_ptr<io::PointFieldReader> laser_;  // each point's laser id, for per-laser offsets
  io::LasWriter writer_;                         // opened last: a bad input leaves no temporary file
};

}  // namespace

ApplyStats applyMounting(const Job& job, const MountingParameters& mounting, const std::string& out_dir, std::size_t chunk_points,
                         const LaserCorrections& lasers, StripFormat format, const std::vector<std::string>& also_inputs, int threads) {
  std::vector<std::string> inputs, outputs;
  planOutputs(job, out_dir, lasers, format, also_inputs, &inputs, &outputs);
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec) throw FileError(out_dir, "", "cannot create the output folder: " + ec.message());
  const LoadedJob loaded = loadJobTrajectory(job);
  std::vector<ApplyStats> per_file(inputs.size());
  // Every output is written to a temporary file first and placed only when all are written: a
  // run that fails on any file leaves every earlier output as it was (no folder mixing two
  // mountings).
  std::vector<std::string> temporaries(inputs.size());
  try {
    detail::parallelFor(inputs.size(), threads, [&](std::size_t f) {
      per_file[f] = FileApplier(job, loaded, mounting, lasers, inputs[f], outputs[f], chunk_points).run(&temporaries[f]);
    });
  } catch (...) {
    for (const std::string& t : temporaries)
      if (!t.empty()) std::remove(t.c_str());
    throw;
  }
  std::vector<std::pair<std::string, std::string>> placements;
  for (std::size_t f = 0; f < inputs.size(); ++f) placements.emplace_back(temporaries[f], outputs[f]);
  io::placeFilesAtomically(placements);
  ApplyStats stats;
  for (const ApplyStats& f : per_file) {
    stats.points += f.points;
    stats.strips += f.strips;
    stats.max_shift_m = std::max(stats.max_shift_m, f.max_shift_m);
  }
  return stats;
}

}  // namespace mountcal
