// A hostile but realistic user (issue "Nothing lost, nothing absurd accepted"): one regression
// test per class of bad input. Each case must end with exit 2 and one line naming the file and
// the place — or a correct result where the input is valid — and never change an input or a
// good output.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <sys/wait.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "mountcal/core/error.hpp"
#include "mountcal/io/atomic_file.hpp"
#include "mountcal/io/csv.hpp"
#include "mountcal/io/sbet.hpp"
#include "real_data.hpp"
#include "support.hpp"

using namespace mountcal_tests;
using namespace mountcal;
namespace fs = std::filesystem;
using nlohmann::json;

// The fixture is outside an anonymous namespace: the TEST_F classes derive from it (GCC's
// -Wsubobject-linkage in the unity build of the tests).

/// A simulated survey (local frame, and the same in UTM zone 11 with an SBET), made once.
class Hardening : public ::testing::Test {
 protected:
  static fs::path dir() { return fs::temp_directory_path() / ("mountcal_hardening_" + std::to_string(::getpid())); }
  static fs::path field() { return dir() / "field"; }
  static fs::path utm() { return dir() / "utm"; }
  static void SetUpTestSuite() {
    fs::remove_all(dir());
    fs::create_directories(dir());
    // CTest runs every test in its own process: the surveys are simulated once per build of the
    // command (keyed by its modification time) and each process works on its own copy.
    const fs::path cache = surveyCache();
    ASSERT_FALSE(cache.empty());
    fs::copy(cache / "field", field(), fs::copy_options::recursive);
    fs::copy(cache / "utm", utm(), fs::copy_options::recursive);
  }
  static fs::path surveyCache() {
    const std::string stamp = std::to_string(std::hash<std::string>{}(MOUNTCAL_CLI)) + "_" +
                              std::to_string(fs::last_write_time(MOUNTCAL_CLI).time_since_epoch().count());
    const fs::path cache = fs::temp_directory_path() / ("mountcal_hardening_surveys_" + stamp);
    if (fs::exists(cache / "complete")) return cache;
    const fs::path tmp = cache.string() + ".tmp-" + std::to_string(::getpid());
    fs::remove_all(tmp);
    if (runCli("simulate --preset paper-calibration-field --seed 2 --out " + (tmp / "field").string()).code != 0) return {};
    if (runCli("simulate --preset paper-calibration-field --seed 2 --crs EPSG:32611 --out " + (tmp / "utm").string()).code != 0) return {};
    spit(tmp / "complete", "");
    std::error_code ec;
    fs::rename(tmp, cache, ec);  // fails when another process got there first: use theirs
    if (ec) fs::remove_all(tmp);
    return fs::exists(cache / "complete") ? cache : fs::path();
  }
  static void TearDownTestSuite() { fs::remove_all(dir()); }

  /// Every file of the field folder, to prove that nothing was changed.
  static std::map<std::string, std::string> snapshot() {
    std::map<std::string, std::string> m;
    for (const auto& e : fs::directory_iterator(field()))
      if (e.is_regular_file()) m[e.path().filename().string()] = slurp(e.path());
    return m;
  }
  /// A job variant of field/job.json written next to it.
  static std::string variant(const std::string& name, const std::function<void(json&)>& edit, const fs::path& base = field()) {
    json j = json::parse(slurp(base / "job.json"));
    edit(j);
    spit(base / name, j.dump(1));
    return (base / name).string();
  }
  /// Exit 2, one line, naming `file` and containing `what`; the field folder unchanged.
  static void expectRefused(const std::string& args, const std::string& file, const std::string& what) {
    const auto before = snapshot();
    const CommandRun r = runCli(args);
    EXPECT_EQ(r.code, 2) << args << "\n" << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find(file), std::string::npos) << "the message does not name " << file << ": " << r.err;
    EXPECT_NE(r.err.find(what), std::string::npos) << r.err;
    const auto after = snapshot();
    for (const auto& [name, content] : before) {
      auto it = after.find(name);
      EXPECT_TRUE(it != after.end() && it->second == content) << name << " changed by: " << args;
    }
  }
  static std::string withLine(const std::string& csv, int line, const std::function<std::string(const std::string&)>& edit) {
    std::istringstream in(csv);
    std::string out, l;
    for (int n = 1; std::getline(in, l); ++n) out += (n == line ? edit(l) : l) + "\n";
    return out;
  }
};

std::string replaceField(const std::string& line, int field, const std::string& value) {
  std::vector<std::string> f;
  std::stringstream ss(line);
  for (std::string c; std::getline(ss, c, ',');) f.push_back(c);
  f[static_cast<std::size_t>(field)] = value;
  std::string out;
  for (std::size_t i = 0; i < f.size(); ++i) out += (i ? "," : "") + f[i];
  return out;
}

