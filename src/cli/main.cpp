// mountcal — the command-line tool. Exit codes (SPEC §4): 0 success; 1 the solve ran but is
// not usable; 2 bad input, with one line on stderr naming the file and where it went wrong.
#include <CLI/CLI.hpp>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <string>

#include "mountcal/core/error.hpp"
#include "mountcal/report/error_curves.hpp"
#include "mountcal/io/crs.hpp"
#include "mountcal/io/las.hpp"
#include "mountcal/io/las_crs.hpp"
#include "mountcal/io/sbet.hpp"
#include "mountcal/io/atomic_file.hpp"
#include "mountcal/io/geotiff.hpp"
#include "mountcal/report/swath_qc.hpp"
#include "mountcal/job.hpp"
#include "mountcal/core/mounting_forms.hpp"
#include "mountcal/plan/planner.hpp"
#include "mountcal/report/report.hpp"
#include "mountcal/simulation/survey.hpp"
#include "mountcal/version.hpp"

namespace {

/// Progress for long steps, only when a person is watching stderr.
void progress(const char* what) {
  static const bool tty = ::isatty(2) != 0;
  if (tty) std::fprintf(stderr, "mountcal: %s\n", what);
}

int runSimulate(const std::string& scenario, const std::string& preset, std::uint64_t seed, const std::string& out, bool no_noise,
                const std::string& crs, bool no_ties, bool laz) {
  using namespace mountcal::simulation;
  SurveyConfig config;
  Scene scene;
  if (!scenario.empty()) {
    loadScenario(scenario, &config, &scene);
  } else {
    makePreset(preset, seed, &config, &scene);
  }
  if (no_noise) config.noise = NoiseModel::none();
  mountcal::SurveyWriteOptions write_options;
  write_options.crs = crs;
  write_options.ties = !no_ties;
  write_options.laz = laz;
  mountcal::checkSurveyWriteOptions(write_options);  // refused before the survey is simulated
  const auto t0 = std::chrono::steady_clock::now();
  const SimulatedSurvey survey = simulate(config, scene);
  const std::string empty = mountcal::stripWithoutPoints(survey);
  if (!empty.empty()) {  // nothing written: a survey without points calibrates nothing
    std::fprintf(stderr, "mountcal simulate: %s: strip %s has no point on the ground (check the mountings and the flight)\n",
                 scenario.empty() ? ("--preset " + preset).c_str() : scenario.c_str(), empty.c_str());
    return 1;
  }
  mountcal::writeSurvey(survey, out, write_options);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::size_t points = 0;
  for (const auto& s : survey.strips) points += s.points_m.size();
  std::printf("%s: %zu strips, %zu points, %zu tie observations, %zu check-point observations in %.1f s\n", config.name.c_str(),
              survey.strips.size(), points, survey.ties.size(), survey.check_points.size(), secs);
  std::printf("wrote %s/job.json and truth.json; run: mountcal calibrate %s/job.json\n", out.c_str(), out.c_str());
  (void)no_ties;
  return 0;
}

/// Notices for the user (deprecated job keys that were still read), printed on stderr when the
/// command ends without bad input (bad input gets its one line alone).
std::vector<std::string>& notices() {
  static std::vector<std::string> n;
  return n;
}
mountcal::Job readJobNoting(const std::string& path) {
  mountcal::Job job = mountcal::readJob(path);
  for (const std::string& n : job.notices) notices().push_back(path + ": " + n);
  return job;
}
int withNotices(int code) {
  for (const std::string& n : notices()) std::fprintf(stderr, "mountcal: notice: %s\n", n.c_str());
  return code;
}

/// "x0,y0,x1,y1[,width]" of --profile: four or five finite numbers, a line of positive length.
std::vector<mountcal::ReportOptions::ProfileLine> profileLines(const std::vector<std::string>& args) {
  std::vector<mountcal::ReportOptions::ProfileLine> out;
  for (const std::string& a : args) {
    const std::string expected = "--profile " + a + ": expected x0,y0,x1,y1[,width] in metres";
    std::vector<double> v;
    std::size_t pos = 0;
    while (true) {
      const std::size_t comma = a.find(',', pos);
      const std::string part = a.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos);
      char* end = nullptr;
      const double x = std::strtod(part.c_str(), &end);
      if (part.empty() || *end != '\0' || !std::isfinite(x)) throw mountcal::InvalidInput(expected + "; '" + part + "' is not a number");
      v.push_back(x);
      if (comma == std::string::npos) break;
      pos = comma + 1;
    }
    if (v.size() < 4 || v.size() > 5) throw mountcal::InvalidInput(expected + "; " + std::to_string(v.size()) + " numbers given");
    if (v.size() == 4) v.push_back(1.0);
    const double length = std::hypot(v[2] - v[0], v[3] - v[1]);
    if (!(length > 0) || length > 10000)
      throw mountcal::InvalidInput(expected + "; the line is " + std::to_string(length) + " m long (more than 0, at most 10 km)");
    if (!(v[4] > 0) || v[4] > 100) throw mountcal::InvalidInput(expected + "; the width must be in (0, 100] m");
    mountcal::ReportOptions::ProfileLine l;
    l.id = "profile_" + std::to_string(out.size() + 1);
    l.x0_m = v[0], l.y0_m = v[1], l.x1_m = v[2], l.y1_m = v[3], l.width_m = v[4];
    out.push_back(l);
  }
  return out;
}

