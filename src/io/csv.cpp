#include "mountcal/io/csv.hpp"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>

#include "mountcal/core/error.hpp"
#include "mountcal/io/atomic_file.hpp"
#include "plausible.hpp"

namespace mountcal::io {

namespace {

std::string trim(const std::string& s) {
  const auto a = s.find_first_not_of(" \t\r\n");
  if (a == std::string::npos) return "";
  const auto b = s.find_last_not_of(" \t\r\n");
  return s.substr(a, b - a + 1);
}

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::string cell;
  std::istringstream in(line);
  while (std::getline(in, cell, ',')) out.push_back(trim(cell));
  if (!line.empty() && line.back() == ',') out.push_back("");
  return out;
}

std::string lineRef(std::size_t line) { return "line " + std::to_string(line); }

}  // namespace

namespace {

/// True when `s` is well-formed UTF-8 (RFC 3629: no overlong forms, no surrogates, ≤ U+10FFFF).
bool validUtf8(const std::string& s) {
  const auto* p = reinterpret_cast<const unsigned char*>(s.data());
  const std::size_t n = s.size();
  for (std::size_t i = 0; i < n;) {
    const unsigned char c = p[i];
    std::size_t len;
    std::uint32_t cp;
    if (c < 0x80) {
      ++i;
      continue;
    }
    if ((c & 0xE0) == 0xC0)
      len = 2, cp = c & 0x1Fu;
    else if ((c & 0xF0) == 0xE0)
      len = 3, cp = c & 0x0Fu;
    else if ((c & 0xF8) == 0xF0)
      len = 4, cp = c & 0x07u;
    else
      return false;
    if (i + len > n) return false;
    for (std::size_t k = 1; k < len; ++k) {
      if ((p[i + k] & 0xC0) != 0x80) return false;
      cp = (cp << 6) | (p[i + k] & 0x3Fu);
    }
    if ((len == 2 && cp < 0x80) || (len == 3 && cp < 0x800) || (len == 4 && cp < 0x10000) || cp > 0x10FFFF ||
        (cp >= 0xD800 && cp <= 0xDFFF))
      return false;
    i += len;
  }
  return true;
}

constexpr std::size_t kMaxLineBytes = 1u << 20;  // no CSV line of mountcal's is near this

}  // namespace