// Outputs never replace inputs or each other, and a failed run writes nothing.
TEST_F(Hardening, OutputsNeverReplaceInputs) {
  for (const std::string target : {"ties.csv", "strip_1.las", "trajectory.csv", "o_self.json"}) {
    const std::string job = variant("o_self.json", [&](json& j) { j["output"] = {{"result", target}}; });
    expectRefused("calibrate --quiet " + job, "o_self.json:field 'output.result'", "is also an input of the job");
  }
  const std::string same = variant("o_same.json", [](json& j) { j["output"] = {{"result", "x.out"}, {"report", "./x.out"}}; });
  expectRefused("calibrate --quiet " + same, "field 'output.report'", "is also output.result");
  // A report that cannot be written: refused before the solve, and the result not written.
  const std::string nofolder = variant("o_nofolder.json", [](json& j) {
    j["output"] = {{"result", "r_nofolder.json"}, {"report", "/nonexistent/r.html"}};
  });
  expectRefused("calibrate --quiet " + nofolder, "field 'output.report'", "does not exist");
  EXPECT_FALSE(fs::exists(field() / "r_nofolder.json"));
  // apply: onto the inputs' own folder, and onto the result file it reads.
  ASSERT_EQ(runCli("calibrate --quiet " + (field() / "job.json").string()).code, 0);
  expectRefused(
      "apply " + (field() / "job.json").string() + " --result " + (field() / "result.json").string() + " --out " + field().string(),
      "strip_1.las", "apply would overwrite an input");
  spit(dir() / "strip_1.las", "a result file that looks like a strip's output");
  fs::copy_file(field() / "result.json", dir() / "strip_1.las", fs::copy_options::overwrite_existing);
  const CommandRun r =
      runCli("apply " + (field() / "job.json").string() + " --result " + (dir() / "strip_1.las").string() + " --out " + dir().string());
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("apply would overwrite an input"), std::string::npos) << r.err;
}

// writeFilesAtomically: when the second file fails, the first keeps its previous content.
TEST_F(Hardening, SeveralOutputsAllOrNothing) {
  const fs::path a = dir() / "a.txt";
  spit(a, "previous");
  EXPECT_THROW(io::writeFilesAtomically({{a.string(), "new"}, {(dir() / "no" / "b.txt").string(), "b"}}), FileError);
  EXPECT_EQ(slurp(a), "previous");
  EXPECT_THROW(io::writeFilesAtomically({{a.string(), "1"}, {(dir() / "." / "a.txt").string(), "2"}}), FileError);
  EXPECT_EQ(slurp(a), "previous");
  io::writeFilesAtomically({{a.string(), "new"}, {(dir() / "b.txt").string(), "b"}});
  EXPECT_EQ(slurp(a), "new");
  EXPECT_EQ(slurp(dir() / "b.txt"), "b");
  for (const auto& e : fs::directory_iterator(dir())) EXPECT_EQ(e.path().string().find(".tmp-"), std::string::npos) << e.path();
}