int runCalibrate(const std::string& job_path, bool quiet, const std::string& report, const std::vector<std::string>& profiles,
                 const std::string& pair_dir, int threads, const std::string& result) {
  using namespace mountcal;
  Job job = readJobNoting(job_path);
  if (!report.empty()) job.report_path = report;
  if (!result.empty()) job.result_path = result;
  if (threads >= 0) job.options.threads = threads;
  ReportOptions ro;
  ro.title = "mountcal calibration — " + job_path;
  ro.profiles = profileLines(profiles);
  // The visual report shows the strips' points, which a solve from pair files does not read.
  if (!pair_dir.empty() && !report.empty())
    throw FileError(report, "",
                    "the visual report shows the strips' points, which a solve from pair files does not read; leave out --report");
  const bool report_skipped = !pair_dir.empty() && !job.report_path.empty();
  if (report_skipped) job.report_path.clear();
  // Before anything is computed: an output never replaces an input (a pair file included).
  std::vector<std::string> pair_inputs;
  if (!pair_dir.empty()) {
    pair_inputs = pairFilesIn(pair_dir);
    pair_inputs.push_back(pair_dir);
  }
  checkJobOutputs(job, pair_inputs);
  progress(pair_dir.empty() ? "reading the trajectory and strips" : "reading the trajectory and the pair files");
  const LoadedJob loaded = pair_dir.empty() ? loadJob(job) : loadJobFromPairFiles(job, pair_dir);
  const CalibrationData& data = loaded.data;
  progress("building the observations and solving");
  // Check data and the pass-to-pass discrepancy need the strips' points: not from pair files.
  const JobCalibration run = calibrateJob(job, loaded, pair_dir.empty());
  const MountingCalibrator::Summary& summary = run.summary;
  const ResultEvaluation& ev = run.evaluation;
  const bool any_eval = ev.any();
  std::vector<std::pair<std::string, std::string>> outputs;  // written all or nothing
  if (!job.result_path.empty()) outputs.emplace_back(job.result_path, run.result_json);
  if (!job.report_path.empty()) outputs.emplace_back(job.report_path, visualReport(summary, data, any_eval ? &ev : nullptr, ro));
  io::writeFilesAtomically(outputs);
  if (!quiet) std::printf("%s", summary.FullReport().c_str());
  if (!job.result_path.empty() && !quiet) std::printf("wrote %s\n", job.result_path.c_str());
  if (report_skipped && !quiet)
    std::printf("no report: a solve from pair files does not read the strips' points (run calibrate on the whole job for it)\n");
  if (!summary.IsSolutionUsable()) {
    std::fprintf(stderr, "mountcal calibrate: the solve is not usable: %s (%s)\n", toString(summary.termination), summary.message.c_str());
    return 1;
  }
  const MountingCalibrator::Verdict verdict = summary.verdict();
  if (verdict.kind == MountingCalibrator::Verdict::Kind::kReject) {
    std::string why;
    for (const std::string& r : verdict.reasons) why += (why.empty() ? "" : "; ") + r;
    std::fprintf(stderr, "mountcal calibrate: the calibration should not be used: %s\n", why.c_str());
    return 1;
  }
  return 0;
}

int runApply(const std::string& job_path, const std::string& result_path, const std::string& out, const std::string& format,
             const std::vector<std::string>& only_strips, int threads) {
  using namespace mountcal;
  Job job = readJobNoting(job_path);
  std::vector<std::string> other_inputs{result_path};
  if (!only_strips.empty()) {
    // The files of the named strips (with every strip split from them); the others stay inputs.
    std::vector<JobStrip> keep;
    for (const std::string& id : only_strips) {
      const auto it = std::find_if(job.strips.begin(), job.strips.end(), [&](const JobStrip& js) { return js.id == id; });
      if (it == job.strips.end()) throw FileError(job_path, "field 'strips'", "no strip '" + id + "' (--strip)");
    }
    for (const JobStrip& js : job.strips) {
      bool take = false;
      for (const std::string& id : only_strips)
        for (const JobStrip& named : job.strips)
          if (named.id == id && io::samePath(named.path, js.path)) take = true;
      if (take)
        keep.push_back(js);
      else
        other_inputs.push_back(js.path);
    }
    job.strips = keep;
  }
  const MountingParameters m = readResultMounting(result_path, job.mounting_used.R_nom);
  const LaserCorrections lasers = readResultLaserCorrections(result_path);
  progress("rewriting the strips");
  const StripFormat f = format == "las" ? StripFormat::las : format == "laz" ? StripFormat::laz : StripFormat::same_as_input;
  const ApplyStats st = applyMounting(job, m, out, 1u << 20, lasers, f, other_inputs, threads < 0 ? 0 : threads);
  std::printf(
      "applied lever arm (%.4f, %.4f, %.4f) m, boresight (%.5f, %.5f, %.5f) deg to %zu files, %llu points; "
      "largest shift %.3f m; wrote %s\n",
      m.a_b.x(), m.a_b.y(), m.a_b.z(), m.boresightDeg().x(), m.boresightDeg().y(), m.boresightDeg().z(), st.strips,
      static_cast<unsigned long long>(st.points), st.max_shift_m, out.c_str());
  return 0;
}

/// One group of the discrepancy breakdown (DiscrepancyBreakdown), before and after, by class.
void printBreakdown(const mountcal::DiscrepancyGroupChange& g) {
  if (g.classes.empty()) return;
  std::printf("  by %s:\n    %-24s %8s %8s   median before/after [m]   P90 before/after [m]\n", g.title.c_str(), "class", "points", "used");
  for (const mountcal::DiscrepancyClassChange& c : g.classes)
    std::printf("    %-24s %8zu %8zu   %8.4f %8.4f         %8.4f %8.4f\n", c.label.c_str(), c.after.queries, c.after.used,
                c.before.median_m, c.after.median_m, c.before.p90_m, c.after.p90_m);
}