CsvTable CsvTable::read(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw FileError(path, "", std::string("cannot open for reading: ") + std::strerror(errno));
  CsvTable t;
  t.path_ = path;
  std::vector<char> buffer(kMaxLineBytes + 1);
  std::size_t n = 0;
  // Lines are read with a bounded buffer: an endless stream without line breaks (/dev/zero)
  // is refused at its first megabyte instead of filling the memory.
  for (;;) {
    in.getline(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    const auto got = static_cast<std::size_t>(in.gcount());
    if (got == 0 && (in.eof() || in.fail())) break;
    ++n;
    if (in.fail() && !in.eof())
      throw FileError(path, lineRef(n), "longer than " + std::to_string(kMaxLineBytes) + " bytes: not a CSV file of mountcal's");
    std::string line(buffer.data(), in.eof() ? got : got - 1);                // without the line break
    if (n == 1 && line.compare(0, 3, "\xEF\xBB\xBF") == 0) line.erase(0, 3);  // a byte-order mark, as spreadsheets write
    if (!validUtf8(line)) throw FileError(path, lineRef(n), "not valid UTF-8 text");
    const std::string s = trim(line);
    if (!s.empty() && s[0] != '#') {
      if (t.header_.empty()) {
        t.header_ = split(s);
        for (const std::string& h : t.header_) {
          if (h.empty()) throw FileError(path, lineRef(n), "empty column name in the header");
          bool numeric = !h.empty();
          for (char c : h)
            numeric = numeric && (std::isdigit(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '+' || c == 'e');
          if (numeric)
            throw FileError(path, lineRef(n), "the first line must be a header naming the columns, got '" + s.substr(0, 60) + "'");
        }
      } else {
        std::vector<std::string> cells = split(s);
        if (cells.size() != t.header_.size()) {
          throw FileError(
              path, lineRef(n),
              "expected " + std::to_string(t.header_.size()) + " fields (as in the header), got " + std::to_string(cells.size()));
        }
        t.cells_.push_back(std::move(cells));
        t.lines_.push_back(n);
      }
    }
    if (in.eof()) break;
  }
  if (t.header_.empty()) throw FileError(path, "", "empty file: a header line is required");
  return t;
}

bool CsvTable::has(const std::string& column) const {
  for (const std::string& h : header_)
    if (h == column) return true;
  return false;
}

std::size_t CsvTable::column(const std::string& name) const {
  for (std::size_t i = 0; i < header_.size(); ++i)
    if (header_[i] == name) return i;
  std::string cols;
  for (const std::string& h : header_) cols += (cols.empty() ? "" : ",") + h;
  throw FileError(path_, "line 1", "missing column '" + name + "' (the header has " + cols + ")");
}

double CsvTable::number(std::size_t row, std::size_t col) const {
  const std::string& s = cells_[row][col];
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(s.c_str(), &end);
  if (s.empty() || end != s.c_str() + s.size() || errno == ERANGE || !std::isfinite(v)) {
    throw FileError(path_, lineRef(lines_[row]), "column '" + header_[col] + "': '" + s + "' is not a finite number");
  }
  return v;
}

long CsvTable::integer(std::size_t row, std::size_t col) const {
  const std::string& s = cells_[row][col];
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(s.c_str(), &end, 10);
  if (s.empty() || end != s.c_str() + s.size() || errno == ERANGE) {
    throw FileError(path_, lineRef(lines_[row]), "column '" + header_[col] + "': '" + s + "' is not an integer");
  }
  return v;
}

long CsvTable::integer(std::size_t row, std::size_t col, long lo, long hi) const {
  const long v = integer(row, col);
  if (v < lo || v > hi) {
    throw FileError(
        path_, lineRef(lines_[row]),
        "column '" + header_[col] + "': " + std::to_string(v) + " is outside [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  }
  return v;
}

Trajectory readTrajectoryCsv(const std::string& path, double time_offset_s, PositionInterpolation interpolation) {
  const CsvTable t = CsvTable::read(path);
  const std::size_t ct = t.column("time"), cx = t.column("x"), cy = t.column("y"), cz = t.column("z");
  const std::size_t cr = t.column("roll_deg"), cp = t.column("pitch_deg"), ch = t.column("heading_deg");
  std::vector<TrajectorySample> samples(t.rows());
  for (std::size_t r = 0; r < t.rows(); ++r) {
    TrajectorySample& s = samples[r];
    s.time_s = t.number(r, ct) + time_offset_s;
    s.p_m = Vec3(t.number(r, cx), t.number(r, cy), t.number(r, cz));
    s.roll = deg2rad(t.number(r, cr));
    s.pitch = deg2rad(t.number(r, cp));
    s.heading = deg2rad(t.number(r, ch));
    detail::checkAttitude(s.roll, s.pitch, s.heading, path, lineRef(t.lineOf(r)));
    if (r > 0 && !(s.time_s > samples[r - 1].time_s)) {
      throw FileError(path, lineRef(t.lineOf(r)),
                      "time is not after the previous record's: the trajectory must be sorted with no duplicate times");
    }
    if (r > 0) detail::checkSpeed(samples[r - 1].time_s, samples[r - 1].p_m, s.time_s, s.p_m, path, lineRef(t.lineOf(r)));
  }
  if (samples.size() < 2) throw FileError(path, "", "a trajectory needs at least 2 records");
  return Trajectory(std::move(samples), interpolation);
}

void writeTrajectoryCsv(const std::string& path, const Trajectory& trajectory) {
  std::string out = "time,x,y,z,roll_deg,pitch_deg,heading_deg\n";
  char line[256];
  for (const TrajectorySample& s : trajectory.samples()) {
    std::snprintf(line, sizeof line, "%.9f,%.6f,%.6f,%.6f,%.10f,%.10f,%.10f\n", s.time_s, s.p_m.x(), s.p_m.y(), s.p_m.z(), rad2deg(s.roll),
                  rad2deg(s.pitch), rad2deg(s.heading));
    out += line;
  }
  writeFileAtomically(path, out);
}

std::vector<TieObservation> readTiesCsv(const std::string& path) {
  const CsvTable t = CsvTable::read(path);
  const std::size_t ci = t.column("tie_id"), cs = t.column("strip_id"), cx = t.column("x"), cy = t.column("y");
  std::vector<TieObservation> out(t.rows());
  for (std::size_t r = 0; r < t.rows(); ++r) {
    out[r].tie_id = t.text(r, ci);
    out[r].strip_id = t.text(r, cs);
    if (out[r].tie_id.empty() || out[r].strip_id.empty()) throw FileError(path, lineRef(t.lineOf(r)), "empty tie_id or strip_id");
    out[r].x_m = t.number(r, cx);
    out[r].y_m = t.number(r, cy);
    out[r].line = t.lineOf(r);
  }
  // A tie is picked once per strip: a second pick, identical or metres away, would count twice.
  std::map<std::pair<std::string, std::string>, std::size_t> seen;
  for (const TieObservation& o : out) {
    const auto [it, fresh] = seen.emplace(std::make_pair(o.tie_id, o.strip_id), o.line);
    if (!fresh) {
      throw FileError(path, "lines " + std::to_string(it->second) + " and " + std::to_string(o.line),
                      "tie '" + o.tie_id + "' is picked twice on strip '" + o.strip_id + "'; keep one pick per tie and strip");
    }
  }
  return out;
}

void writeTiesCsv(const std::string& path, const std::vector<TieObservation>& ties) {
  std::string out = "tie_id,strip_id,x,y\n";
  char line[256];
  for (const TieObservation& o : ties) {
    std::snprintf(line, sizeof line, "%s,%s,%.4f,%.4f\n", o.tie_id.c_str(), o.strip_id.c_str(), o.x_m, o.y_m);
    out += line;
  }
  writeFileAtomically(path, out);
}

std::vector<PlaneRegion> readPlanesCsv(const std::string& path) {
  const CsvTable t = CsvTable::read(path);
  const std::size_t ci = t.column("plane_id"), c0 = t.column("xmin"), c1 = t.column("ymin"), c2 = t.column("xmax"), c3 = t.column("ymax");
  std::vector<PlaneRegion> out(t.rows());
  for (std::size_t r = 0; r < t.rows(); ++r) {
    out[r] = {t.text(r, ci), t.number(r, c0), t.number(r, c1), t.number(r, c2), t.number(r, c3), t.lineOf(r)};
    if (!(out[r].xmax > out[r].xmin) || !(out[r].ymax > out[r].ymin)) {
      throw FileError(path, lineRef(t.lineOf(r)), "xmax/ymax must be greater than xmin/ymin");
    }
    for (std::size_t k = 0; k < r; ++k)  // a region listed twice would be adjusted twice
      if (out[k].id == out[r].id)
        throw FileError(path, lineRef(t.lineOf(r)),
                        "region '" + out[r].id + "' is listed twice (also on line " + std::to_string(out[k].line) + ")");
  }
  return out;
}

void writePlanesCsv(const std::string& path, const std::vector<PlaneRegion>& planes) {
  std::string out = "plane_id,xmin,ymin,xmax,ymax\n";
  char line[256];
  for (const PlaneRegion& p : planes) {
    std::snprintf(line, sizeof line, "%s,%.3f,%.3f,%.3f,%.3f\n", p.id.c_str(), p.xmin, p.ymin, p.xmax, p.ymax);
    out += line;
  }
  writeFileAtomically(path, out);
}

std::vector<GroundControlPoint> readGcpCsv(const std::string& path) {
  const CsvTable t = CsvTable::read(path);
  const std::size_t ci = t.column("gcp_id"), cx = t.column("x"), cy = t.column("y"), cz = t.column("z");
  const std::size_t sxy = t.column("sigma_xy_m"), sz = t.column("sigma_z_m");
  std::vector<GroundControlPoint> out(t.rows());
  for (std::size_t r = 0; r < t.rows(); ++r) {
    out[r] = {t.text(r, ci), t.number(r, cx), t.number(r, cy), t.number(r, cz), t.number(r, sxy), t.number(r, sz)};
    if (!(out[r].sigma_xy_m > 0) || !(out[r].sigma_z_m > 0)) throw FileError(path, lineRef(t.lineOf(r)), "sigmas must be positive");
  }
  return out;
}

void writeGcpCsv(const std::string& path, const std::vector<GroundControlPoint>& gcps) {
  std::string out = "gcp_id,x,y,z,sigma_xy_m,sigma_z_m\n";
  char line[256];
  for (const GroundControlPoint& g : gcps) {
    std::snprintf(line, sizeof line, "%s,%.4f,%.4f,%.4f,%.4f,%.4f\n", g.id.c_str(), g.x_m, g.y_m, g.z_m, g.sigma_xy_m, g.sigma_z_m);
    out += line;
  }
  writeFileAtomically(path, out);
}

std::vector<RawPulse> readRawCsv(const std::string& path, SensorType type) {
  const CsvTable t = CsvTable::read(path);
  std::vector<RawPulse> out(t.rows());
  const std::size_t ct = t.column("time");
  const std::size_t ci = t.has("intensity") ? t.column("intensity") : static_cast<std::size_t>(-1);
  for (std::size_t r = 0; r < t.rows(); ++r) {
    RawPulse& p = out[r];
    p.time_s = t.number(r, ct);
    if (ci != static_cast<std::size_t>(-1)) p.intensity = static_cast<float>(t.number(r, ci));
    switch (type) {
      case SensorType::kLine:
        p.angle_rad = deg2rad(t.number(r, t.column("scan_angle_deg")));
        p.range_m = t.number(r, t.column("range_m"));
        break;
      case SensorType::kMultiBeam:
        p.laser_id = static_cast<int>(t.integer(r, t.column("laser_id"), 0, 65535));
        p.angle_rad = deg2rad(t.number(r, t.column("azimuth_deg")));
        p.range_m = t.number(r, t.column("range_m"));
        break;
      case SensorType::kVector:
        p.r_s = Vec3(t.number(r, t.column("xs")), t.number(r, t.column("ys")), t.number(r, t.column("zs")));
        p.range_m = p.r_s.norm();
        break;
    }
  }
  return out;
}

void writeRawCsv(const std::string& path, SensorType type, const std::vector<RawPulse>& pulses) {
  std::string out;
  out.reserve(pulses.size() * 56 + 64);
  out += type == SensorType::kLine        ? "time,scan_angle_deg,range_m,intensity\n"
         : type == SensorType::kMultiBeam ? "time,laser_id,azimuth_deg,range_m,intensity\n"
                                          : "time,xs,ys,zs,intensity\n";
  char line[256];
  for (const RawPulse& p : pulses) {
    if (type == SensorType::kLine) {
      std::snprintf(line, sizeof line, "%.9f,%.9f,%.6f,%.0f\n", p.time_s, rad2deg(p.angle_rad), p.range_m, p.intensity);
    } else if (type == SensorType::kMultiBeam) {
      std::snprintf(line, sizeof line, "%.9f,%d,%.9f,%.6f,%.0f\n", p.time_s, p.laser_id, rad2deg(p.angle_rad), p.range_m, p.intensity);
    } else {
      std::snprintf(line, sizeof line, "%.9f,%.6f,%.6f,%.6f,%.0f\n", p.time_s, p.r_s.x(), p.r_s.y(), p.r_s.z(), p.intensity);
    }
    out += line;
  }
  writeFileAtomically(path, out);
}

}  // namespace mountcal::io
