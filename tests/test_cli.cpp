// The mountcal command on files written to SPEC §4 (issue: VTPM self-calibration, I/O).
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "mountcal/io/las.hpp"
#include "mountcal/simulation/survey.hpp"
#include "support.hpp"

using namespace mountcal_tests;
using namespace mountcal;
using namespace mountcal::simulation;
namespace fs = std::filesystem;

namespace {

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
    std::fprintf(f, "%.6f,%.5f,%.5f,%.5f,%.9f,%.9f,%.9f\n", p.time_s, p.p_m.x(), p.p_m.y(), p.p_m.z(), rad2deg(p.roll), rad2deg(p.pitch),
                 rad2deg(p.heading));
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
      << " \"vtpm\": {\"radius_m\": 1.0, \"ransac_threshold_m\": 0.05, \"tie_sigma_xy_m\": 0.03, \"tie_sigma_z_m\": 0.03, "
         "\"strip_offset_sigma_m\": 0.005},"
      << " \"solver\": {\"max_iterations\": 100, \"loss\": \"trivial\"},"
      << " \"output\": {\"result\": \"result.json\", \"report\": \"report.html\"}}\n";
  return (dir / "job.json").string();
}

}  // namespace

TEST(Cli, CalibratesAJobWrittenByAnIndependentProgram) {
  const std::string job = writeIndependentJob();
  const CommandRun r = runCli("calibrate --quiet " + job);
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
  std::string flagged = las;  // the compression bit without a LASzip VLR
  flagged[104] = static_cast<char>(flagged[104] | 0x80);
  writeFile("points.laz", flagged);
  writeFile("notlas.las",
            "this is not a LAS file, just text that is long enough to hold a header ............"
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
      {variant("laz.json", "\"s1.las\"", "\"points.laz\""), "points.laz:byte 104: the point format says compressed (LAZ)"},
      {variant("notlas.json", "\"s1.las\"", "\"notlas.las\""), "notlas.las"},
      {variant("unsorted.json", "\"traj.csv\"", "\"unsorted.csv\""), "unsorted.csv:line 3"},
      {variant("nan.json", "\"traj.csv\"", "\"nan.csv\""), "nan.csv:line 3"},
      {variant("badties.json", "\"ties.csv\"", "\"badties.csv\""), "badties.csv:line 3"},
      {variant("outside.json", "\"traj.csv\"", "\"shorttraj.csv\""), "outside the trajectory"},
      {variant("offset.json", "\"format\": \"csv\"}", "\"format\": \"csv\", \"time_offset_s\": 1e9}"), "time encoding mismatch"},
      {variant("crs.json", "{\"type\": \"local\"}", "{\"type\": \"crs\", \"crs\": \"EPSG:32611\"}"),
       "traj.csv:line 1: missing column 'lat_deg'"},
      {variant("sbetlocal.json", "\"format\": \"csv\"}", "\"format\": \"sbet\"}"), "an SBET needs"},
      {variant("features.json", "\"method\": \"vtpm\"", "\"method\": \"features\""), "needs the target regions CSV"},
      {variant("planes.json", "\"method\": \"vtpm\"", "\"method\": \"planes\""), "field 'planes': missing"},
      {variant("methods.json", "\"method\": \"vtpm\"", "\"method\": [\"vtpm\", \"vtpm\"]"), "named twice"},
      {variant("method9.json", "\"method\": \"vtpm\"", "\"method\": [\"vtpm\", 9]"), "field 'method'"},
      {variant("budget.json", "\"method\": \"vtpm\"", "\"method\": \"correspondences\", \"correspondence\": {\"budget\": 2.5}"),
       "field 'correspondence.budget'"},
      {variant("nostrips.json", "\"strips\": [", "\"strip_list\": ["), "field 'strip_list'"},
      {variant("noties.json", "\"ties\": \"ties.csv\",", ""), "field 'ties': missing"},
  };
  for (const Case& c : cases) {
    const CommandRun r = runCli("calibrate --quiet " + c.job);
    EXPECT_EQ(r.code, 2) << c.job << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find(c.names), std::string::npos) << "expected '" << c.names << "' in: " << r.err;
  }
  // Nothing half-written over the good result.
  EXPECT_EQ(slurp((dir / "result.json").string()), result_before);
  EXPECT_EQ(runCli("no-such-command").code, 2);
  EXPECT_EQ(runCli("simulate --preset nope --out " + (dir / "x").string()).code, 2);
}