int runEvaluate(const std::string& job_path, const std::string& result_path, const std::string& report,
                const std::vector<std::string>& profiles) {
  using namespace mountcal;
  Job job = readJobNoting(job_path);
  ReportOptions ro;
  ro.title = "mountcal evaluation — " + result_path + " on " + job_path;
  ro.profiles = profileLines(profiles);
  if (!report.empty()) {  // the only output of evaluate: never an input, the result file included
    job.result_path.clear();
    job.report_path = report;
    checkJobOutputs(job, {result_path});
  }
  const LoadedJob loaded = loadJob(job);
  const MountingParameters m = readResultMounting(result_path, job.mounting_used.R_nom);
  const ResultEvaluation ev = evaluateJob(job, loaded, m, true, readResultLaserCorrections(result_path));
  if (!ev.any()) {
    std::fprintf(stderr, "mountcal evaluate: %s: the job names no check_points or check_planes, and no strips overlap\n", job_path.c_str());
    return 2;
  }
  if (!report.empty()) {
    // No solve here: the report shows the result's mounting against the job's, and the data.
    MountingCalibrator::Summary summary;
    summary.termination = TerminationType::kConvergence;
    summary.message = "evaluation of " + result_path + " (no adjustment: no σ, correlations or residuals)";
    summary.mounting_used = loaded.data.mounting_used;
    summary.mounting = m;
    summary.estimated.fill(true);
    summary.sigma.fill(std::nan(""));
    io::writeFilesAtomically({{report, visualReport(summary, loaded.data, &ev, ro)}});
  }
  if (!ev.discrepancy_after.empty()) {
    const DiscrepancyOptions d;
    std::printf(
        "pass-to-pass discrepancy (each point of the smaller strip against the local plane of the larger's %d nearest:\n"
        "  nearest within %.2f m, plane sigma <= %.3f m, sqrt(l_mid/l_max) >= %.2f, extent <= %.2f m;\n"
        "  for a sparse larger strip of spacing s, nearest within 3 s and extent <= 1.5 s sqrt(k/pi) where larger):\n",
        d.neighbours, d.max_neighbour_distance_m, d.max_plane_sigma_m, d.min_spread_ratio, d.max_extent_m);
    std::printf("  %-12s %-12s %8s %8s   median  before/after [m]     RMS before/after [m]     P90 before/after [m]\n", "query",
                "reference", "points", "used");
    for (const PairDiscrepancy& a : ev.discrepancy_after) {
      DiscrepancyStats b;
      for (const PairDiscrepancy& x : ev.discrepancy_before)
        if (x.query == a.query && x.reference == a.reference) b = x.stats;
      std::printf("  %-12s %-12s %8zu %8zu   %8.4f %8.4f        %8.4f %8.4f        %8.4f %8.4f\n", a.query.c_str(), a.reference.c_str(),
                  a.stats.queries, a.stats.used, b.median_m, a.stats.median_m, b.rms_m, a.stats.rms_m, b.p90_m, a.stats.p90_m);
    }
    std::printf("where the discrepancy lies (the used points of every pair; tilt: the reference surface's normal from the vertical):\n");
    for (const mountcal::DiscrepancyGroupChange& g : mountcal::compareBreakdowns(ev.breakdown_before, ev.breakdown_after))
      printBreakdown(g);
  }
  if (ev.has_check_points) {
    const auto &b = ev.check_points_before, &a = ev.check_points_after;
    std::printf("check points: %zu observations (%zu rejected)\n", a.residuals.size(), a.rejected.size());
    std::printf("  RMS before (%.4f, %.4f, %.4f) m\n  RMS after  (%.4f, %.4f, %.4f) m\n", b.rms_m.x(), b.rms_m.y(), b.rms_m.z(),
                a.rms_m.x(), a.rms_m.y(), a.rms_m.z());
  }
  if (!ev.check_planes_after.empty()) {
    const auto &b = ev.check_planes_before, &a = ev.check_planes_after;
    std::printf("check planes (RMS = sqrt(sum d^2/(n-3)), seed eq. 13):\n");
    for (std::size_t i = 0; i < a.size(); ++i)
      std::printf("  %-12s %7d points  before %.4f m  after %.4f m\n", a[i].plane_id.c_str(), a[i].points, b[i].rms_m, a[i].rms_m);
  }
  return 0;
}

/// The extra-bytes data type's name (LAS 1.4 R15 table 24).
std::string extraBytesTypeName(const mountcal::io::ExtraBytesAttribute& a) {
  static const char* kBase[] = {"bytes", "uint8", "int8", "uint16", "int16", "uint32", "int32", "uint64", "int64", "float", "double"};
  if (a.data_type == 0) return std::to_string(a.size) + " undocumented bytes";
  const int base = a.data_type <= 10 ? a.data_type : (a.data_type - 1) % 10 + 1;
  return std::string(kBase[base]) + (a.elements > 1 ? "[" + std::to_string(a.elements) + "]" : "");
}

/// The LASzip VLR and chunk table of a LAZ file.
void printLaz(const mountcal::io::LasReader& r) {
  using namespace mountcal;
  const io::LazVlr* z = r.laz();
  if (!z) return;
  static const char* kCompressor[] = {"none", "point-wise", "point-wise chunked", "layered chunked"};
  std::string items;
  for (const io::LazItem& it : z->items)
    items += (items.empty() ? "" : ", ") + io::lazItemName(it.type) + "(" + std::to_string(it.size) + ") v" + std::to_string(it.version);
  std::printf("  LAZ: compressor %d (%s), LASzip %d.%d r%d%s; items %s\n", z->compressor, kCompressor[z->compressor], z->version_major,
              z->version_minor, z->version_revision, (z->options & 1) ? ", LAS 1.4 compatibility mode" : "", items.c_str());
  const auto& chunks = r.lazChunks();
  std::uint64_t bytes = 0;
  for (const auto& c : chunks) bytes += c.bytes;
  if (z->compressor == 1)
    std::printf("  one stream of %llu bytes (no chunks)\n", static_cast<unsigned long long>(bytes));
  else if (z->variableChunks())
    std::printf("  %zu chunks of variable size, %llu bytes\n", chunks.size(), static_cast<unsigned long long>(bytes));
  else
    std::printf("  %zu chunks of %u points, %llu bytes\n", chunks.size(), z->chunk_size, static_cast<unsigned long long>(bytes));
}

/// The CRS, the VLRs and EVLRs, and the extra-bytes attributes of a LAS header.
void printLasRecords(const mountcal::io::LasHeader& h, const std::string& path) {
  using namespace mountcal;
  const io::LasCrs crs = io::lasCrs(h, path);
  std::printf("  CRS: %s\n", crs.summary().c_str());
  for (const io::GeoKey& k : crs.geo_keys) {
    std::printf("    GeoTIFF %-24s ", k.name().c_str());
    if (k.location == 34737)
      std::printf("'%s'\n", k.text.c_str());
    else if (k.location == 34736)
      std::printf("%s\n", k.numbers.empty() ? "" : std::to_string(k.numbers[0]).c_str());
    else
      std::printf("%u\n", k.value);
  }
  for (const auto& v : h.vlrs)
    std::printf("  VLR %s/%d: %s (%zu bytes)\n", v.user_id.c_str(), v.record_id, v.description.c_str(), v.data.size());
  for (const auto& v : h.evlrs)
    std::printf("  EVLR %s/%d: %s (%zu bytes)\n", v.user_id.c_str(), v.record_id, v.description.c_str(), v.data.size());
  for (const auto& a : io::extraBytesAttributes(h, path)) {
    std::printf("  extra bytes: %-24s %-10s bytes %zu-%zu", a.name.c_str(), extraBytesTypeName(a).c_str(), a.byte_offset,
                a.byte_offset + a.size - 1);
    if (a.hasScale()) std::printf(", scale %g", a.scale[0]);
    if (a.hasOffset()) std::printf(", offset %g", a.offset[0]);
    std::printf("%s\n", a.description.empty() ? "" : (" — " + a.description).c_str());
  }
}

