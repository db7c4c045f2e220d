// The mountcal command on files written to SPEC §4 (issue: VTPM self-calibration, I/O).
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "mountcal/simulation/survey.hpp"

using namespace mountcal;
using namespace mountcal::simulation;
namespace fs = std::filesystem;

namespace {

struct CliRun {
  int code;
  std::string err;
};

CliRun runCli(const std::string& args) {
  const std::string err_file = (fs::temp_directory_path() / ("mountcal_cli_err_" + std::to_string(::getpid()))).string();
  const std::string cmd = std::string(MOUNTCAL_CLI) + " " + args + " > /dev/null 2> " + err_file;
  const int status = std::system(cmd.c_str());
  std::ifstream in(err_file);
  std::stringstream ss;
  ss << in.rdbuf();
  fs::remove(err_file);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, ss.str()};
}

std::string slurp(const std::string& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void put(std::string& b, std::size_t off, const void* v, std::size_t n) { std::memcpy(&b[off], v, n); }

/// An independent LAS 1.2, point format 1 writer (not the library's): header, no VLRs.
void writeLas12(const std::string& path, const std::vector<Vec3>& xyz, const std::vector<double>& t) {
  const double scale = 0.001;
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (const Vec3& p : xyz)
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
  const double off[3] = {std::floor(lo[0]), std::floor(lo[1]), std::floor(lo[2])};
  std::string h(227, '\0');
  std::memcpy(&h[0], "LASF", 4);
  h[24] = 1;
  h[25] = 2;
  const std::uint16_t hs = 227, rl = 28;
  const std::uint32_t offset = 227, n = static_cast<std::uint32_t>(xyz.size());
  const std::uint8_t fmt = 1;
  put(h, 94, &hs, 2);
  put(h, 96, &offset, 4);
  put(h, 104, &fmt, 1);
  put(h, 105, &rl, 2);
  put(h, 107, &n, 4);
  put(h, 111, &n, 4);
  for (int a = 0; a < 3; ++a) {
    put(h, 131 + 8 * a, &scale, 8);
    put(h, 155 + 8 * a, &off[a], 8);
    put(h, 179 + 16 * a, &hi[a], 8);
    put(h, 187 + 16 * a, &lo[a], 8);
  }
  std::ofstream out(path, std::ios::binary);
  out.write(h.data(), static_cast<std::streamsize>(h.size()));
  for (std::size_t i = 0; i < xyz.size(); ++i) {
    std::string r(28, '\0');
    for (int a = 0; a < 3; ++a) {
      const std::int32_t q = static_cast<std::int32_t>(std::llround((xyz[i][a] - off[a]) / scale));
      put(r, 4 * a, &q, 4);
    }
    r[14] = 0x09;  // return 1 of 1
    put(r, 20, &t[i], 8);
    out.write(r.data(), 28);
  }
}

/// Writes a survey-grade calibration-field survey with the independent writers above.
std::string writeIndependentJob() {
  const fs::path dir = fs::temp_directory_path() / ("mountcal_cli_job_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  static SimulatedSurvey s = [] {
    Scene scene;
    SurveyConfig c;
    makePreset("paper-calibration-field", 4, &c, &scene);
    c.noise.gnss_sigma_m = 0.005;
    c.noise.pick_sigma_m = 0.03;
    c.roi_radius_m = 6.0;
    return simulate(c, scene);
  }();
  FILE* f = std::fopen((dir / "traj.csv").c_str(), "w");
  std::fprintf(f, "time,x,y,z,roll_deg,pitch_deg,heading_deg\n");
  for (const TrajectorySample& p : s.measured_trajectory->samples())
    std::fprintf(f, "%.6f,%.5f,%.5f,%.5f,%.9f,%.9f,%.9f\n", p.time_s, p.p_m.x(), p.p_m.y(), p.p_m.z(), rad2deg(p.roll), rad2deg(p.pitch), rad2deg(p.heading));
  std::fclose(f);
  std::string strips;
  for (const SimulatedStrip& st : s.strips) {
    std::vector<double> t;
    for (const RawPulse& p : st.pulses) t.push_back(p.time_s);
    writeLas12((dir / ("s" + st.id + ".las")).string(), st.points_m, t);
    strips += std::string(strips.empty() ? "" : ",") + "{\"id\": \"" + st.id + "\", \"path\": \"s" + st.id + ".las\"}";
  }
  f = std::fopen((dir / "ties.csv").c_str(), "w");
  std::fprintf(f, "tie_id,strip_id,x,y\n");
  for (const TiePick& p : s.ties) std::fprintf(f, "%s,%s,%.4f,%.4f\n", p.tie_id.c_str(), p.strip_id.c_str(), p.x_m, p.y_m);
  std::fclose(f);
  std::ofstream job(dir / "job.json");
  job << "{\"frame\": {\"type\": \"local\"}, \"trajectory\": {\"path\": \"traj.csv\", \"format\": \"csv\"},"
      << " \"sensor\": {\"type\": \"line\", \"nominal_rotation_deg\": [0, 0, 0]},"
      << " \"mounting_used\": {\"lever_arm_m\": [0, 0, 0], \"boresight_deg\": [0, 0, 0]},"
      << " \"strips\": [" << strips << "], \"ties\": \"ties.csv\", \"method\": \"vtpm\","
      << " \"estimate\": {\"lever_arm\": [true, true, false], \"boresight\": [true, true, true]},"
      << " \"vtpm\": {\"radius_m\": 1.0, \"ransac_threshold_m\": 0.05, \"tie_sigma_xy_m\": 0.03, \"tie_sigma_z_m\": 0.03, \"strip_offset_sigma_m\": 0.005},"
      << " \"solver\": {\"max_iterations\": 100, \"loss\": \"trivial\"},"
      << " \"output\": {\"result\": \"result.json\", \"report\": \"report.html\"}}\n";
  return (dir / "job.json").string();
}

}  // namespace