namespace {
nlohmann::json resultOf(const std::string& job_dir) { return nlohmann::json::parse(slurp(job_dir + "/result.json")); }
}  // namespace

TEST(Cli, SameSurveyInUtmWithSbetAndInALocalFrameGivesTheSameMounting) {
  const std::string base = (fs::temp_directory_path() / ("mountcal_crs_" + std::to_string(::getpid()))).string();
  const std::string loc = base + "/local", crs = base + "/utm";
  ASSERT_EQ(runCli("simulate --preset paper-calibration-field --seed 6 --out " + loc).code, 0);
  const CommandRun sim = runCli("simulate --preset paper-calibration-field --seed 6 --crs EPSG:32611 --out " + crs);
  ASSERT_EQ(sim.code, 0) << sim.err;
  ASSERT_TRUE(fs::exists(crs + "/trajectory.sbet"));
  ASSERT_EQ(runCli("calibrate --quiet " + loc + "/job.json").code, 0);
  const CommandRun cal = runCli("calibrate --quiet " + crs + "/job.json");
  ASSERT_EQ(cal.code, 0) << cal.err;
  const auto a = resultOf(loc), b = resultOf(crs);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(a["mounting"]["boresight_deg"][i].get<double>(), b["mounting"]["boresight_deg"][i].get<double>(), 1e-4) << i;
    EXPECT_NEAR(a["mounting"]["lever_arm_m"][i].get<double>(), b["mounting"]["lever_arm_m"][i].get<double>(), 2e-3) << i;
  }
  // Both are near the truth (default realistic noise; see the README for its sigmas).
  const double truth[3] = {0.05, -0.08, 0.12};
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(b["mounting"]["boresight_deg"][i].get<double>(), truth[i], 0.01) << i;
  fs::remove_all(base);
}

TEST(Cli, ApplyWithTheProducingMountingReproducesTheStripAndEvaluateReports) {
  const std::string base = (fs::temp_directory_path() / ("mountcal_apply_" + std::to_string(::getpid()))).string();
  ASSERT_EQ(runCli("simulate --preset paper-calibration-field --seed 7 --crs EPSG:32611 --out " + base).code, 0);
  // A result holding the mounting the strips were produced with.
  std::ofstream(base + "/same.json") << "{\"mounting\": {\"lever_arm_m\": [0, 0, 0], \"boresight_deg\": [0, 0, 0]}}";
  const CommandRun r = runCli("apply " + base + "/job.json --result " + base + "/same.json --out " + base + "/same");
  ASSERT_EQ(r.code, 0) << r.err;
  io::LasHeader ha, hb;
  std::vector<io::LasPoint> pa, pb;
  io::readLas(base + "/strip_1.las", &ha, &pa);
  io::readLas(base + "/same/strip_1.las", &hb, &pb);
  ASSERT_EQ(pa.size(), pb.size());
  EXPECT_EQ(ha.offset, hb.offset);
  EXPECT_EQ(ha.scale, hb.scale);
  for (std::size_t i = 0; i < pa.size(); ++i) {
    ASSERT_LE(std::abs(pa[i].X - pb[i].X), 1) << i;  // within the LAS scale (1 mm)
    ASSERT_LE(std::abs(pa[i].Y - pb[i].Y), 1) << i;
    ASSERT_LE(std::abs(pa[i].Z - pb[i].Z), 1) << i;
    ASSERT_TRUE(pa[i].gps_time == pb[i].gps_time && pa[i].intensity == pb[i].intensity && pa[i].scan_angle == pb[i].scan_angle &&
                pa[i].classification == pb[i].classification && pa[i].point_source_id == pb[i].point_source_id)
        << i;
  }
  // Calibrate, apply, and the check planes of the rewritten strips agree better.
  ASSERT_EQ(runCli("calibrate --quiet " + base + "/job.json").code, 0);
  ASSERT_EQ(runCli("apply " + base + "/job.json --result " + base + "/result.json --out " + base + "/applied").code, 0);
  const auto res = resultOf(base);
  const auto planes = res["evaluation"]["check_planes"];
  ASSERT_EQ(planes.size(), 2u);
  for (const auto& p : planes) EXPECT_LT(p["rms_after_m"].get<double>(), p["rms_before_m"].get<double>());
  EXPECT_EQ(runCli("evaluate " + base + "/job.json --result " + base + "/result.json").code, 0);
  // Applying onto its own input is refused.
  EXPECT_EQ(runCli("apply " + base + "/job.json --result " + base + "/result.json --out " + base).code, 2);
  EXPECT_EQ(runCli("info " + base + "/strip_1.las").code, 0);
  EXPECT_EQ(runCli("info " + base + "/trajectory.sbet").code, 0);
  EXPECT_EQ(runCli("curves --out " + base).code, 0);
  EXPECT_TRUE(fs::exists(base + "/fig2_y.svg"));
  fs::remove_all(base);
}