/// Time and scan-angle ranges, points by class and by return number, from every record.
void printLasStatistics(mountcal::io::LasReader& r) {
  using namespace mountcal;
  const io::LasHeader& h = r.header();
  double t0 = 1e300, t1 = -1e300, a0 = 1e300, a1 = -1e300;
  std::map<int, std::uint64_t> by_class, by_return;
  std::vector<io::LasPoint> chunk;
  while (r.read(&chunk) > 0) {
    for (const auto& p : chunk) {
      t0 = std::min(t0, p.gps_time);
      t1 = std::max(t1, p.gps_time);
      a0 = std::min(a0, io::scanAngleDeg(h, p));
      a1 = std::max(a1, io::scanAngleDeg(h, p));
      ++by_class[h.point_format >= 6 ? p.classification : (p.classification & 31)];
      ++by_return[p.return_number];
    }
  }
  if (h.point_count == 0) return;
  if (h.hasGpsTime())
    std::printf("  time [%.6f, %.6f] s, scan angle [%.3f, %.3f] deg\n", t0, t1, a0, a1);
  else
    std::printf("  scan angle [%.3f, %.3f] deg\n", a0, a1);
  std::printf("  points by class:");
  for (const auto& [c, n] : by_class) std::printf(" %d: %llu", c, static_cast<unsigned long long>(n));
  std::printf("\n  points by return number:");
  for (const auto& [c, n] : by_return) std::printf(" %d: %llu", c, static_cast<unsigned long long>(n));
  std::printf("\n");
}

int runInfo(const std::string& path) {
  using namespace mountcal;
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw FileError(path, "", "is a folder; info reads one LAS, LAZ or SBET file");
  std::string ext = path.size() >= 4 ? path.substr(path.size() - 4) : "";
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  if (ext == ".las" || ext == ".laz") {
    io::LasReader r(path);
    const io::LasHeader& h = r.header();
    std::printf("%s: LAS %d.%d, point format %d (%d bytes, %d extra), %llu points\n", path.c_str(), h.version_major, h.version_minor,
                h.point_format, h.point_record_length, h.extraBytesPerPoint(), static_cast<unsigned long long>(h.point_count));
    std::printf("  scale (%g, %g, %g), offset (%.3f, %.3f, %.3f)\n", h.scale[0], h.scale[1], h.scale[2], h.offset[0], h.offset[1],
                h.offset[2]);
    std::printf("  bounds x [%.3f, %.3f] y [%.3f, %.3f] z [%.3f, %.3f]\n", h.min[0], h.max[0], h.min[1], h.max[1], h.min[2], h.max[2]);
    std::printf("  GPS time: %s\n",
                h.hasGpsTime() ? (h.adjustedStandardGpsTime() ? "adjusted standard GPS time" : "GPS week seconds") : "none");
    printLaz(r);
    printLasRecords(h, path);
    printLasStatistics(r);
    return 0;
  }
  const auto rec = io::readSbet(path);
  double lat0 = 1e9, lat1 = -1e9, lon0 = 1e9, lon1 = -1e9, h0 = 1e9, h1 = -1e9;
  for (const auto& r : rec) {
    lat0 = std::min(lat0, r.lat_rad), lat1 = std::max(lat1, r.lat_rad);
    lon0 = std::min(lon0, r.lon_rad), lon1 = std::max(lon1, r.lon_rad);
    h0 = std::min(h0, r.h_m), h1 = std::max(h1, r.h_m);
  }
  const double span = rec.back().time_s - rec.front().time_s;
  std::printf("%s: SBET, %zu records, time [%.6f, %.6f] s (%.1f Hz)\n", path.c_str(), rec.size(), rec.front().time_s, rec.back().time_s,
              span > 0 ? static_cast<double>(rec.size() - 1) / span : 0.0);
  std::printf("  latitude [%.7f, %.7f] deg, longitude [%.7f, %.7f] deg, height [%.3f, %.3f] m\n", rad2deg(lat0), rad2deg(lat1),
              rad2deg(lon0), rad2deg(lon1), h0, h1);
  return 0;
}

/// LAS to LAZ and back by the output's extension: every point record, VLR and EVLR kept; the
/// header changes only where compression requires (the format's compression bit, offsets, the
/// LASzip VLR).
int runConvert(const std::string& in, const std::string& out) {
  using namespace mountcal;
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::exists(out, ec) && fs::equivalent(in, out, ec)) throw FileError(out, "", "is the input; convert writes a new file");
  std::string ext = fs::path(out).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext != ".las" && ext != ".laz")
    throw FileError(out, "", "the output's extension chooses the format: .las or .laz (not '" + ext + "')");
  io::LasReader reader(in);
  io::LasWriter writer(out, reader.header());
  writer.keepHeaderStatistics();
  std::vector<std::uint8_t> records;
  std::size_t n;
  while ((n = reader.readRaw(&records, 1u << 18)) > 0) writer.writeRaw(records.data(), n);
  writer.close();
  const auto in_size = fs::file_size(in, ec), out_size = fs::file_size(out, ec);
  std::printf("%s -> %s: %llu points, %s, %llu -> %llu bytes (%.1f %%)\n", in.c_str(), out.c_str(),
              static_cast<unsigned long long>(reader.header().point_count), writer.compressed() ? "LAZ" : "LAS",
              static_cast<unsigned long long>(in_size), static_cast<unsigned long long>(out_size),
              in_size ? 100.0 * static_cast<double>(out_size) / static_cast<double>(in_size) : 0.0);
  return 0;
}

