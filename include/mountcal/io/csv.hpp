#pragma once
/// \file io/csv.hpp
/// The CSV files of SPEC §4: trajectory, raw observations, ties, check planes, GCPs.
/// Every reader requires the header line, accepts the columns in any order, ignores blank lines
/// and lines starting with '#', and throws FileError naming the file, the line and the column
/// for a missing column, a non-numeric or non-finite value, or a wrong field count.

#include <string>
#include <vector>

#include "mountcal/observations.hpp"
#include "mountcal/core/sensor_model.hpp"
#include "mountcal/core/trajectory.hpp"

namespace mountcal::io {

/// A parsed CSV table with named columns.
class CsvTable {
 public:
  /// Reads and splits `path`. Throws FileError.
  static CsvTable read(const std::string& path);

  std::size_t rows() const { return cells_.size(); }
  const std::string& path() const { return path_; }
  bool has(const std::string& column) const;
  /// The column index; throws FileError (line 1) when absent.
  std::size_t column(const std::string& name) const;
  const std::string& text(std::size_t row, std::size_t col) const { return cells_[row][col]; }
  /// A finite number; throws FileError naming line and column otherwise.
  double number(std::size_t row, std::size_t col) const;
  long integer(std::size_t row, std::size_t col) const;
  /// The same, refused (FileError naming the line and column) outside [lo, hi].
  long integer(std::size_t row, std::size_t col, long lo, long hi) const;
  std::size_t lineOf(std::size_t row) const { return lines_[row]; }

 private:
  std::string path_;
  std::vector<std::string> header_;
  std::vector<std::vector<std::string>> cells_;
  std::vector<std::size_t> lines_;
};

/// Local-frame trajectory CSV `time,x,y,z,roll_deg,pitch_deg,heading_deg`. `time_offset_s` is
/// added to every time. Throws FileError (also for unsorted or duplicate times, with the line).
Trajectory readTrajectoryCsv(const std::string& path, double time_offset_s = 0.0,
                             PositionInterpolation interpolation = PositionInterpolation::kLinear);
/// Writes the local-frame trajectory CSV (atomically).
void writeTrajectoryCsv(const std::string& path, const Trajectory& trajectory);

/// Ties CSV (`tie_id,strip_id,x,y`) and check-points CSV.
using mountcal::TieObservation;
std::vector<TieObservation> readTiesCsv(const std::string& path);
void writeTiesCsv(const std::string& path, const std::vector<TieObservation>& ties);

/// Check-planes / planes / targets CSV (`plane_id,xmin,ymin,xmax,ymax`).
using mountcal::PlaneRegion;
std::vector<PlaneRegion> readPlanesCsv(const std::string& path);
void writePlanesCsv(const std::string& path, const std::vector<PlaneRegion>& planes);

/// GCP CSV (`gcp_id,x,y,z,sigma_xy_m,sigma_z_m`).
using mountcal::GroundControlPoint;
std::vector<GroundControlPoint> readGcpCsv(const std::string& path);
void writeGcpCsv(const std::string& path, const std::vector<GroundControlPoint>& gcps);

/// Raw observations CSV (SPEC §4), by sensor type: line `time,scan_angle_deg,range_m,intensity`;
/// multi-beam `time,laser_id,azimuth_deg,range_m,intensity`; vector `time,xs,ys,zs,intensity`.
std::vector<RawPulse> readRawCsv(const std::string& path, SensorType type);
void writeRawCsv(const std::string& path, SensorType type, const std::vector<RawPulse>& pulses);

}  // namespace mountcal::io