TEST(Cli, UnknownCrsAndCorruptSbetAreBadInput) {
  const std::string base = (fs::temp_directory_path() / ("mountcal_crsbad_" + std::to_string(::getpid()))).string();
  ASSERT_EQ(runCli("simulate --preset paper-check-block --crs EPSG:32611 --out " + base).code, 0);
  std::string job = slurp(base + "/job.json");
  job.replace(job.find("EPSG:32611"), 10, "EPSG:999999");
  std::ofstream(base + "/badcrs.json") << job;
  CommandRun r = runCli("calibrate --quiet " + base + "/badcrs.json");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("badcrs.json:field 'frame.crs'"), std::string::npos) << r.err;
  const std::string sbet = slurp(base + "/trajectory.sbet");
  std::ofstream(base + "/trajectory.sbet", std::ios::binary) << sbet.substr(0, sbet.size() - 5);
  r = runCli("calibrate --quiet " + base + "/job.json");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("trajectory.sbet:byte"), std::string::npos) << r.err;
  // A non-finite value in record 3 (its height) is named by record.
  std::string nan_sbet = sbet;
  const double nan = std::nan("");
  std::memcpy(&nan_sbet[3 * 136 + 3 * 8], &nan, 8);
  std::ofstream(base + "/trajectory.sbet", std::ios::binary) << nan_sbet;
  r = runCli("calibrate --quiet " + base + "/job.json");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("trajectory.sbet:record 3"), std::string::npos) << r.err;
  fs::remove_all(base);
}