int runCurves(const std::string& out, double delta_deg) {
  using namespace mountcal;
  std::vector<double> angles, ranges{500, 1000, 1500, 2000};
  for (int a = -45; a <= 45; ++a) angles.push_back(deg2rad(a));
  const auto samples = boresightErrorCurves(Vec3::Constant(deg2rad(delta_deg)), angles, ranges);
  if (out.empty()) {
    std::printf("%s", errorCurvesCsv(samples).c_str());
    return 0;
  }
  writeErrorCurves(out, samples, delta_deg);
  std::printf("wrote %s/fig_errors.csv, fig1_x.svg, fig2_y.svg, fig3_z.svg\n", out.c_str());
  return 0;
}

/// The strip pairs to match, one per line: "A<TAB>B" (stdout, or --out written atomically).
int runPairs(const std::string& job_path, const std::string& out) {
  using namespace mountcal;
  const Job job = readJobNoting(job_path);
  if (!out.empty()) {
    for (const std::string& in : jobInputPaths(job))
      if (io::samePath(out, in)) throw FileError(out, "", "is an input of the job (" + in + "); pairs --out writes a new file");
  }
  std::string text;
  for (const auto& [a, b] : jobStripPairs(job)) text += a + "\t" + b + "\n";
  if (out.empty())
    std::fputs(text.c_str(), stdout);
  else
    io::writeFileAtomically(out, text);
  return 0;
}

/// One pair's candidate neighbourhoods into a pair file.
int runMatch(const std::string& job_path, const std::vector<std::string>& pair, const std::string& out) {
  using namespace mountcal;
  const Job job = readJobNoting(job_path);
  for (const std::string& in : jobInputPaths(job))
    if (io::samePath(out, in)) throw FileError(out, "", "is an input of the job (" + in + "); match --out writes a new file");
  const auto t0 = std::chrono::steady_clock::now();
  const PairCandidates p = jobPairCandidates(job, pair[0], pair[1]);
  writePairCandidates(out, p, job.options.method<CorrespondenceOptions>(), job.mounting_used.toArray());
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("%s / %s: %s, %zu samples (%d sparse), %zu + %zu points in %.2f s; wrote %s\n", p.strip_a.c_str(), p.strip_b.c_str(),
              p.overlap ? "overlap" : "no overlap", p.samples(), p.sparse_samples, p.samples_a.size(), p.points_b.size(), secs,
              out.c_str());
  return 0;
}

int runPlan(const std::string& plan_path, const std::string& report_path, bool no_candidates) {
  using namespace mountcal;
  if (!report_path.empty() && io::samePath(report_path, plan_path))
    throw FileError(report_path, "", "is the plan file; --report writes a new file");
  const plan::Plan p = plan::readPlan(plan_path);
  progress("simulating the plan and its candidate additions");
  plan::PlannerOptions opts;
  opts.try_candidates = !no_candidates;
  const plan::PlanAnalysis a = plan::analysePlan(p, opts);
  if (!report_path.empty()) io::writeFilesAtomically({{report_path, plan::planReportHtml(p, a)}});
  std::printf("plan %s: %zu lines, methods", p.name.c_str(), p.lines.size());
  for (const std::string& m : p.options.methods) std::printf(" %s", m.c_str());
  std::printf("\n%s", a.text().c_str());
  if (!report_path.empty()) std::printf("wrote %s\n", report_path.c_str());
  return 0;
}

/// A subcommand and what runs it once its options are parsed.
struct Command {
  CLI::App* app = nullptr;
  std::function<int()> run;
};

Command addMethods(CLI::App& app) {
  CLI::App* c =
      app.add_subcommand("methods", "The calibration methods: what each observes, its job input and its options with defaults and units");
  return {c, [] {
            std::printf("%s", mountcal::describeMethods().c_str());
            return 0;
          }};
}

Command addMounting(CLI::App& app) {
  struct Args {
    std::string result, job;
    bool json = false;
  };
  auto a = std::make_shared<Args>();
  CLI::App* c = app.add_subcommand("mounting",
                                   "A result's mounting in other programs' forms: forward-right-down and forward-left-up axes, degrees and "
                                   "radians, matrices and quaternions");
  c->add_option("result", a->result, "Result JSON file of mountcal calibrate")->required();
  c->add_option("--job", a->job, "The job, for the sensor's nominal rotation in R_bs (default: none)");
  c->add_flag("--json", a->json, "Write JSON instead of text");
  return {c, [a] {
            using namespace mountcal;
            Mat3 R_nom = Mat3::Identity();
            if (!a->job.empty())
              R_nom = MountingParameters::fromDegrees(Vec3::Zero(), Vec3::Zero(), readJobNoting(a->job).nominal_rotation_deg).R_nom;
            const MountingParameters m = readResultMounting(a->result, R_nom);
            const LaserCorrections lasers = readResultLaserCorrections(a->result);
            std::printf("%s", (a->json ? mountingFormsJson(m, lasers) : mountingFormsText(m, lasers)).c_str());
            return withNotices(0);
          }};
}

Command addSimulate(CLI::App& app) {
  struct Args {
    std::string scenario, preset, out, crs;
    std::uint64_t seed = 1;
    bool no_noise = false, no_ties = false, laz = false;
  };
  auto a = std::make_shared<Args>();
  CLI::App* c = app.add_subcommand("simulate", "Simulate a survey with known mounting truth (SPEC §4)");
  c->add_option("scenario", a->scenario, "Scenario JSON file (a preset with overrides)");
  std::string presets;
  for (const std::string& n : mountcal::simulation::presetNames()) presets += (presets.empty() ? "" : ", ") + n;
  c->add_option("--preset", a->preset, "Preset: " + presets + " (12 strips), block-N (N strips, N even from 4 to 256)");
  c->add_option("--seed", a->seed, "Random seed for the noise")->capture_default_str();
  c->add_option("--out", a->out, "Output folder")->required();
  c->add_flag("--no-noise", a->no_noise, "Switch every noise source off");
  c->add_flag("--no-ties", a->no_ties, "Write no ties file: the job calibrates automatically (method \"correspondences\")");
  c->add_option("--crs", a->crs, "Write the survey in this CRS (e.g. EPSG:32611) with an SBET trajectory");
  c->add_flag("--laz", a->laz, "Write the strips as LAZ (strip_ID.laz)");
  return {c, [a] {
            if (a->scenario.empty() == a->preset.empty()) {
              std::fprintf(stderr, "mountcal simulate: give either a SCENARIO file or --preset NAME\n");
              return 2;
            }
            return runSimulate(a->scenario, a->preset, a->seed, a->out, a->no_noise, a->crs, a->no_ties, a->laz);
          }};
}