// Finite but absurd values: refused with the file and the place.
TEST_F(Hardening, AbsurdValuesAreRefused) {
  const std::string traj = slurp(field() / "trajectory.csv");
  spit(field() / "t_att.csv", withLine(traj, 100, [](const std::string& l) { return replaceField(l, 4, "1e300"); }));
  expectRefused("calibrate --quiet " + variant("a_att.json", [](json& j) { j["trajectory"]["path"] = "t_att.csv"; }), "t_att.csv:line 100",
                "attitude");
  spit(field() / "t_pos.csv", withLine(traj, 100, [](const std::string& l) { return replaceField(l, 1, "1e300"); }));
  expectRefused("calibrate --quiet " + variant("a_pos.json", [](json& j) { j["trajectory"]["path"] = "t_pos.csv"; }), "t_pos.csv:line 100",
                "no platform flies");
  expectRefused("calibrate --quiet " + variant("a_rad.json", [](json& j) { j["vtpm"]["radius_m"] = 1e6; }), "field 'vtpm.radius_m'",
                "expected a number in");
  expectRefused("calibrate --quiet " + variant("a_sig.json", [](json& j) { j["vtpm"]["tie_sigma_xy_m"] = 1e300; }),
                "field 'vtpm.tie_sigma_xy_m'", "expected a number in");
  expectRefused("calibrate --quiet " + variant("a_neg.json", [](json& j) { j["vtpm"]["strip_offset_sigma_m"] = -1; }),
                "field 'vtpm.strip_offset_sigma_m'", "expected a number in");
  // A LAS scale that puts points 1e305 m away while the header bounds say a few hundred metres.
  std::string las = slurp(field() / "strip_1.las");
  const double scale = 1e296;
  std::memcpy(&las[131], &scale, 8);
  spit(field() / "s_scale.las", las);
  expectRefused("calibrate --quiet " + variant("a_scale.json", [](json& j) { j["strips"][0]["path"] = "s_scale.las"; }),
                "s_scale.las:record 0", "outside the header's bounds");
  // Every GPS time of a strip equal.
  las = slurp(field() / "strip_1.las");
  std::uint32_t offset;
  std::uint64_t count;
  std::memcpy(&offset, &las[96], 4);
  std::memcpy(&count, &las[247], 8);
  const double t = 1.0e5;
  for (std::uint64_t i = 0; i < count; ++i) std::memcpy(&las[offset + i * 30 + 22], &t, 8);
  spit(field() / "s_time.las", las);
  expectRefused("calibrate --quiet " + variant("a_time.json", [](json& j) { j["strips"][0]["path"] = "s_time.las"; }), "s_time.las",
                "the times are not the pulse times");
  // Strips in another UTM zone than the trajectory (SBET): the laser ranges give it away.
  const std::string zone = variant(
      "zone.json", [](json& j) { j["frame"]["crs"] = "EPSG:32612"; }, utm());
  const CommandRun z = runCli("calibrate --quiet " + zone);
  EXPECT_EQ(z.code, 2) << z.err;
  EXPECT_NE(z.err.find("strips and trajectory do not agree in space"), std::string::npos) << z.err;
  // An SBET attitude of 1e300 rad.
  std::vector<io::SbetRecord> sbet = io::readSbet((utm() / "trajectory.sbet").string());
  sbet[7].roll_rad = 1e300;
  io::writeSbet((utm() / "bad.sbet").string(), sbet);
  const std::string badsbet = variant(
      "badsbet.json", [](json& j) { j["trajectory"]["path"] = "bad.sbet"; }, utm());
  const CommandRun s = runCli("calibrate --quiet " + badsbet);
  EXPECT_EQ(s.code, 2) << s.err;
  EXPECT_NE(s.err.find("bad.sbet:record 7: attitude"), std::string::npos) << s.err;
}

// The same tie picked twice on one strip, identically or metres apart.
TEST_F(Hardening, DuplicateTiesAreRefusedNamingBothLines) {
  const std::string ties = slurp(field() / "ties.csv");
  std::istringstream in(ties);
  std::string header, first;
  std::getline(in, header);
  std::getline(in, first);
  const int last_line = static_cast<int>(std::count(ties.begin(), ties.end(), '\n')) + 1;
  spit(field() / "ties_dup.csv", ties + first + "\n");
  expectRefused("calibrate --quiet " + variant("d1.json", [](json& j) { j["ties"] = "ties_dup.csv"; }),
                "ties_dup.csv:lines 2 and " + std::to_string(last_line), "is picked twice on strip");
  std::stringstream ss(first);
  std::string id, strip;
  std::getline(ss, id, ',');
  std::getline(ss, strip, ',');
  spit(field() / "ties_dup2.csv", ties + id + "," + strip + ",0.0,0.0\n");
  expectRefused("calibrate --quiet " + variant("d2.json", [](json& j) { j["ties"] = "ties_dup2.csv"; }), "ties_dup2.csv:lines 2 and",
                "is picked twice");
}

// Inputs that used to end as internal errors (exit 3) are bad input naming the file.
TEST_F(Hardening, MalformedJobsAreBadInputNotInternalErrors) {
  std::string j = slurp(field() / "job.json");
  const auto at = j.find("\"max_iterations\": 100");
  ASSERT_NE(at, std::string::npos);
  // Where the JSON goes wrong is said as line and column (1-based), counted here by hand.
  const auto lineColumn = [](const std::string& text, std::size_t byte) {
    const std::size_t line = 1 + static_cast<std::size_t>(std::count(text.begin(), text.begin() + static_cast<long>(byte), '\n'));
    const std::size_t nl = text.rfind('\n', byte == 0 ? 0 : byte - 1);
    const std::size_t column = byte - (nl == std::string::npos || byte == 0 ? 0 : nl + 1) + 1;
    return "line " + std::to_string(line) + ", column " + std::to_string(column);
  };
  std::string big = j;
  big.replace(at, 21, "\"max_iterations\": 1e999");
  spit(field() / "i_big.json", big);
  expectRefused("calibrate --quiet " + (field() / "i_big.json").string(), "i_big.json:" + lineColumn(big, at + 18),
                "the number 1e999 does not fit a double");
  std::string broken = j;
  const std::size_t comma = broken.find(',', at);
  broken.erase(comma, 1);  // the comma after max_iterations: the next key is unexpected
  const std::size_t next = broken.find('"', comma);
  spit(field() / "i_syntax.json", broken);
  const std::string at_next = lineColumn(broken, next);  // the parser stops within that token: its line
  expectRefused("calibrate --quiet " + (field() / "i_syntax.json").string(),
                "i_syntax.json:" + at_next.substr(0, at_next.find(',')) + ", column", "invalid JSON");
  fs::create_directories(field() / "adir");
  expectRefused("calibrate --quiet " + (field() / "adir").string(), "adir", "is a folder");
  fs::remove(field() / "adir");
  const std::string ties = slurp(field() / "ties.csv");
  spit(field() / "ties_utf.csv", withLine(ties, 2, [](const std::string& l) { return "\xff\xfe" + l; }));
  expectRefused("calibrate --quiet " + variant("i_utf.json", [](json& v) { v["ties"] = "ties_utf.csv"; }), "ties_utf.csv:line 2",
                "not valid UTF-8");
  expectRefused("calibrate --quiet " + variant("i_25.json", [](json& v) { v["solver"]["max_iterations"] = 2.5; }),
                "field 'solver.max_iterations'", "expected an integer");
  expectRefused("calibrate --quiet " + variant("i_300.json", [](json& v) { v["solver"]["max_iterations"] = 1e300; }),
                "field 'solver.max_iterations'", "expected an integer");
}

