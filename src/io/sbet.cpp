#include "mountcal/io/sbet.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>

#include "mountcal/core/error.hpp"
#include "mountcal/io/atomic_file.hpp"
#include "mountcal/io/csv.hpp"
#include "plausible.hpp"

namespace mountcal::io {

namespace {

/// Physical ranges of SBET-like records: attitudes, heights, and the speed between records
/// (positions to metres on a sphere of the Earth's mean radius — ample for this check).
void checkRecords(const std::vector<SbetRecord>& recs, const std::string& path, const std::function<std::string(std::size_t)>& where) {
  constexpr double R = 6371000.0;
  for (std::size_t i = 0; i < recs.size(); ++i) {
    const SbetRecord& s = recs[i];
    detail::checkAttitude(s.roll_rad, s.pitch_rad, s.platform_heading_rad, path, where(i));
    detail::checkAttitude(0.0, 0.0, s.wander_rad, path, where(i));
    if (!(std::abs(s.h_m) <= detail::kMaxAbsHeight))
      throw FileError(path, where(i), "height " + std::to_string(s.h_m) + " m is out of range");
    if (i > 0) {
      const SbetRecord& p = recs[i - 1];
      const Vec3 a(0, 0, p.h_m),
          b(R * (s.lat_rad - p.lat_rad), R * std::cos(s.lat_rad) * std::remainder(s.lon_rad - p.lon_rad, 2 * kPi), s.h_m);
      detail::checkSpeed(p.time_s, a, s.time_s, b, path, where(i));
    }
  }
}

/// The records of a headerless file of fixed-size records of float64 (`what`: "SBET", "smrmsg"),
/// refused naming the file when it cannot be read, is empty, or its size is no multiple of one.
template <typename Record>
std::vector<Record> readRecords(const std::string& path, const std::string& what, const std::string& not_one) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError(path, "", "cannot open the " + what + " file");
  in.seekg(0, std::ios::end);
  const std::streamoff end = in.tellg();
  // A pipe or a folder has no size: say so rather than print a bogus one.
  if (!in || end < 0) throw FileError(path, "", "cannot determine the file size (not a regular file?)");
  const auto size = static_cast<std::uint64_t>(end);
  in.seekg(0);
  constexpr std::uint64_t kSize = sizeof(Record);
  if (size % kSize != 0) {
    throw FileError(path, "byte " + std::to_string(size - size % kSize),
                    "size " + std::to_string(size) + " bytes is not a multiple of the " + std::to_string(kSize) + "-byte " + what +
                        " record: the file is truncated or not " + not_one);
  }
  if (size == 0) throw FileError(path, "", "empty " + what + " file");
  std::vector<Record> out(size / kSize);
  in.read(reinterpret_cast<char*>(out.data()), static_cast<std::streamsize>(size));
  if (!in) throw FileError(path, "", "read failed");
  return out;
}

}  // namespace

std::vector<SbetRecord> readSbet(const std::string& path) {
  std::vector<SbetRecord> out = readRecords<SbetRecord>(path, "SBET", "an SBET");
  for (std::size_t i = 0; i < out.size(); ++i) {
    const double* v = reinterpret_cast<const double*>(&out[i]);
    for (int k = 0; k < 17; ++k) {
      if (!std::isfinite(v[k])) throw FileError(path, "record " + std::to_string(i), "field " + std::to_string(k) + " is not finite");
    }
    if (std::abs(out[i].lat_rad) > kPi / 2 || std::abs(out[i].lon_rad) > 2 * kPi) {
      throw FileError(path, "record " + std::to_string(i), "latitude/longitude out of range (are they in radians?)");
    }
  }
  checkRecords(out, path, [](std::size_t i) { return "record " + std::to_string(i); });
  return out;
}

void writeSbet(const std::string& path, const std::vector<SbetRecord>& records) {
  writeFileAtomically(path, std::string(reinterpret_cast<const char*>(records.data()), records.size() * sizeof(SbetRecord)));
}