Command addCalibrate(CLI::App& app) {
  struct Args {
    std::string job, report, pair_dir, result;
    std::vector<std::string> profiles;
    bool quiet = false;
    int threads = -1;
  };
  auto a = std::make_shared<Args>();
  CLI::App* c = app.add_subcommand("calibrate", "Calibrate the mounting from a job file (SPEC §4); writes the result file");
  c->add_option("job", a->job, "Job JSON file")->required();
  c->add_flag("--quiet", a->quiet, "Print nothing on success");
  c->add_option("--report", a->report, "Write the visual HTML report here (instead of the job's output.report)");
  c->add_option("--profile", a->profiles, "A profile for the report: x0,y0,x1,y1[,width] in metres (repeatable)");
  c->add_option("--result", a->result, "Write the result file here (instead of the job's output.result)");
  c->add_option("--correspondences", a->pair_dir,
                "Solve from the pair files (*.mcpair) of mountcal match in this folder instead of searching the strips");
  c->add_option(
       "--threads", a->threads,
       "Threads for building the observations: correspondence search, VTPM construction (default: every core); results do not depend on it")
      ->check(CLI::Range(1, 4096));
  return {c, [a] { return withNotices(runCalibrate(a->job, a->quiet, a->report, a->profiles, a->pair_dir, a->threads, a->result)); }};
}

Command addApply(CLI::App& app) {
  struct Args {
    std::string job, result, out, format;
    std::vector<std::string> strips;
    int threads = -1;
  };
  auto a = std::make_shared<Args>();
  CLI::App* c = app.add_subcommand("apply", "Rewrite the job's LAS strips with the calibrated mounting");
  c->add_option("job", a->job, "Job JSON file")->required();
  c->add_option("--result", a->result, "Result JSON file of mountcal calibrate")->required();
  c->add_option("--out", a->out, "Output folder (the strips keep their file names)")->required();
  c->add_option("--format", a->format, "las or laz: write this format whatever the input's (default: the input's)")
      ->check(CLI::IsMember({"las", "laz"}));
  c->add_option("--strip", a->strips, "Rewrite only the file of this strip (repeatable; a workflow's per-strip job)");
  c->add_option("--threads", a->threads, "Files rewritten at once (default: every core)")->check(CLI::Range(1, 4096));
  return {c, [a] { return withNotices(runApply(a->job, a->result, a->out, a->format, a->strips, a->threads)); }};
}