// Endless or absurd sizes: bounded, refused.
TEST_F(Hardening, ResourcesStayBounded) {
  expectRefused("calibrate --quiet " + variant("r_zero.json", [](json& j) { j["ties"] = "/dev/zero"; }), "/dev/zero:line 1", "longer than");
  spit(dir() / "neg_roi.json", R"({"preset": "paper-calibration-field", "roi_radius_m": -5})");
  const CommandRun r = runCli("simulate " + (dir() / "neg_roi.json").string() + " --out " + (dir() / "neg").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("neg_roi.json:field 'roi_radius_m'"), std::string::npos) << r.err;
  spit(dir() / "neg_noise.json", R"({"preset": "paper-calibration-field", "noise": {"range_sigma_m": -1}})");
  const CommandRun n = runCli("simulate " + (dir() / "neg_noise.json").string() + " --out " + (dir() / "neg").string());
  EXPECT_EQ(n.code, 2);
  EXPECT_NE(n.err.find("field 'noise.range_sigma_m'"), std::string::npos) << n.err;
}

// Messages that name the file and where.
TEST_F(Hardening, MessagesSayWhere) {
  const std::string cps = slurp(field() / "check_points.csv");
  spit(field() / "cp_bad.csv", withLine(cps, 2, [](const std::string& l) { return replaceField(l, 1, "99"); }));
  expectRefused("calibrate --quiet " + variant("m_cp.json", [](json& j) { j["check_points"] = "cp_bad.csv"; }), "cp_bad.csv:line 2", "99");
  const std::string las = slurp(field() / "strip_1.las");
  std::uint32_t offset;
  std::memcpy(&offset, &las[96], 4);
  std::string empty = las.substr(0, offset);
  const std::uint64_t zero = 0;
  std::memcpy(&empty[247], &zero, 8);
  std::memcpy(&empty[107], &zero, 4);
  spit(field() / "s_empty.las", empty);
  expectRefused("calibrate --quiet " + variant("m_empty.json", [](json& j) { j["strips"][0]["path"] = "s_empty.las"; }), "s_empty.las",
                "has no points");
  fs::create_directories(dir() / "adir");
  const CommandRun d = runCli("info " + (dir() / "adir").string());
  EXPECT_EQ(d.code, 2);
  EXPECT_NE(d.err.find("adir"), std::string::npos) << d.err;
  // A pipe has no size: no bogus byte counts in the message, whatever the reader.
  for (const std::string name : {"pipe.sbet", "pipe.las"}) {
    const fs::path pipe = dir() / name;
    fs::remove(pipe);
    ASSERT_EQ(::mkfifo(pipe.c_str(), 0600), 0);
    // The command reads the pipe while an empty writer opens it (and gives up after 5 s if
    // nobody reads, so the test never hangs).
    const fs::path err = dir() / "pipe_err.txt";
    const int status = std::system(("(" + std::string(MOUNTCAL_CLI) + " info " + pipe.string() + " > /dev/null 2> " + err.string() +
                                    "; echo $? >> " + err.string() + ") & timeout 5 sh -c 'cat /dev/null > " + pipe.string() + "'; wait")
                                       .c_str());
    (void)status;
    const std::string p = slurp(err);
    EXPECT_NE(p.find(name + ": cannot determine the file size"), std::string::npos) << p;
    EXPECT_NE(p.find("\n2\n"), std::string::npos) << p;  // exit 2
    EXPECT_EQ(p.find("18446744073709551"), std::string::npos) << p;
    fs::remove(pipe);
  }
  spit(dir() / "sc_type.json", R"({"preset": "paper-calibration-field", "roi_radius_m": "big"})");
  const CommandRun t = runCli("simulate " + (dir() / "sc_type.json").string() + " --out " + (dir() / "t").string());
  EXPECT_EQ(t.code, 2);
  EXPECT_NE(t.err.find("sc_type.json"), std::string::npos) << t.err;
}

