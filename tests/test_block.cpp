// A block's calibration split into pair jobs, threads, and the Snakemake workflow (issue 13:
// "Fast on one machine, and a block of thousands of strips on an existing workflow engine").
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>

#include "mountcal/mountcal.hpp"
#include "support.hpp"
#include "sanitizer_build.hpp"

using namespace mountcal_tests;
using namespace mountcal;
using namespace mountcal::simulation;
namespace fs = std::filesystem;

namespace {

/// The 8-strip block (four E–W lines crossing four N–S lines), simulated within 5 m of its
/// features: the light block of the suites.
const SimulatedSurvey& block() {
  static const SimulatedSurvey s = [] {
    Scene scene;
    SurveyConfig c;
    makeBlock(8, 7, &c, &scene);
    c.roi_radius_m = 5.0;
    return simulate(c, scene);
  }();
  return s;
}

MountingCalibrator::Options correspondenceOptions(int threads) {
  MountingCalibrator::Options o;
  o.methods = {"correspondences"};
  o.estimate = {false, true, false, true, true, true};  // one height: lever x and z are not determined
  o.threads = threads;
  // These tests compare mountings (threads, pair files); the re-solve check, which doubles a
  // matching calibration's time, is tested in test_observability.cpp and on the Gravity data.
  o.resolve_check = false;
  // The block's strips move against each other by about 2 m during the calibration: pair files
  // matched for the default 1 m would refuse those samples (and warn), where the whole search
  // grows its margin from the data — matched for 4 m, both hold every neighbourhood whole.
  o.method<CorrespondenceOptions>().apriori_misalignment_m = 4.0;
  return o;
}

fs::path tempDir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("mountcal_block_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

struct ShellRun {
  int code;
  std::string out;
};

/// A shell command's exit code and its stdout and stderr together.
ShellRun sh(const std::string& cmd) {
  const fs::path log = fs::temp_directory_path() / ("mountcal_block_log_" + std::to_string(::getpid()));
  const int status = std::system((cmd + " > " + log.string() + " 2>&1").c_str());
  ShellRun r{WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(log)};
  fs::remove(log);
  return r;
}

std::string cli() { return MOUNTCAL_CLI; }

void expectSameMounting(const MountingParameters& a, const MountingParameters& b, double tol, const std::string& what) {
  const auto x = a.toArray(), y = b.toArray();
  for (int j = 0; j < 6; ++j) EXPECT_NEAR(x[j], y[j], tol) << what << ", parameter " << j;
}

}  // namespace

TEST(Block, PairFilesGiveTheSameMountingAsTheWholeSearch) {
  const CalibrationData d = toCalibrationData(block());
  const auto o = correspondenceOptions(0);
  const MountingCalibrator::Summary whole = calibrate(d, o);
  ASSERT_TRUE(whole.IsSolutionUsable()) << whole.message;
  ASSERT_GT(whole.section<CorrespondenceSection>().used, 500);
  // Each pair from its two strips alone, through a pair file and back.
  const fs::path dir = tempDir("pairs");
  auto given = std::make_shared<std::vector<PairCandidates>>();
  int overlapping = 0;
  for (const auto& [a, b] : candidateStripPairs(d, o.method<CorrespondenceOptions>())) {
    CalibrationData two;
    two.trajectory = d.trajectory;
    two.mounting_used = d.mounting_used;
    two.strips = {d.strips[static_cast<std::size_t>(a)], d.strips[static_cast<std::size_t>(b)]};
    const PairCandidates p = findPairCandidates(two, 0, 1, o.method<CorrespondenceOptions>());
    const std::string file = (dir / (p.strip_a + "__" + p.strip_b + ".mcpair")).string();
    writePairCandidates(file, p, o.method<CorrespondenceOptions>(), d.mounting_used.toArray());
    CorrespondenceOptions read_options;
    std::array<double, 6> read_mounting{};
    PairCandidates q = readPairCandidates(file, &read_options, &read_mounting);
    EXPECT_TRUE(sameMatchingOptions(read_options, o.method<CorrespondenceOptions>()));
    EXPECT_EQ(read_mounting, d.mounting_used.toArray());
    ASSERT_EQ(q.samples_a.size(), p.samples_a.size());
    ASSERT_EQ(q.points_b.size(), p.points_b.size());
    for (std::size_t k = 0; k < p.points_b.size(); k += 97) {
      EXPECT_EQ(q.points_b[k].index, p.points_b[k].index);
      EXPECT_EQ(q.points_b[k].x0_m, p.points_b[k].x0_m);
      EXPECT_EQ(q.points_b[k].r_s_m, p.points_b[k].r_s_m);
    }
    q.attitudesFrom(*d.trajectory);  // the file holds times: attitudes from the trajectory, as the whole search took them
    for (std::size_t k = 0; k < p.points_b.size(); k += 97) EXPECT_EQ(q.points_b[k].R_mb, p.points_b[k].R_mb);
    overlapping += q.overlap;
    given->push_back(std::move(q));
  }
  EXPECT_GT(overlapping, 18);  // 16 crossings and the side overlaps
  CalibrationData from_files;
  from_files.trajectory = d.trajectory;
  from_files.mounting_used = d.mounting_used;
  for (const StripData& s : d.strips) {
    StripData id_only;
    id_only.id = s.id;
    from_files.strips.push_back(id_only);
  }
  from_files.correspondence_candidates = given;
  const MountingCalibrator::Summary split = calibrate(from_files, o);
  ASSERT_TRUE(split.IsSolutionUsable()) << split.message;
  EXPECT_EQ(whole.section<CorrespondenceSection>().misalignment_growths, 0);  // so the two searched alike
  EXPECT_EQ(split.section<CorrespondenceSection>().rejectedMoved(), 0);
  expectSameMounting(split.mounting, whole.mounting, 1e-9, "pair files against the whole search");
  EXPECT_EQ(split.mounting.toArray(), whole.mounting.toArray());  // to the last bit, in fact
  EXPECT_EQ(split.section<CorrespondenceSection>().used, whole.section<CorrespondenceSection>().used);
  EXPECT_EQ(split.section<CorrespondenceSection>().rounds, whole.section<CorrespondenceSection>().rounds);
  for (int j : {1, 3, 4, 5}) EXPECT_NEAR(split.sigma[j], whole.sigma[j], 1e-12 * whole.sigma[j]);  // the analysis rounds alike to 1e-16
  // And the block calibrates: the boresight within a few σ of the truth (lever x held at zero
  // moves pitch by 0.1 m / 300 m = 0.019°).
  const Vec3 truth = block().config.true_mounting.boresightDeg(), got = whole.mounting.boresightDeg();
  EXPECT_NEAR(got.x(), truth.x(), 0.003);
  EXPECT_NEAR(got.y(), truth.y() + rad2deg(0.1 / 300.0), 0.01);
  EXPECT_NEAR(got.z(), truth.z(), 0.01);
  fs::remove_all(dir);
  // Pair files matched for a misalignment the strips then exceed (the default 1 m) cannot grow:
  // the samples whose neighbours reach past them are refused, and the warning says what to match for.
  auto o1 = o;
  o1.method<CorrespondenceOptions>().apriori_misalignment_m = 1.0;
  auto narrow = std::make_shared<std::vector<PairCandidates>>();
  for (const auto& [a, b] : candidateStripPairs(d, o1.method<CorrespondenceOptions>()))
    narrow->push_back(findPairCandidates(d, a, b, o1.method<CorrespondenceOptions>()));
  from_files.correspondence_candidates = narrow;
  const MountingCalibrator::Summary short_pairs = calibrate(from_files, o1);
  const CorrespondenceSection& cs = short_pairs.section<CorrespondenceSection>();
  EXPECT_GT(cs.rejectedMoved(), 0);
  EXPECT_EQ(cs.misalignment_growths, 0);
  EXPECT_GT(cs.needed_misalignment_m, 1.0);
  ASSERT_EQ(cs.warnings().size(), 1u);
  EXPECT_NE(cs.warnings()[0].find("mountcal match"), std::string::npos) << cs.warnings()[0];
}

TEST(Block, ThreadsDoNotChangeTheResult) {
  const CalibrationData d = toCalibrationData(block());
  const CorrespondenceSet one = findCorrespondences(d, d.mounting_used.toArray(), CorrespondenceOptions{}, true, 1);
  const CorrespondenceSet two = findCorrespondences(d, d.mounting_used.toArray(), CorrespondenceOptions{}, true, 2);
  ASSERT_EQ(one.correspondences.size(), two.correspondences.size());
  ASSERT_GT(one.correspondences.size(), 1000u);
  for (std::size_t k = 0; k < one.correspondences.size(); ++k) {
    const Correspondence &a = one.correspondences[k], &b = two.correspondences[k];
    ASSERT_EQ(a.strip_a, b.strip_a);
    ASSERT_EQ(a.point_a, b.point_a);
    ASSERT_EQ(a.points_b, b.points_b);
    ASSERT_EQ(a.distance_m, b.distance_m);
  }
  // The sanitizer build matches on one and two threads (memory errors there); the two whole
  // calibrations (15 s there) compare results, which the Release suite does.
  if (mountcal_tests::kSanitizerBuild)
    GTEST_SKIP() << "sanitizer build: the matching compared on 1 and 2 threads; the two calibrations in the Release suite";
  const auto S1 = calibrate(d, correspondenceOptions(1));
  const auto S2 = calibrate(d, correspondenceOptions(2));
  EXPECT_EQ(S1.mounting.toArray(), S2.mounting.toArray());
  EXPECT_EQ(S1.final_cost, S2.final_cost);
  EXPECT_EQ(S1.section<CorrespondenceSection>().rounds, S2.section<CorrespondenceSection>().rounds);
}

TEST(Block, VirtualTiePointsAndSimulationDoNotDependOnThreads) {
  // VTPM construction on 1 and 2 threads: the same virtual tie points, bit for bit.
  Scene scene;
  SurveyConfig c;
  makePreset("paper-calibration-field", 3, &c, &scene);
  c.roi_radius_m = 6.0;
  c.threads = 1;
  const SimulatedSurvey s1 = simulate(c, scene);
  c.threads = 2;
  const SimulatedSurvey s2 = simulate(c, scene);
  ASSERT_EQ(s1.strips.size(), s2.strips.size());
  for (std::size_t k = 0; k < s1.strips.size(); ++k) EXPECT_EQ(s1.strips[k].points_m, s2.strips[k].points_m) << "strip " << k;
  ASSERT_EQ(s1.ties.size(), s2.ties.size());
  for (std::size_t k = 0; k < s1.ties.size(); ++k) EXPECT_EQ(s1.ties[k].x_m, s2.ties[k].x_m);
  const CalibrationData d = toCalibrationData(s1);
  MountingCalibrator::Options o;
  const TieObservations one(d, d.ties, d.gcps, o.method<VtpmOptions>(), o.method<VtpmOptions>().vtp, "ties", 1),
      two(d, d.ties, d.gcps, o.method<VtpmOptions>(), o.method<VtpmOptions>().vtp, "ties", 2);
  ASSERT_GT(one.virtualTiePoints().size(), 100u);
  ASSERT_EQ(one.virtualTiePoints().size(), two.virtualTiePoints().size());
  for (std::size_t k = 0; k < one.virtualTiePoints().size(); ++k) {
    EXPECT_EQ(one.virtualTiePoints()[k].referencePosition(), two.virtualTiePoints()[k].referencePosition()) << k;
  }
  EXPECT_EQ(one.section().rejected.size(), two.section().rejected.size());
}

TEST(Block, PairFileErrorsNameTheFileAndTheByte) {
  const CalibrationData d = toCalibrationData(block());
  const CorrespondenceOptions o;
  const auto pairs = candidateStripPairs(d, o);
  ASSERT_FALSE(pairs.empty());
  const PairCandidates p = findPairCandidates(d, pairs[0].first, pairs[0].second, o);
  ASSERT_TRUE(p.overlap);
  const fs::path dir = tempDir("errors");
  const std::string good = (dir / "good.mcpair").string();
  writePairCandidates(good, p, o, d.mounting_used.toArray());
  const std::string bytes = slurp(good);
  auto expectRefused = [&](const std::string& content, const std::string& needle) {
    const std::string f = (dir / "bad.mcpair").string();
    std::ofstream(f, std::ios::binary) << content;
    try {
      readPairCandidates(f);
      ADD_FAILURE() << "accepted: " << needle;
    } catch (const FileError& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find(f), std::string::npos) << m;
      EXPECT_NE(m.find("byte"), std::string::npos) << m;
      EXPECT_NE(m.find(needle), std::string::npos) << m;
    }
  };
  expectRefused(bytes.substr(0, bytes.size() / 2), "truncated");
  expectRefused("LASF" + bytes.substr(4), "MCPAIRS2");
  expectRefused(bytes + "x", "after the end mark");
  std::string huge = bytes;
  const std::uint64_t n = 1ull << 60;  // the sample count: right after the options and mounting
  const std::size_t at = 8 + 4 + 4 + p.strip_a.size() + 4 + p.strip_b.size() + 24 + 8 + 4 + 32 + 8 + 48;
  std::memcpy(&huge[at], &n, 8);
  expectRefused(huge, "do not fit");
  // A folder of pair files: a missing pair, and files matched with other settings, are named.
  const fs::path jobdir = tempDir("job");
  mountcal::writeSurvey(block(), jobdir.string(), mountcal::SurveyWriteOptions{});
  Job job = readJob((jobdir / "job.json").string());
  job.options.methods = {"correspondences"};
  const fs::path pairdir = jobdir / "pairs";
  fs::create_directories(pairdir);
  try {
    loadJobFromPairFiles(job, pairdir.string());
    ADD_FAILURE() << "an empty folder was accepted";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("no pair file for strips"), std::string::npos) << e.what();
  }
  const auto job_pairs = jobStripPairs(job);
  ASSERT_GE(job_pairs.size(), pairs.size());  // from the headers: a superset
  CorrespondenceOptions other = job.options.method<CorrespondenceOptions>();
  other.max_neighbours += 1;
  const PairCandidates q = jobPairCandidates(job, job_pairs[0].first, job_pairs[0].second);
  writePairCandidates((pairdir / "x.mcpair").string(), q, other, job.mounting_used.toArray());
  try {
    loadJobFromPairFiles(job, pairdir.string());
    ADD_FAILURE() << "other options accepted";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("other correspondence options"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
  fs::remove_all(jobdir);
}

TEST(Workflow, SnakemakeBlockEqualsOneCalibrateAndRematchesOnlyADeletedPair) {
  // The test setup (scripts/test.sh) installs Snakemake: its absence is a failure here.
  ASSERT_EQ(sh("snakemake --version").code, 0) << "snakemake is not installed (scripts/test.sh installs it)";
  const fs::path dir = tempDir("snakemake");
  {
    std::ofstream sc(dir / "scenario.json");
    // block-4: every rule of the workflow on six pairs (block-8 took 67 s under the sanitizers).
    sc << "{\"preset\": \"block-4\", \"seed\": 7, \"roi_radius_m\": 5}\n";
  }
  ShellRun r = sh(cli() + " simulate " + (dir / "scenario.json").string() + " --no-ties --out " + (dir / "block").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string job = (dir / "block" / "job.json").string();
  {
    // The workflow's equality with one calibrate does not need the re-solve check (it doubles
    // every calibrate of the block; tested in test_observability.cpp).
    nlohmann::json j = nlohmann::json::parse(slurp(job));
    j["solver"]["resolve_check"] = false;
    j["correspondences"]["apriori_misalignment_m"] = 4.0;  // the strips move by about 2 m (correspondenceOptions)
    std::ofstream(job) << j.dump(2);
  }
  r = sh(cli() + " calibrate " + job + " --result " + (dir / "serial.json").string() + " --quiet --threads 2");
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string snake = "snakemake -s " + std::string(MOUNTCAL_SOURCE_DIR) + "/workflows/block/Snakefile --cores 2 --directory " +
                            (dir / "run").string() + " --config job=" + job + " out=" + (dir / "wf").string() + " mountcal=" + cli();
  r = sh(snake);
  ASSERT_EQ(r.code, 0) << r.out;
  auto mounting = [](const fs::path& result) {
    const nlohmann::json j = nlohmann::json::parse(slurp(result));
    std::vector<double> v;
    for (const char* k : {"lever_arm_m", "boresight_deg"})
      for (double x : j["mounting"][k]) v.push_back(x);
    return v;
  };
  const std::vector<double> serial = mounting(dir / "serial.json"), workflow = mounting(dir / "wf" / "result.json");
  ASSERT_EQ(serial.size(), 6u);
  for (int j = 0; j < 6; ++j) EXPECT_NEAR(workflow[j], serial[j], 1e-9) << "parameter " << j;
  // The swath QC rules (one job per pair on the block's cell, one summary) equal one `mountcal qc`
  // of the whole block: the same pairs, cells and figures.
  fs::create_directories(dir / "qc_whole");
  r = sh(cli() + " qc " + job + " --result " + (dir / "wf" / "result.json").string() + " --out " + (dir / "qc_whole").string());
  ASSERT_EQ(r.code, 0) << r.out;
  {
    const nlohmann::json whole = nlohmann::json::parse(slurp(dir / "qc_whole" / "qc.json"));
    const nlohmann::json parts = nlohmann::json::parse(slurp(dir / "wf" / "qc" / "qc.json"));
    ASSERT_EQ(parts["pairs"].size(), whole["pairs"].size());
    EXPECT_GE(whole["pairs"].size(), 4u);
    for (std::size_t k = 0; k < whole["pairs"].size(); ++k) {
      const nlohmann::json &p = parts["pairs"][k], &w = whole["pairs"][k];
      EXPECT_EQ(p["a"], w["a"]);
      EXPECT_EQ(p["b"], w["b"]);
      EXPECT_EQ(p["after"]["cells"], w["after"]["cells"]);
      EXPECT_EQ(p["after"]["rmsdz_m"], w["after"]["rmsdz_m"]);
      EXPECT_EQ(p["point_to_plane"]["after"]["median_m"], w["point_to_plane"]["after"]["median_m"]);
    }
    for (const char* state : {"before", "after"}) {
      const nlohmann::json& ws = std::string(state) == "after" ? whole["summary"] : whole["summary"]["before"];
      const nlohmann::json& ps = std::string(state) == "after" ? parts["summary"] : parts["summary"]["before"];
      EXPECT_EQ(ps["cells"], ws["cells"]) << state;
      EXPECT_NEAR(ps["rmsdz_m"].get<double>(), ws["rmsdz_m"].get<double>(), 1e-12) << state;
      EXPECT_EQ(ps["max_abs_dz_m"], ws["max_abs_dz_m"]) << state;
    }
    ASSERT_EQ(parts["summary"]["classes"].size(), whole["summary"]["classes"].size());
    for (std::size_t k = 0; k < whole["summary"]["classes"].size(); ++k)
      EXPECT_EQ(parts["summary"]["classes"][k]["pass"], whole["summary"]["classes"][k]["pass"]) << k;
    EXPECT_TRUE(fs::exists(dir / "wf" / "qc" / "qc.html"));
  }
  // Four strips applied, one job each, equal to applying the serial result to the whole job.
  int strips = 0;
  for (const auto& e : fs::directory_iterator(dir / "wf" / "strips")) strips += e.path().extension() == ".las";
  EXPECT_EQ(strips, 4);
  r = sh(cli() + " apply " + job + " --result " + (dir / "serial.json").string() + " --out " + (dir / "whole").string() + " --threads 2");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(slurp(dir / "wf" / "strips" / "strip_ew2.las"), slurp(dir / "whole" / "strip_ew2.las"));
  EXPECT_EQ(slurp(dir / "wf" / "strips" / "strip_ns2.las"), slurp(dir / "whole" / "strip_ns2.las"));
  // Delete one pair's file: the rerun matches that pair only, then solves and applies again.
  const fs::path victim = dir / "wf" / "pairs" / "ew2__ns1.mcpair";
  ASSERT_TRUE(fs::exists(victim));
  const std::string before = slurp(victim);
  fs::remove(victim);
  r = sh(snake);
  ASSERT_EQ(r.code, 0) << r.out;
  auto count = [&](const std::string& rule) {
    std::size_t n = 0;
    for (std::size_t at = r.out.find("rule " + rule + ":"); at != std::string::npos; at = r.out.find("rule " + rule + ":", at + 1)) ++n;
    return n;
  };
  EXPECT_EQ(count("match"), 1u) << r.out;
  EXPECT_NE(r.out.find("wildcards: a=ew2, b=ns1"), std::string::npos) << r.out;
  EXPECT_EQ(count("solve"), 1u);
  EXPECT_EQ(slurp(victim), before);  // the same pair file again
  const std::vector<double> again = mounting(dir / "wf" / "result.json");
  for (int j = 0; j < 6; ++j) EXPECT_EQ(again[j], workflow[j]);
  // The commands refuse what they cannot do, with exit 2 and the file.
  r = sh(cli() + " match " + job + " --pair ew1 nowhere --out " + (dir / "x.mcpair").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("no strip 'nowhere'"), std::string::npos) << r.out;
  r = sh(cli() + " match " + job + " --pair ew1 ew2 --out " + job);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("is an input of the job"), std::string::npos) << r.out;
  fs::create_directories(dir / "empty");
  r = sh(cli() + " calibrate " + job + " --correspondences " + (dir / "empty").string() + " --result " + (dir / "e.json").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("no pair file for strips"), std::string::npos) << r.out;
  r = sh(cli() + " apply " + job + " --result " + (dir / "serial.json").string() + " --strip nowhere --out " + (dir / "y").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("no strip 'nowhere'"), std::string::npos) << r.out;
  fs::remove_all(dir);
}