/// A strip id as a file-name part: letters, digits, '-' and '_' kept, anything else '_'.
std::string fileNamePart(const std::string& id) {
  std::string out;
  for (char c : id) out += (std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_') ? c : '_';
  return out.empty() ? std::string("_") : out;
}

int runQc(const std::string& job_path, const std::string& result_path, const std::string& out, double cell,
          const std::vector<std::string>& pair, bool print_cell) {
  using namespace mountcal;
  namespace fs = std::filesystem;
  Job job = readJobNoting(job_path);
  if (!print_cell) {
    if (out.empty()) throw FileError(job_path, "", "mountcal qc needs --out (or --print-cell)");
    if (!fs::is_directory(out)) {
      std::fprintf(stderr, "mountcal qc: %s: the output folder does not exist\n", out.c_str());
      return 2;
    }
  }
  std::vector<std::string> inputs = jobInputPaths(job);
  if (!result_path.empty()) inputs.push_back(result_path);
  if (!pair.empty()) job = jobWithStrips(job, pair);
  const LoadedJob loaded = loadJob(job);
  // The points in the job's frame (a CRS job's rasters are in its CRS).
  auto inJobFrame = [&](std::vector<std::vector<Vec3>> x) {
    if (!loaded.frame.isLocal())
      for (auto& strip : x)
        for (Vec3& p : strip) p = loaded.frame.fromLocal(p);
    return x;
  };
  const MountingParameters before = loaded.data.mounting_used;
  const std::vector<std::vector<Vec3>> xb = inJobFrame(georeferencedStrips(loaded.data, before));
  if (print_cell) {  // the cell of the QC of these strips, for a block's pairs measured one by one
    std::printf("%.17g\n", swathQcCellSize(xb));
    return 0;
  }
  const MountingParameters after = result_path.empty() ? before : readResultMounting(result_path, job.mounting_used.R_nom);
  SwathQcOptions o;
  o.cell_size_m = cell;
  std::vector<std::string> ids;
  for (const StripData& st : loaded.data.strips) ids.push_back(st.id);
  // After: with the result's per-laser intrinsics, as apply writes the strips.
  const std::vector<std::vector<Vec3>> xa = inJobFrame(
      georeferencedStrips(loaded.data, after, result_path.empty() ? LaserCorrections{} : readResultLaserCorrections(result_path)));
  const SwathQcResult qc = swathQcOfPoints(ids, xb, xa, o);
  if (qc.pairs.empty() && pair.empty()) {  // one pair of a block's (--pair): no overlap is an answer, not an error
    std::fprintf(stderr, "mountcal qc: %s: no two strips share a smooth open cell of %.3g m or a sloped planar one of %.3g m\n",
                 job_path.c_str(), qc.cell_size_m, qc.plane_cell_size_m);
    return 1;
  }
  // Every output is written under a temporary name, then all are placed together.
  std::vector<std::pair<std::string, std::string>> placed;
  auto target = [&](const std::string& name) {
    const std::string path = (fs::path(out) / name).string();
    for (const std::string& in : inputs)
      if (io::samePath(in, path)) throw FileError(path, "output", "would overwrite an input of the job");
    return path;
  };
  try {
    for (const PairQc& p : qc.pairs) {
      const std::string stem = "dz_" + fileNamePart(p.a) + "_" + fileNamePart(p.b);
      if (p.raster_before.nx > 0)
        placed.push_back({io::writeGeoTiff(target(stem + "_before.tif"), p.raster_before, job.crs, false), target(stem + "_before.tif")});
      if (p.raster_after.nx > 0)
        placed.push_back({io::writeGeoTiff(target(stem + "_after.tif"), p.raster_after, job.crs, false), target(stem + "_after.tif")});
    }
    for (const auto& [name, text] :
         {std::pair<std::string, std::string>{"qc.json", swathQcJson(qc)},
          {"qc.html", swathQcHtml(qc, "mountcal swath QC — " + job_path + (result_path.empty() ? "" : " with " + result_path))}}) {
      const std::string path = target(name), tmp = path + ".tmp-mountcal";
      io::writeFileAtomically(tmp, text);
      placed.push_back({tmp, path});
    }
  } catch (...) {
    for (const auto& pt : placed) std::remove(pt.first.c_str());
    throw;
  }
  io::placeFilesAtomically(placed);
  std::printf("swath QC, cells of %.3g m (smooth: slope <= %.0f deg, roughness <= %.3f m, >= %d points per strip):\n", qc.cell_size_m,
              o.max_slope_deg, o.max_roughness_m, o.min_points);
  std::printf("  %-24s %8s %10s %10s %10s\n", "pair", "cells", "RMSDz [m]", "mean [m]", "max|dZ| [m]");
  auto row = [](const std::string& what, const DzStats& st) {
    std::printf("  %-24s %8zu %10.4f %+10.4f %10.4f\n", what.c_str(), st.cells, st.rmsdz_m, st.mean_dz_m, st.max_abs_dz_m);
  };
  row("all, before", qc.overall_before);
  row("all, after", qc.overall_after);
  for (const PairQc& p : qc.pairs) row(p.a + "-" + p.b + ", after", p.after);
  if (qc.sloped_planes_before.cells + qc.sloped_planes_after.cells > 0)
    std::printf("  sloped planes (roofs; cells of %.3g m): distance RMS %.4f m over %zu cells before, %.4f m over %zu after\n",
                qc.plane_cell_size_m, qc.sloped_planes_before.rmsdz_m, qc.sloped_planes_before.cells, qc.sloped_planes_after.rmsdz_m,
                qc.sloped_planes_after.cells);
  if (qc.roof_edges_before.cells + qc.roof_edges_after.cells > 0)
    std::printf("  roof edges (ridges and valleys): distance RMS %.4f m over %zu cell pairs before, %.4f m over %zu after\n",
                qc.roof_edges_before.rmsdz_m, qc.roof_edges_before.cells, qc.roof_edges_after.rmsdz_m, qc.roof_edges_after.cells);
  for (const StripQc& st : qc.strips)
    std::printf("  strip %-10s intraswath precision %.4f m, within-cell range (P95) %.4f m over %zu cells\n", st.id.c_str(),
                st.intraswath_precision_m, st.intraswath_max_m, st.smooth_cells);
  for (const LevelVerdict& v : qc.verdicts) std::printf("  %-10s %s\n", v.level.name.c_str(), v.pass() ? "pass" : "fail");
  std::printf("wrote %s/qc.json, qc.html and %zu GeoTIFF rasters\n", out.c_str(), placed.size() - 2);
  return 0;
}

Command addQc(CLI::App& app) {
  struct Args {
    std::string job, result, out;
    double cell = 0;
    std::vector<std::string> pair;
    bool print_cell = false;
  };
  auto a = std::make_shared<Args>();
  CLI::App* c = app.add_subcommand(
      "qc", "Swath-to-swath quality control (interswath dZ, sloped planes, intraswath precision, USGS and ASPRS classes)");
  c->add_option("job", a->job, "Job JSON file")->required();
  c->add_option("--result", a->result, "Result JSON file: QC before (the job's mounting) and after (the result's)");
  c->add_option("--out", a->out, "Folder for qc.json, qc.html and the dZ GeoTIFFs (must exist)");
  c->add_option("--cell", a->cell, "Raster cell [m] (default: from the point spacing)")->check(CLI::Range(0.0, 1000.0));
  c->add_option("--pair", a->pair, "Only these two strips (a block workflow's per-pair job; give the block's --cell)")->expected(2);
  c->add_flag("--print-cell", a->print_cell, "Print the cell the QC of every strip takes, and nothing else (for --pair jobs' --cell)");
  return {c, [a] { return withNotices(runQc(a->job, a->result, a->out, a->cell, a->pair, a->print_cell)); }};
}

int runQcSummary(const std::vector<std::string>& parts, const std::string& out) {
  using namespace mountcal;
  namespace fs = std::filesystem;
  if (!fs::is_directory(out)) {
    std::fprintf(stderr, "mountcal qc-summary: %s: the output folder does not exist\n", out.c_str());
    return 2;
  }
  std::vector<SwathQcResult> qcs;
  for (const std::string& path : parts) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw FileError(path, "", "cannot be read");
    std::ostringstream text;
    text << in.rdbuf();
    try {
      qcs.push_back(swathQcFromJson(text.str()));
    } catch (const InvalidInput& e) {
      throw FileError(path, "", e.what());
    }
  }
  const SwathQcResult qc = mergeSwathQc(qcs);
  std::vector<std::pair<std::string, std::string>> files;
  for (const auto& [name, text] : {std::pair<std::string, std::string>{"qc.json", swathQcJson(qc)},
                                   {"qc.html", swathQcHtml(qc, "mountcal swath QC — " + std::to_string(parts.size()) + " pairs")}}) {
    const std::string path = (fs::path(out) / name).string();
    for (const std::string& in : parts)
      if (io::samePath(in, path)) throw FileError(path, "output", "would overwrite an input");
    files.push_back({path, text});
  }
  io::writeFilesAtomically(files);
  std::printf("swath QC of %zu pairs: RMSDz %.4f m before, %.4f m after over %zu cells; wrote %s/qc.json, qc.html\n", qc.pairs.size(),
              qc.overall_before.rmsdz_m, qc.overall_after.rmsdz_m, qc.overall_after.cells, out.c_str());
  return 0;
}