// A UTF-8 byte-order mark (as spreadsheets write) is accepted, with the same result.
TEST_F(Hardening, ByteOrderMarkIsAccepted) {
  spit(field() / "ties_bom.csv", "\xEF\xBB\xBF" + slurp(field() / "ties.csv"));
  spit(field() / "traj_bom.csv", "\xEF\xBB\xBF" + slurp(field() / "trajectory.csv"));
  const std::string plain = variant("bom0.json", [](json& j) { j["output"] = {{"result", "bom0.result.json"}}; });
  const std::string bom = variant("bom1.json", [](json& j) {
    j["ties"] = "ties_bom.csv";
    j["trajectory"]["path"] = "traj_bom.csv";
    j["output"] = {{"result", "bom1.result.json"}};
  });
  ASSERT_EQ(runCli("calibrate --quiet " + plain).code, 0);
  const CommandRun r = runCli("calibrate --quiet " + bom);
  ASSERT_EQ(r.code, 0) << r.err;
  const json a = json::parse(slurp(field() / "bom0.result.json")), b = json::parse(slurp(field() / "bom1.result.json"));
  // The same observations; two VTPM solves agree to ~1e-9 (Ceres orders the eliminated tie
  // blocks by their addresses, so its Schur sums round differently from run to run, and the
  // solver stops at its tolerance on either path).
  for (const char* k : {"lever_arm_m", "boresight_deg"})
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(a["mounting"][k][j].get<double>(), b["mounting"][k][j].get<double>(), 1e-7) << k << j;
}

// Geographic CRSs (degrees) for strips: refused by the simulator and in jobs.
TEST_F(Hardening, GeographicCrsIsRefused) {
  const CommandRun r = runCli("simulate --preset paper-calibration-field --crs EPSG:4326 --out " + (dir() / "geo").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("geographic"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir() / "geo" / "job.json"));
  const std::string job = variant(
      "geo.json", [](json& j) { j["frame"]["crs"] = "EPSG:4326"; }, utm());
  const CommandRun g = runCli("calibrate --quiet " + job);
  EXPECT_EQ(g.code, 2);
  EXPECT_NE(g.err.find("geo.json:field 'frame.crs'"), std::string::npos) << g.err;
}

// ---- The second battery (issue 30): the newer commands ---------------------------------------

// apply fails on the fourth strip (a record's GPS time outside the trajectory): every output
// the folder held from an earlier run is unchanged, and no temporary file is left — on one
// thread and on two.
TEST_F(Hardening, FailedApplyLeavesEveryEarlierOutput) {
  const std::string job = (field() / "job.json").string();
  ASSERT_EQ(runCli("calibrate --quiet " + job).code, 0);
  const fs::path out = dir() / "applied";
  ASSERT_EQ(runCli("apply " + job + " --result " + (field() / "result.json").string() + " --out " + out.string()).code, 0);
  std::map<std::string, std::string> before;
  for (const auto& e : fs::directory_iterator(out)) before[e.path().filename().string()] = slurp(e.path());
  ASSERT_EQ(before.size(), 4u);
  // Another mounting, and a copy of the survey whose strip_4 is corrupt half-way.
  json r = json::parse(slurp(field() / "result.json"));
  r["mounting"]["boresight_deg"][2] = r["mounting"]["boresight_deg"][2].get<double>() + 0.5;
  spit(dir() / "r2.json", r.dump());
  const fs::path bad = dir() / "bad";
  fs::create_directories(bad);
  for (const char* f : {"job.json", "trajectory.csv", "strip_1.las", "strip_2.las", "strip_3.las", "strip_4.las", "ties.csv",
                        "check_points.csv", "check_planes.csv", "planes.csv"})
    fs::copy_file(field() / f, bad / f);
  std::string las = slurp(bad / "strip_4.las");
  std::uint32_t offset;
  std::memcpy(&offset, &las[96], 4);
  const double t = 1e12;
  std::memcpy(&las[offset + 30000 * 30 + 22], &t, 8);  // format 6: GPS time at byte 22 of the record
  spit(bad / "strip_4.las", las);
  for (const char* threads : {"1", "2"}) {
    const CommandRun a = runCli("apply " + (bad / "job.json").string() + " --result " + (dir() / "r2.json").string() + " --out " +
                                out.string() + " --threads " + threads);
    EXPECT_EQ(a.code, 2) << a.err;
    EXPECT_NE(a.err.find("strip_4.las:record 30000"), std::string::npos) << a.err;
    std::map<std::string, std::string> after;
    for (const auto& e : fs::directory_iterator(out)) after[e.path().filename().string()] = slurp(e.path());
    EXPECT_TRUE(after == before) << "a failed apply changed the output folder (" << threads << " threads)";
    for (const auto& e : fs::directory_iterator(bad)) EXPECT_EQ(e.path().string().find(".tmp-"), std::string::npos) << e.path();
  }
  // The same run on good strips replaces all four.
  ASSERT_EQ(runCli("apply " + job + " --result " + (dir() / "r2.json").string() + " --out " + out.string()).code, 0);
  for (const auto& [name, content] : before) EXPECT_NE(slurp(out / name), content) << name;
}

