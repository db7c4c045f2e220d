#include "mountcal/job/apply.hpp"

#include <filesystem>

#include "mountcal/error.hpp"
#include "mountcal/georeference_model.hpp"
#include "mountcal/io/las.hpp"
#include "mountcal/job/load.hpp"

namespace mountcal {

namespace fs = std::filesystem;

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

}  // namespace mountcal