TEST(Cli, EveryMethodAndCombinationRunsFromJobFiles) {
  // SPEC §4 methods from job files: "planes" with the simulator's regions and with "auto",
  // "correspondences", ["vtpm", "planes"]; and a preset with no ties file calibrates
  // automatically. Each result keeps the SPEC keys and adds its method's section.
  const std::string base = (fs::temp_directory_path() / ("mountcal_methods_" + std::to_string(::getpid()))).string();
  // The field within 8 m of its features (the preset: 12 m): five calibrations of the same kinds
  // on half the points.
  fs::create_directories(base);
  const std::string scenario = base + "/scenario.json";
  std::ofstream(scenario) << R"({"preset": "paper-calibration-field", "seed": 3, "roi_radius_m": 8})";
  const CommandRun sim = runCli("simulate " + scenario + " --no-ties --out " + base);
  ASSERT_EQ(sim.code, 0) << sim.err;
  ASSERT_FALSE(fs::exists(base + "/ties.csv"));
  const auto job = nlohmann::json::parse(slurp(base + "/job.json"));
  ASSERT_FALSE(job.contains("ties"));
  EXPECT_EQ(job["method"], "correspondences");
  const double truth[3] = {0.05, -0.08, 0.12};
  auto check = [&](const std::string& name, const nlohmann::json& j) {
    const std::string path = base + "/" + name + ".json";
    nlohmann::json jj = j;
    jj["output"] = {{"result", name + "_result.json"}, {"report", name + "_report.html"}};
    std::ofstream(path) << jj.dump(2);
    const CommandRun r = runCli("calibrate --quiet " + path);
    EXPECT_EQ(r.code, 0) << name << ": " << r.err;
    const auto res = nlohmann::json::parse(slurp(base + "/" + name + "_result.json"));
    for (const char* key : {"mounting", "sigma", "correlation", "estimated", "unobservable", "ties", "rms_before_m", "rms_after_m",
                            "residuals", "solver", "methods", "kinds"})
      EXPECT_TRUE(res.contains(key)) << name << ": " << key;
    for (int i = 0; i < 3; ++i) {
      const double e = res["mounting"]["boresight_deg"][i].get<double>(), s = res["sigma"]["boresight_deg"][i].get<double>();
      // Near the truth: the preset's lever_arm_z (0.2 m) is held at 0 without GCPs and leaks a
      // few thousandths of a degree, hence the 0.01° floor of the other CLI tests.
      EXPECT_LT(std::abs(e - truth[i]), std::max(3 * s, 0.01)) << name << " boresight " << i;
    }
    const std::string html = slurp(base + "/" + name + "_report.html");
    EXPECT_NE(html.find("boresight_heading"), std::string::npos) << name;
    return res;
  };
  auto res = check("auto_corr", job);  // the job as written: no ties, automatic
  ASSERT_TRUE(res.contains("correspondences"));
  EXPECT_GT(res["correspondences"]["used"].get<int>(), 1000);
  EXPECT_EQ(res["correspondences"]["pairs"].size(), 6u);
  EXPECT_NE(slurp(base + "/auto_corr_report.html").find("Automatic correspondences"), std::string::npos);

  nlohmann::json planes = job;
  planes["method"] = "planes";
  // The re-solve check ran with the correspondences above; the other jobs skip its second solve.
  planes["solver"]["resolve_check"] = false;
  res = check("planes_regions", planes);
  ASSERT_TRUE(res.contains("planes"));
  EXPECT_GE(res["planes"]["patches_used"].get<int>(), 5);
  EXPECT_FALSE(res["planes"]["automatic"].get<bool>());
  for (const auto& p : res["planes"]["patches"]) EXPECT_LT(p["rms_after_m"].get<double>(), p["rms_before_m"].get<double>());
  EXPECT_NE(slurp(base + "/planes_regions_report.html").find("Plane patches"), std::string::npos);

  planes["planes"] = "auto";
  res = check("planes_auto", planes);
  EXPECT_TRUE(res["planes"]["automatic"].get<bool>());
  EXPECT_GT(res["planes"]["patches_used"].get<int>(), 20);

  // Ties and planes in one adjustment (the ties written by a second simulation of the same seed).
  ASSERT_EQ(runCli("simulate " + scenario + " --out " + base + "/with_ties").code, 0);
  fs::copy_file(base + "/with_ties/ties.csv", base + "/ties.csv");
  nlohmann::json both = job;
  both["solver"]["resolve_check"] = false;
  both["ties"] = "ties.csv";
  both["method"] = {"vtpm", "planes"};
  res = check("vtpm_planes", both);
  EXPECT_GT(res["ties"]["used"].get<int>(), 20);
  EXPECT_GT(res["planes"]["points_used"].get<int>(), 200);
  ASSERT_EQ(res["kinds"].size(), 2u);
  EXPECT_EQ(res["methods"], nlohmann::json({"vtpm", "planes"}));
  fs::remove_all(base);
}

// Issue 26: a calibration that should not be used exits 1 with the reason; the result file and
// the report carry the verdict. The job states a tie σ 30× too small (1 mm for picks that
// scatter 5 cm), so σ₀² is far above 10.
TEST(Cli, ACalibrationThatShouldNotBeUsedExits1WithTheReason) {
  const std::string base = (fs::temp_directory_path() / ("mountcal_verdict_" + std::to_string(::getpid()))).string();
  ASSERT_EQ(runCli("simulate --preset paper-calibration-field --seed 4 --out " + base).code, 0);
  const CommandRun good = runCli("calibrate --quiet " + base + "/job.json");
  ASSERT_EQ(good.code, 0) << good.err;
  EXPECT_NE(resultOf(base)["verdict"]["kind"].get<std::string>(), "reject");
  nlohmann::json job = nlohmann::json::parse(slurp(base + "/job.json"));
  job["vtpm"]["tie_sigma_xy_m"] = 0.001;
  job["vtpm"]["tie_sigma_z_m"] = 0.001;
  job["vtpm"]["estimate_tie_sigma"] = false;
  job["output"]["report"] = "report.html";
  std::ofstream(base + "/bad.json") << job.dump(2);
  const CommandRun bad = runCli("calibrate --quiet " + base + "/bad.json");
  EXPECT_EQ(bad.code, 1);
  EXPECT_NE(bad.err.find("should not be used: σ₀²"), std::string::npos) << bad.err;
  const auto result = resultOf(base);
  EXPECT_EQ(result["verdict"]["kind"], "reject");
  EXPECT_NE(result["verdict"]["reasons"][0].get<std::string>().find("σ₀²"), std::string::npos);
  EXPECT_NE(slurp(base + "/report.html").find("Verdict: reject"), std::string::npos);
  fs::remove_all(base);
}