// The pair files of --correspondences are inputs: --result cannot replace one; a pair file that
// names a strip the job does not list, or one strip twice, is refused naming the file.
TEST_F(Hardening, PairFilesAreInputsAndNameTheirStrips) {
  const std::string job = variant("pf.json", [](json& j) {
    j["method"] = "correspondences";
    j.erase("ties");
    j["output"] = {{"result", "pf.result.json"}};
  });
  const fs::path pairs = dir() / "pairs";
  fs::create_directories(pairs);
  ASSERT_EQ(runCli("match " + job + " --pair 1 2 --out " + (pairs / "1_2.mcpair").string()).code, 0);
  const std::string pair_file = slurp(pairs / "1_2.mcpair");
  const CommandRun r =
      runCli("calibrate --quiet " + job + " --correspondences " + pairs.string() + " --result " + (pairs / "1_2.mcpair").string());
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("is also an input of the job"), std::string::npos) << r.err;
  EXPECT_EQ(slurp(pairs / "1_2.mcpair"), pair_file);
  // The job's strips renamed: the pair file's strip '1' is unknown.
  const std::string renamed = variant("pf_renamed.json", [](json& j) {
    j["method"] = "correspondences";
    j.erase("ties");
    j.erase("check_points");
    for (auto& s : j["strips"]) s["id"] = "s" + s["id"].get<std::string>();
  });
  const CommandRun u = runCli("calibrate --quiet " + renamed + " --correspondences " + pairs.string());
  EXPECT_EQ(u.code, 2) << u.err;
  EXPECT_NE(u.err.find("1_2.mcpair: names strip '1', which"), std::string::npos) << u.err;
  const CommandRun self = runCli("match " + job + " --pair 1 1 --out " + (pairs / "1_1.mcpair").string());
  EXPECT_EQ(self.code, 2) << self.err;
  EXPECT_NE(self.err.find("a pair of one strip"), std::string::npos) << self.err;
}

// Regions beyond the data and plans beyond the simulator's budget: refused before the work,
// naming the file and the line.
TEST_F(Hardening, RegionsAndPlansAreBoundedBeforeTheWork) {
  spit(field() / "p_huge.csv", "plane_id,xmin,ymin,xmax,ymax\nroof,-1e6,-1e6,1e6,1e6\n");
  expectRefused("calibrate --quiet " + variant("r_planes.json",
                                               [](json& j) {
                                                 j["method"] = "planes";
                                                 j["planes"] = "p_huge.csv";
                                               }),
                "p_huge.csv:line 2", "reaches beyond the strips' extent");
  expectRefused("calibrate --quiet " + variant("r_check.json", [](json& j) { j["check_planes"] = "p_huge.csv"; }), "p_huge.csv:line 2",
                "reaches beyond");
  const json base = json::parse(R"({"name": "bounded", "sensor": {"type": "line"},
    "lines": [{"id": "1", "start": [-400, 0], "end": [400, 0], "height_m": 500},
              {"id": "2", "start": [0, -400], "end": [0, 400], "height_m": 500}],
    "ground": {"roofs": [{"id": "h", "centre": [20, 30]}], "targets": [{"id": "t", "centre": [-50, -40]}]}, "method": "vtpm"})");
  auto plan = [&](const std::string& name, const std::function<void(json&)>& edit) {
    json p = base;
    edit(p);
    spit(dir() / name, p.dump());
    return (dir() / name).string();
  };
  const std::string slow = plan("slow.json", [](json& p) {
    p["lines"][0]["start"] = {-50000, 0};
    p["lines"][0]["end"] = {50000, 0};
    p["lines"][0]["speed_mps"] = 0.5;
  });
  CommandRun r = runCli("plan --no-candidates " + slow);
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("slow.json: survey 'bounded': flight line '1' takes 200000 s"), std::string::npos) << r.err;
  const std::string walking = plan("walking.json", [](json& p) {
    p["lines"][0]["start"] = {-1500, 0};
    p["lines"][0]["end"] = {1500, 0};
    for (auto& l : p["lines"]) l["speed_mps"] = 0.5;
    p["sensor"]["prf_hz"] = 2e6;
  });
  r = runCli("plan --no-candidates " + walking);
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("walking.json: survey 'bounded': more than 2e+06 points stored"), std::string::npos) << r.err;
  const std::string far = plan("far.json", [](json& p) {
    for (auto& l : p["lines"]) l["start"][0] = l["start"][0].get<double>() + 5000, l["end"][0] = l["end"][0].get<double>() + 5000;
  });
  r = runCli("plan --no-candidates " + far);
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("far.json: no beam of the planned lines reaches the ground"), std::string::npos) << r.err;
  EXPECT_EQ(runCli("plan --no-candidates " + plan("ok.json", [](json&) {})).code, 0);
}

