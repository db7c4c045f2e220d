#pragma once
/// \file io/sbet.hpp
/// Applanix SBET trajectories (SPEC §4): no header; records of 17 little-endian float64.

#include <string>
#include <vector>

#include "mountcal/core/geodesy.hpp"
#include "mountcal/core/trajectory.hpp"

namespace mountcal::io {

/// One SBET record, in the file's units.
struct SbetRecord {
  double time_s;                ///< GPS seconds of week [s]
  double lat_rad, lon_rad;      ///< [rad]
  double h_m;                   ///< ellipsoidal height [m]
  double vx, vy, vz;            ///< velocity, wander frame [m/s]
  double roll_rad, pitch_rad;   ///< [rad]
  double platform_heading_rad;  ///< heading in the wander frame [rad]
  double wander_rad;            ///< wander angle [rad]
  double ax, ay, az;            ///< body acceleration [m/s²]
  double wx, wy, wz;            ///< body angular rate [rad/s]
  /// True heading = platform heading − wander angle (SPEC §4).
  double trueHeading() const { return platform_heading_rad - wander_rad; }
};
static_assert(sizeof(SbetRecord) == 136, "an SBET record is 17 float64");

/// Reads an SBET file. Throws FileError naming the file for a size that is not a multiple of
/// 136 bytes (a corrupt or truncated file), for fewer than one record, and — naming the record
/// — for non-finite values or an out-of-range latitude.
std::vector<SbetRecord> readSbet(const std::string& path);

/// Writes an SBET file (atomically).
void writeSbet(const std::string& path, const std::vector<SbetRecord>& records);

/// One record of an SBET's accuracy file — Applanix POSPac's "smrmsg" (smoothed RMS error): no
/// header; records of 10 little-endian float64 — the time, the north, east and down position RMS
/// errors [m], the north, east and down velocity RMS errors [m/s], the roll, pitch and heading RMS
/// errors [arc minutes] (the layout NOAA's Kluster documents and reads, `HSTB/kluster` sbet.py).
struct SmrmsgRecord {
  double time_s;                                     ///< GPS seconds of week [s]
  double north_m, east_m, down_m;                    ///< position RMS errors [m]
  double v_north_mps, v_east_mps, v_down_mps;        ///< velocity RMS errors [m/s]
  double roll_arcmin, pitch_arcmin, heading_arcmin;  ///< attitude RMS errors [arc minutes]
};
static_assert(sizeof(SmrmsgRecord) == 80, "an smrmsg record is 10 float64");

/// Reads an smrmsg file, sorted by time (exporters do not always write it in order). Throws
/// FileError naming the file for a size that is not a multiple of 80 bytes or no record, and
/// naming the record for a value that is not finite or an RMS error that is negative or beyond
/// any GNSS/INS solution's (100 m, 600 arc minutes).
std::vector<SmrmsgRecord> readSmrmsg(const std::string& path);

/// Writes an smrmsg file (atomically).
void writeSmrmsg(const std::string& path, const std::vector<SmrmsgRecord>& records);

/// The accuracy along time that an smrmsg file states, for TrajectoryAccuracy::series: `time_offset_s`
/// added to every time (as sbetToTrajectory adds it), position σ along the tangent frame's east,
/// north and up, attitude σ about its horizontal axes the RMS of roll and pitch, about its vertical
/// the heading's (as TrajectoryAccuracy's constants are taken), in radians.
TrajectoryAccuracySeries smrmsgToAccuracy(const std::vector<SmrmsgRecord>& records, double time_offset_s = 0.0);

/// Reads the geodetic trajectory CSV of SPEC §4 (`time,lat_deg,lon_deg,h_m,roll_deg,
/// pitch_deg,heading_deg`) as SBET-like records (wander 0, rates and accelerations 0).
std::vector<SbetRecord> readGeodeticTrajectoryCsv(const std::string& path);

/// The SBET as a trajectory in the ENU tangent frame `frame` (R_mn per sample, true heading).
/// `time_offset_s` is added to every time. Throws FileError for unsorted or duplicate times.
Trajectory sbetToTrajectory(const std::string& path, const std::vector<SbetRecord>& records, const LocalTangentFrame& frame,
                            double time_offset_s = 0.0, PositionInterpolation interpolation = PositionInterpolation::kLinear);

}  // namespace mountcal::io