TEST(Cli, CalibratesAJobWrittenByAnIndependentProgram) {
  const std::string job = writeIndependentJob();
  const CliRun r = runCli("calibrate --quiet " + job);
  ASSERT_EQ(r.code, 0) << r.err;
  const fs::path dir = fs::path(job).parent_path();
  const auto j = nlohmann::json::parse(slurp((dir / "result.json").string()));
  const auto lever = j["mounting"]["lever_arm_m"], bore = j["mounting"]["boresight_deg"];
  EXPECT_NEAR(bore[0].get<double>(), 0.05, 0.003);
  EXPECT_NEAR(bore[1].get<double>(), -0.08, 0.003);
  EXPECT_NEAR(bore[2].get<double>(), 0.12, 0.003);
  EXPECT_NEAR(lever[0].get<double>(), 0.10, 0.05);
  EXPECT_NEAR(lever[1].get<double>(), -0.05, 0.05);
  EXPECT_TRUE(j["sigma"]["lever_arm_m"][2].is_null());  // held fixed → null sigma (SPEC §4)
  EXPECT_EQ(j["solver"]["termination"], "CONVERGENCE");
  EXPECT_EQ(j["correlation"].size(), 6u);
  EXPECT_GT(j["ties"]["used"].get<int>(), 20);
  EXPECT_GT(j["residuals"].size(), 50u);
  const std::string html = slurp((dir / "report.html").string());
  EXPECT_NE(html.find("<svg"), std::string::npos);
  EXPECT_NE(html.find("boresight_heading"), std::string::npos);
}