// "Nothing solved" is never success: strips cut into single records give no correspondence
// (exit 1, the verdict says why); two strips that are the same records are bad input.
TEST_F(Hardening, NothingSolvedIsNotSuccessAndAPassIsNotMatchedWithItself) {
  auto split = [](int part_a, const std::string& file_b, int part_b) {
    return [=](json& j) {
      j["method"] = "correspondences";
      for (const char* k : {"ties", "check_points", "check_planes", "planes"}) j.erase(k);
      j["output"] = {{"result", "split.result.json"}};
      j["strips"] = {{{"id", "a"}, {"path", "strip_1.las"}, {"split", {{"field", "gps_time"}, {"part", part_a}, {"gap", 0}}}},
                     {{"id", "b"}, {"path", file_b}, {"split", {{"field", "gps_time"}, {"part", part_b}, {"gap", 0}}}}};
    };
  };
  const CommandRun tiny = runCli("calibrate --quiet " + variant("split_tiny.json", split(5, "strip_2.las", 7)));
  EXPECT_EQ(tiny.code, 1) << tiny.err;
  EXPECT_NE(tiny.err.find("not usable"), std::string::npos) << tiny.err;
  expectRefused("calibrate --quiet " + variant("split_self.json", split(5, "strip_1.las", 5)), "split_self.json:field 'strips[1]'",
                "two strips must be different passes");
  expectRefused("calibrate --quiet " + variant("same_file.json", [](json& j) { j["strips"][1]["path"] = "./strip_1.las"; }),
                "same_file.json:field 'strips[1]'", "two strips must be different passes");
}

// Malformed requests: refused with the file (or option) and the place, never dropped silently.
TEST_F(Hardening, MalformedRequestsAreRefused) {
  const std::string job = (field() / "job.json").string();
  const std::string planes = slurp(field() / "planes.csv");  // its first region again at the end
  const std::size_t l1 = planes.find('\n') + 1, l2 = planes.find('\n', l1) + 1;
  spit(field() / "p_twice.csv", planes + planes.substr(l1, l2 - l1));
  expectRefused("calibrate --quiet " + variant("twice.json",
                                               [](json& j) {
                                                 j["method"] = "planes";
                                                 j["planes"] = "p_twice.csv";
                                               }),
                "p_twice.csv:line", "is listed twice (also on line 2)");
  for (const std::string profile : {"0,0,0,0", "0,0,10,10,1,7", "0,0,10", "0,0,x,1"}) {
    const CommandRun r = runCli("calibrate --quiet " + job + " --profile " + profile + " --report " + (dir() / "p.html").string());
    EXPECT_EQ(r.code, 2) << profile << ": " << r.err;
    EXPECT_NE(r.err.find("--profile " + profile), std::string::npos) << r.err;
  }
  expectRefused("convert " + (field() / "strip_1.las").string() + " " + (dir() / "out.txt").string(), "out.txt", "extension");
  EXPECT_FALSE(fs::exists(dir() / "out.txt"));
  const CommandRun unknown = runCli("calibrat " + job);
  EXPECT_EQ(unknown.code, 2);
  EXPECT_NE(unknown.err.find("unknown subcommand 'calibrat'"), std::string::npos) << unknown.err;
  // Absurd result values are the result file's fault.
  ASSERT_EQ(runCli("calibrate --quiet " + job).code, 0);
  json r = json::parse(slurp(field() / "result.json"));
  r["mounting"]["boresight_deg"][0] = 1e300;
  spit(dir() / "r_angle.json", r.dump());
  r = json::parse(slurp(field() / "result.json"));
  r["mounting"]["lever_arm_m"][1] = 1e300;
  spit(dir() / "r_lever.json", r.dump());
  expectRefused("apply " + job + " --result " + (dir() / "r_angle.json").string() + " --out " + (dir() / "o1").string(),
                "r_angle.json:field 'mounting.boresight_deg'", "beyond ±180°");
  expectRefused("apply " + job + " --result " + (dir() / "r_lever.json").string() + " --out " + (dir() / "o2").string(),
                "r_lever.json:field 'mounting.lever_arm_m'", "beyond ±1000 m");
  EXPECT_FALSE(fs::exists(dir() / "o1") && !fs::is_empty(dir() / "o1"));
  // The simulator's truth: a lever arm of 1e300 m.
  spit(dir() / "sc_lever.json", R"({"preset": "paper-calibration-field", "true_mounting": {"lever_arm_m": [0, 1e300, 0]}})");
  const CommandRun s = runCli("simulate " + (dir() / "sc_lever.json").string() + " --out " + (dir() / "lever").string());
  EXPECT_EQ(s.code, 2);
  EXPECT_NE(s.err.find("sc_lever.json:field 'true_mounting.lever_arm_m'"), std::string::npos) << s.err;
  EXPECT_FALSE(fs::exists(dir() / "lever" / "job.json"));
  // A LAS whose offset to the point data lies inside its header.
  std::string las = slurp(field() / "strip_1.las");
  const std::uint32_t inside = 200;
  std::memcpy(&las[96], &inside, 4);
  spit(dir() / "inside.las", las);
  const CommandRun i = runCli("info " + (dir() / "inside.las").string());
  EXPECT_EQ(i.code, 2);
  EXPECT_NE(i.err.find("inside.las:byte 96: offset to point data 200 lies inside the header"), std::string::npos) << i.err;
  // A laser id beyond 32 bits in a raw CSV: refused naming the line, not wrapped to a valid id.
  spit(dir() / "raw_mb.csv", "time,laser_id,azimuth_deg,range_m,intensity\n1.0,3,10,20,5\n1.1,4294967305,10,20,5\n");
  try {
    io::readRawCsv((dir() / "raw_mb.csv").string(), SensorType::kMultiBeam);
    FAIL() << "no exception";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("raw_mb.csv:line 3: column 'laser_id'"), std::string::npos) << e.what();
  }
}