std::vector<SbetRecord> readGeodeticTrajectoryCsv(const std::string& path) {
  const CsvTable t = CsvTable::read(path);
  const std::size_t ct = t.column("time"), cla = t.column("lat_deg"), clo = t.column("lon_deg"), ch = t.column("h_m");
  const std::size_t cr = t.column("roll_deg"), cp = t.column("pitch_deg"), chd = t.column("heading_deg");
  std::vector<SbetRecord> out(t.rows());
  for (std::size_t r = 0; r < t.rows(); ++r) {
    SbetRecord& s = out[r];
    std::memset(&s, 0, sizeof s);
    s.time_s = t.number(r, ct);
    s.lat_rad = deg2rad(t.number(r, cla));
    s.lon_rad = deg2rad(t.number(r, clo));
    if (std::abs(s.lat_rad) > kPi / 2) throw FileError(path, "line " + std::to_string(t.lineOf(r)), "latitude out of range");
    s.h_m = t.number(r, ch);
    s.roll_rad = deg2rad(t.number(r, cr));
    s.pitch_rad = deg2rad(t.number(r, cp));
    s.platform_heading_rad = deg2rad(t.number(r, chd));
  }
  checkRecords(out, path, [&](std::size_t i) { return "line " + std::to_string(t.lineOf(i)); });
  return out;
}

Trajectory sbetToTrajectory(const std::string& path, const std::vector<SbetRecord>& records, const LocalTangentFrame& frame,
                            double time_offset_s, PositionInterpolation interpolation) {
  std::vector<TrajectorySample> samples(records.size());
  for (std::size_t i = 0; i < records.size(); ++i) {
    const SbetRecord& r = records[i];
    TrajectorySample& s = samples[i];
    s.time_s = r.time_s + time_offset_s;
    if (i > 0 && !(s.time_s > samples[i - 1].time_s)) {
      throw FileError(path, "record " + std::to_string(i),
                      "time is not after the previous record's: the trajectory must be sorted with no duplicate times");
    }
    s.p_m = frame.toLocal({r.lat_rad, r.lon_rad, r.h_m});
    s.R_mn = frame.R_mn(r.lat_rad, r.lon_rad);  // SPEC §2: curvature and convergence
    s.roll = r.roll_rad;
    s.pitch = r.pitch_rad;
    s.heading = r.trueHeading();
  }
  if (samples.size() < 2) throw FileError(path, "", "a trajectory needs at least 2 records");
  return Trajectory(std::move(samples), interpolation);
}

std::vector<SmrmsgRecord> readSmrmsg(const std::string& path) {
  std::vector<SmrmsgRecord> out = readRecords<SmrmsgRecord>(path, "smrmsg", "an SBET accuracy (smrmsg) file");
  static const char* const kFields[10] = {"time",          "north position", "east position", "down position", "north velocity",
                                          "east velocity", "down velocity",  "roll",          "pitch",         "heading"};
  for (std::size_t i = 0; i < out.size(); ++i) {
    const double* v = reinterpret_cast<const double*>(&out[i]);
    for (int k = 0; k < 10; ++k) {
      if (!std::isfinite(v[k])) throw FileError(path, "record " + std::to_string(i), std::string(kFields[k]) + " is not finite");
      // RMS errors: none negative; none beyond a GNSS/INS solution's (metres: 100; arc minutes: 600, i.e. 10°).
      const double limit = k >= 7 ? 600.0 : 100.0;
      if (k > 0 && !(v[k] >= 0 && v[k] <= limit)) {
        const char* unit = k >= 7 ? "arc minutes" : k >= 4 ? "m/s" : "m";
        throw FileError(path, "record " + std::to_string(i),
                        std::string(kFields[k]) + " RMS error " + std::to_string(v[k]) + " is not in [0, " +
                            std::to_string(static_cast<int>(limit)) + "] (" + unit + ")");
      }
    }
  }
  std::stable_sort(out.begin(), out.end(), [](const SmrmsgRecord& a, const SmrmsgRecord& b) { return a.time_s < b.time_s; });
  return out;
}

void writeSmrmsg(const std::string& path, const std::vector<SmrmsgRecord>& records) {
  writeFileAtomically(path, std::string(reinterpret_cast<const char*>(records.data()), records.size() * sizeof(SmrmsgRecord)));
}

TrajectoryAccuracySeries smrmsgToAccuracy(const std::vector<SmrmsgRecord>& records, double time_offset_s) {
  constexpr double kArcMinute = kPi / (180.0 * 60.0);
  TrajectoryAccuracySeries a;
  a.time_s.reserve(records.size());
  a.position_m.reserve(records.size());
  a.attitude_rad.reserve(records.size());
  for (const SmrmsgRecord& r : records) {
    a.time_s.push_back(r.time_s + time_offset_s);
    a.position_m.emplace_back(r.east_m, r.north_m, r.down_m);
    const double roll_pitch = std::sqrt(0.5 * (r.roll_arcmin * r.roll_arcmin + r.pitch_arcmin * r.pitch_arcmin));
    a.attitude_rad.push_back(kArcMinute * Vec3(roll_pitch, roll_pitch, r.heading_arcmin));
  }
  return a;
}

}  // namespace mountcal::io