Command addQcSummary(CLI::App& app) {
  struct Args {
    std::vector<std::string> parts;
    std::string out;
  };
  auto a = std::make_shared<Args>();
  CLI::App* c = app.add_subcommand("qc-summary", "One swath QC (qc.json, qc.html) from the qc.json files of mountcal qc --pair jobs");
  c->add_option("parts", a->parts, "The pairs' qc.json files")->required();
  c->add_option("--out", a->out, "Folder for the summary's qc.json and qc.html (must exist)")->required();
  return {c, [a] { return withNotices(runQcSummary(a->parts, a->out)); }};
}

Command addEvaluate(CLI::App& app) {
  struct Args {
    std::string job, result, report;
    std::vector<std::string> profiles;
  };
  auto a = std::make_shared<Args>();
  CLI::App* c = app.add_subcommand("evaluate", "Check points, check planes and the pass-to-pass discrepancy before and after a result");
  c->add_option("job", a->job, "Job JSON file")->required();
  c->add_option("--result", a->result, "Result JSON file")->required();
  c->add_option("--report", a->report, "Write the visual HTML report of the result here");
  c->add_option("--profile", a->profiles, "A profile for the report: x0,y0,x1,y1[,width] in metres (repeatable)");
  return {c, [a] { return withNotices(runEvaluate(a->job, a->result, a->report, a->profiles)); }};
}

/// info, convert, curves: commands on single files.
std::vector<Command> addFileCommands(CLI::App& app) {
  auto info = std::make_shared<std::string>();
  CLI::App* ci = app.add_subcommand("info", "Summary of a LAS, LAZ or SBET file");
  ci->add_option("file", *info, "LAS, LAZ or SBET file")->required();
  auto conv = std::make_shared<std::pair<std::string, std::string>>();
  CLI::App* cc = app.add_subcommand("convert", "LAS to LAZ or LAZ to LAS, by the output's extension; every record, VLR and EVLR kept");
  cc->add_option("in", conv->first, "Input LAS or LAZ file")->required();
  cc->add_option("out", conv->second, "Output file: .laz compresses, .las does not")->required();
  auto curves = std::make_shared<std::pair<std::string, double>>(std::string(), 0.1);
  CLI::App* cu = app.add_subcommand("curves", "The first paper's Figs 1-3: boresight error curves (CSV, or CSV + SVG with --out)");
  cu->add_option("--out", curves->first, "Folder for fig_errors.csv and the SVG plots");
  cu->add_option("--boresight-deg", curves->second, "Boresight error on each axis [deg]")->capture_default_str();
  return {{ci, [info] { return runInfo(*info); }},
          {cc, [conv] { return runConvert(conv->first, conv->second); }},
          {cu, [curves] { return runCurves(curves->first, curves->second); }}};
}

/// pairs, match: a block's correspondence search split into jobs.
std::vector<Command> addBlockCommands(CLI::App& app) {
  struct Args {
    std::string job, out;
    std::vector<std::string> pair;
  };
  auto p = std::make_shared<Args>(), m = std::make_shared<Args>();
  CLI::App* cp = app.add_subcommand("pairs", "The strip pairs of a block to match (one \"A<TAB>B\" per line), from the strips' headers");
  cp->add_option("job", p->job, "Job JSON file")->required();
  cp->add_option("--out", p->out, "Write the list to this file instead of stdout");
  CLI::App* cm =
      app.add_subcommand("match", "The candidate correspondences of one strip pair, into a pair file (for calibrate --correspondences)");
  cm->add_option("job", m->job, "Job JSON file")->required();
  cm->add_option("--pair", m->pair, "The two strip ids")->required()->expected(2);
  cm->add_option("--out", m->out, "Pair file to write (docs/command-and-files.md: \"Correspondence pair files\")")->required();
  return {{cp, [p] { return withNotices(runPairs(p->job, p->out)); }},
          {cm, [m] { return withNotices(runMatch(m->job, m->pair, m->out)); }}};
}

Command addPlan(CLI::App& app) {
  struct Args {
    std::string plan, report;
    bool no_candidates = false;
  };
  auto a = std::make_shared<Args>();
  CLI::App* c = app.add_subcommand("plan", "Predict what a planned calibration flight determines, and what to add to it (PLAN.json)");
  c->add_option("plan", a->plan, "Plan JSON file (docs/report-and-planning.md)")->required();
  c->add_option("--report", a->report, "Also write the plan's HTML report to this file");
  c->add_flag("--no-candidates", a->no_candidates, "The prediction only, without trying additions");
  return {c, [a] { return runPlan(a->plan, a->report, a->no_candidates); }};
}

/// An unknown first word is named (CLI11 would only say that a subcommand is required).
bool knownSubcommand(const CLI::App& app, int argc, char** argv) {
  if (argc <= 1 || argv[1][0] == '-') return true;
  std::string names;
  bool known = false;
  for (const CLI::App* sub : app.get_subcommands({})) {
    known = known || sub->get_name() == argv[1];
    names += (names.empty() ? "" : ", ") + sub->get_name();
  }
  if (!known) std::fprintf(stderr, "mountcal: unknown subcommand '%s' (subcommands: %s; mountcal --help)\n", argv[1], names.c_str());
  return known;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mountcal " MOUNTCAL_VERSION_STRING " — LiDAR mounting (lever arm and boresight) calibration from overlapping strips"};
  app.require_subcommand(1);
  std::vector<Command> commands = {addMethods(app), addMounting(app), addSimulate(app), addCalibrate(app),
                                   addApply(app),   addEvaluate(app), addQc(app),       addQcSummary(app)};
  for (Command& c : addFileCommands(app)) commands.push_back(std::move(c));
  for (Command& c : addBlockCommands(app)) commands.push_back(std::move(c));
  commands.push_back(addPlan(app));
  if (!knownSubcommand(app, argc, argv)) return 2;
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  try {
    for (const Command& c : commands)
      if (c.app->parsed()) return c.run();
  } catch (const mountcal::Error& e) {
    std::fprintf(stderr, "mountcal: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mountcal: internal error: %s\n", e.what());
    return 3;
  }
  return 0;
}