// Scenario fields of the wrong type name the field.
TEST_F(Hardening, ScenarioFieldsOfTheWrongTypeAreNamed) {
  for (const auto& [text, field_name] : std::vector<std::pair<std::string, std::string>>{
           {R"({"preset": "paper-calibration-field", "one_height": 3})", "field 'one_height'"},
           {R"({"preset": "paper-calibration-field", "noise": {"range_sigma_m": "x"}})", "field 'noise.range_sigma_m'"},
           {R"({"preset": "paper-calibration-field", "true_mounting": {"boresight_deg": [0, "a", 0]}})",
            "field 'true_mounting.boresight_deg'"},
           {R"({"preset": "paper-calibration-field", "seed": 2.5})", "field 'seed'"},
           {R"({"preset": 7})", "field 'preset'"}}) {
    spit(dir() / "sc.json", text);
    const CommandRun r = runCli("simulate " + (dir() / "sc.json").string() + " --out " + (dir() / "sc_out").string());
    EXPECT_EQ(r.code, 2) << text;
    EXPECT_NE(r.err.find("sc.json:" + field_name), std::string::npos) << text << "\n" << r.err;
  }
}

// info: the CRS (WKT written by simulate --crs; GeoTIFF keys of the Gravity files), the
// extra-bytes types, and points by class and return.
TEST_F(Hardening, InfoShowsTheCrsAndTheExtraBytesTypes) {
  const CommandRun u = runCli("info " + (utm() / "strip_1.las").string());
  ASSERT_EQ(u.code, 0);
  EXPECT_NE(u.out.find("CRS: EPSG:32611 'WGS 84 / UTM zone 11N' (WKT)"), std::string::npos) << u.out;
  EXPECT_NE(u.out.find("points by class: 2: "), std::string::npos) << u.out;
  EXPECT_NE(u.out.find("points by return number: 1: "), std::string::npos) << u.out;
  const CommandRun l = runCli("info " + (field() / "strip_1.las").string());
  EXPECT_NE(l.out.find("CRS: none declared"), std::string::npos) << l.out;
  REQUIRE_DATA("gravity/Car.las");
  const CommandRun g = runCli("info " + dataFile("gravity/Car.las"));
  ASSERT_EQ(g.code, 0);
  // The file's GeoKeyDirectory: ProjectedCSTypeGeoKey 32613 (UTM zone 13 N); its WKT record is empty.
  EXPECT_NE(g.out.find("CRS: EPSG:32613 (GeoTIFF ProjectedCSTypeGeoKey)"), std::string::npos) << g.out;
  EXPECT_NE(g.out.find("extra bytes: SensorX                  double"), std::string::npos) << g.out;
  EXPECT_NE(g.out.find("extra bytes: frameNo                  int32"), std::string::npos) << g.out;
}