TEST(Cli, BadInputExitsTwoWithOneLineNamingTheFileAndKeepsGoodOutput) {
  const std::string job = writeIndependentJob();
  const fs::path dir = fs::path(job).parent_path();
  const std::string good = slurp(job);
  ASSERT_EQ(runCli("calibrate --quiet " + job).code, 0);
  const std::string result_before = slurp((dir / "result.json").string());
  auto variant = [&](const std::string& name, const std::string& from, const std::string& to) {
    std::string text = good;
    const auto pos = text.find(from);
    EXPECT_NE(pos, std::string::npos) << from;
    text.replace(pos, from.size(), to);
    std::ofstream((dir / name).string()) << text;
    return (dir / name).string();
  };
  auto writeFile = [&](const std::string& name, const std::string& content) {
    std::ofstream((dir / name).string(), std::ios::binary) << content;
    return (dir / name).string();
  };
  const std::string las = slurp((dir / "s1.las").string());
  writeFile("truncated.las", las.substr(0, las.size() / 2));
  writeFile("points.laz", las);
  writeFile("notlas.las", "this is not a LAS file, just text that is long enough to hold a header ............"
                          "..........................................................................................."
                          "...........................................................................");
  writeFile("unsorted.csv", "time,x,y,z,roll_deg,pitch_deg,heading_deg\n2,0,0,0,0,0,0\n1,0,0,0,0,0,0\n");
  writeFile("nan.csv", "time,x,y,z,roll_deg,pitch_deg,heading_deg\n1,0,0,0,0,0,0\n2,nan,0,0,0,0,0\n");
  writeFile("badties.csv", "tie_id,strip_id,x,y\na,1,0,0\na,99,1,1\n");
  writeFile("shorttraj.csv", "time,x,y,z,roll_deg,pitch_deg,heading_deg\n1,0,0,0,0,0,0\n2,0,0,0,0,0,0\n");
  struct Case {
    std::string job, names;
  };
  const std::vector<Case> cases = {
      {(dir / "missing.json").string(), "missing.json"},
      {writeFile("invalid.json", "{\"frame\": {"), "invalid.json"},
      {variant("unknown.json", "\"method\": \"vtpm\"", "\"method\": \"vtpm\", \"colour\": 3"), "colour"},
      {variant("wrongtype.json", "\"max_iterations\": 100", "\"max_iterations\": \"many\""), "max_iterations"},
      {variant("notraj.json", "\"traj.csv\"", "\"nowhere.csv\""), "nowhere.csv"},
      {variant("trunc.json", "\"s1.las\"", "\"truncated.las\""), "truncated.las"},
      {variant("laz.json", "\"s1.las\"", "\"points.laz\""), "LAZ"},
      {variant("notlas.json", "\"s1.las\"", "\"notlas.las\""), "notlas.las"},
      {variant("unsorted.json", "\"traj.csv\"", "\"unsorted.csv\""), "unsorted.csv:line 3"},
      {variant("nan.json", "\"traj.csv\"", "\"nan.csv\""), "nan.csv:line 3"},
      {variant("badties.json", "\"ties.csv\"", "\"badties.csv\""), "badties.csv:line 3"},
      {variant("outside.json", "\"traj.csv\"", "\"shorttraj.csv\""), "outside the trajectory"},
      {variant("offset.json", "\"format\": \"csv\"}", "\"format\": \"csv\", \"time_offset_s\": 1e9}"), "time encoding mismatch"},
      {variant("crs.json", "{\"type\": \"local\"}", "{\"type\": \"crs\", \"crs\": \"EPSG:32611\"}"), "not supported yet"},
  };
  for (const Case& c : cases) {
    const CliRun r = runCli("calibrate --quiet " + c.job);
    EXPECT_EQ(r.code, 2) << c.job << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find(c.names), std::string::npos) << "expected '" << c.names << "' in: " << r.err;
  }
  // Nothing half-written over the good result.
  EXPECT_EQ(slurp((dir / "result.json").string()), result_before);
  EXPECT_EQ(runCli("no-such-command").code, 2);
  EXPECT_EQ(runCli("simulate --preset nope --out " + (dir / "x").string()).code, 2);
}
