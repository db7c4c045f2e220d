// The method registry (methods/method.hpp): methods are modules registered by name, their job
// options declared once; a toy method from the test tree (tests/methods/toy/) runs end to end.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "mountcal/mountcal.hpp"
#include "support.hpp"

namespace fs = std::filesystem;
using namespace mountcal;
using namespace mountcal_tests;
using nlohmann::json;

namespace {

json readJson(const std::string& path) {
  std::ifstream f(path);
  return json::parse(f);
}

void writeJson(const std::string& path, const json& j) { std::ofstream(path) << j.dump(2); }

fs::path freshDir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("mountcal_registry_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

/// `bad` written to `path` and read: refused with a FileError whose message names `field`.
void expectRefusedNaming(const std::string& path, const json& bad, const std::string& field) {
  writeJson(path, bad);
  try {
    readJob(path);
    ADD_FAILURE() << "accepted: " << bad.dump();
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
  }
}

/// The smallest valid job: one strip, ties, a local frame (files need not exist to be read).
json minimalJob() {
  return {{"frame", {{"type", "local"}}},
          {"trajectory", {{"path", "t.csv"}}},
          {"sensor", {{"type", "line"}}},
          {"mounting_used", {{"lever_arm_m", {0, 0, 0}}, {"boresight_deg", {0, 0, 0}}}},
          {"strips", {{{"id", "1"}, {"path", "1.las"}}}},
          {"ties", "ties.csv"}};
}

}  // namespace

TEST(Registry, BuiltInMethodsComeFirstInTheOrderTheyJoinTheAdjustment) {
  std::vector<std::string> names;
  for (const auto& m : registeredMethods()) names.push_back(m->name());
  ASSERT_GE(names.size(), 6u);
  const std::vector<std::string> builtin = {"vtpm", "control", "planes", "correspondences", "features"};
  EXPECT_EQ(std::vector<std::string>(names.begin(), names.begin() + 5), builtin);
  EXPECT_NE(findMethod("toy"), nullptr);  // registered by the test tree's toy module
  EXPECT_TRUE(findMethod("control")->implicit());
  EXPECT_EQ(methodNames().find("control"), std::string::npos);                                        // not a name a job gives in "method"
  EXPECT_THROW(registerMethod(findMethod("vtpm") ? registeredMethods()[0] : nullptr), InvalidInput);  // names are unique
}

TEST(Registry, DeclaredRangesAreCheckedAndTheMessageNamesMethodAndOption) {
  MountingCalibrator::Options o;
  std::string why;
  ASSERT_TRUE(o.IsValid(&why)) << why;
  o.method<PlaneOptions>().sigma_m = -1;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("planes.sigma_m"), std::string::npos) << why;
  o.method<PlaneOptions>().sigma_m = 0;
  o.method<PlaneOptions>().max_points_per_strip = 4;  // a relation the method checks itself
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("planes: max_points_per_strip"), std::string::npos) << why;
  o = MountingCalibrator::Options{};
  o.methods = {"nope"};
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("unknown method 'nope'"), std::string::npos) << why;
  o.methods = {"control"};
  EXPECT_FALSE(o.IsValid(&why)) << "ground control is not a method a job names";
}

TEST(Registry, EveryDeclaredOptionIsReadFromAJobAndWrittenBack) {
  const fs::path dir = freshDir("options");
  // A job naming every method's every option with a value other than its default.
  json j = minimalJob();
  j["targets"] = "targets.csv";
  // The features' and the correspondences' options are read and written back without those methods
  // being named: named beside the planes (whose laser_elevation_sigma_deg is set here), each would
  // estimate per-laser offsets too, which one calibration refuses.
  j["method"] = {"vtpm", "planes"};
  j["planes"] = {{"regions", "auto"}};
  std::map<std::string, std::map<std::string, double>> given;
  for (const auto& m : registeredMethods()) {
    const std::any defaults = m->defaultOptions();
    for (const OptionSpec& s : m->options()) {
      double v = s.get(defaults);
      if (s.type == OptionSpec::Type::kBoolean) {
        v = v != 0 ? 0 : 1;
        j[m->name()][s.key] = v != 0;
      } else if (s.type == OptionSpec::Type::kChoice) {  // the next name
        ASSERT_EQ(s.max + 1, static_cast<double>(s.choices.size())) << s.key;
        v = v < s.max ? v + 1 : 0;
        j[m->name()][s.key] = s.choices[static_cast<std::size_t>(v)];
      } else {
        v = v < s.max ? std::min(s.max, std::floor(v) + 1) : s.min;                   // another value in range
        if (s.key == "min_points_per_strip" || s.key == "min_neighbours") v = s.min;  // keep min <= max
        j[m->name()][s.key] = v;
      }
      given[m->name()][s.key] = v;
    }
  }
  const std::string path = (dir / "job.json").string();
  writeJson(path, j);
  const Job job = readJob(path);
  EXPECT_TRUE(job.planes_auto);
  auto check = [&](const Job& jb, const std::string& what) {
    for (const auto& m : registeredMethods()) {
      const std::any defaults = m->defaultOptions();
      const std::any& options = jb.options.method_options.at(m->name(), defaults);
      for (const OptionSpec& s : m->options())
        EXPECT_EQ(s.get(options), given[m->name()][s.key]) << what << ": " << m->name() << "." << s.key;
    }
  };
  check(job, "read");
  const std::string again = (dir / "again.json").string();
  std::ofstream(again) << jobJson(job);
  Job back = readJob(again);
  check(back, "written and read again");
  EXPECT_TRUE(back.planes_auto);
  // A choice is one of its names: another string, a number or the enum's index is refused with
  // the field and the names.
  for (const json& bad : {json("rigid"), json(2), json("Neighbourhood")}) {
    json k = minimalJob();
    k["vtpm"] = {{"motion", bad}};
    writeJson(path, k);
    try {
      readJob(path);
      FAIL() << bad.dump();
    } catch (const FileError& e) {
      EXPECT_NE(std::string(e.what()).find("vtpm.motion"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("expected one of \"auto\", \"triangle\", \"neighbourhood\""), std::string::npos) << e.what();
    }
  }
  json k = minimalJob();
  k["vtpm"] = {{"motion", "neighbourhood"}};
  writeJson(path, k);
  EXPECT_EQ(readJob(path).options.method<VtpmOptions>().vtp.motion, VtpMotion::kNeighbourhood);
}

// The matching defaults of a multi-beam job come from the sensor's range accuracy, which has one
// home (MultiBeamModel::rangeAccuracy: the VLP-16's 3 cm and the HDL-32E's 2 cm from their
// manuals; sensor.range_accuracy_m for a laser table or to override): a plane rougher than 1.5 ×
// it is rough and the Cauchy loss's scale is 1.5 × it (3 cm when unknown). Written back and read
// again; a negative accuracy is refused with the field.
TEST(Registry, MatchingDefaultsFollowTheSensorsRangeAccuracy) {
  const fs::path dir = freshDir("accuracy");
  auto read = [&](const json& sensor) {
    json j = minimalJob();
    j.erase("ties");
    j["method"] = "correspondences";
    j["sensor"] = sensor;
    const std::string path = (dir / "job.json").string();
    writeJson(path, j);
    return readJob(path);
  };
  const json lasers = json::array({{{"elevation_deg", -15}}, {{"elevation_deg", 15}}});
  struct Case {
    json sensor;
    double roughness, loss_scale;
  };
  const std::vector<Case> cases = {
      {{{"type", "multibeam"}, {"model", "VLP-16"}}, 0.045, 0.045},
      {{{"type", "multibeam"}, {"model", "HDL-32E"}}, 0.03, 0.03},
      {{{"type", "multibeam"}, {"model", "HDL-32E"}, {"range_accuracy_m", 0.05}}, 0.075, 0.075},
      {{{"type", "multibeam"}, {"lasers", lasers}}, 0.0, 0.03},
      {{{"type", "multibeam"}, {"lasers", lasers}, {"range_accuracy_m", 0.01}}, 0.015, 0.015},
  };
  for (const Case& c : cases) {
    const Job job = read(c.sensor);
    EXPECT_NEAR(job.options.method<CorrespondenceOptions>().max_roughness_m, c.roughness, 1e-15) << c.sensor.dump();
    EXPECT_EQ(job.options.loss, LossType::kCauchy);
    EXPECT_NEAR(job.options.loss_scale_m, c.loss_scale, 1e-15) << c.sensor.dump();
    const std::string again = (dir / "again.json").string();
    std::ofstream(again) << jobJson(job);
    EXPECT_EQ(readJob(again).sensor.multibeam.rangeAccuracy(), job.sensor.multibeam.rangeAccuracy()) << c.sensor.dump();
  }
  EXPECT_EQ(MultiBeamModel::VLP16().rangeAccuracy(), 0.03);
  EXPECT_EQ(MultiBeamModel::HDL32E().rangeAccuracy(), 0.02);
  try {
    read({{"type", "multibeam"}, {"model", "VLP-16"}, {"range_accuracy_m", -0.01}});
    FAIL() << "a negative range accuracy";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("sensor.range_accuracy_m"), std::string::npos) << e.what();
  }
}

TEST(Registry, EarlierJobKeysAreStillReadWithANotice) {
  const fs::path dir = freshDir("legacy");
  json j = {{"frame", {{"type", "local"}}},
            {"trajectory", {{"path", "t.csv"}}},
            {"sensor", {{"type", "line"}}},
            {"mounting_used", {{"lever_arm_m", {0, 0, 0}}, {"boresight_deg", {0, 0, 0}}}},
            {"strips", {{{"id", "1"}, {"path", "1.las"}}}},
            {"planes", "regions.csv"},
            {"method", {"planes", "correspondences"}},
            {"vtpm", {{"strip_offset_sigma_m", 0.0}, {"radius_m", 2.0}}},
            {"plane", {{"sigma_m", 0.02}}},
            {"correspondence", {{"budget", 77}}}};
  const std::string path = (dir / "job.json").string();
  writeJson(path, j);
  const Job job = readJob(path);
  EXPECT_EQ(job.options.strip_offset_sigma_m, 0.0);
  EXPECT_EQ(job.options.method<VtpmOptions>().vtp.radius_m, 2.0);
  EXPECT_EQ(job.options.method<PlaneOptions>().sigma_m, 0.02);
  EXPECT_EQ(job.options.method<CorrespondenceOptions>().budget, 77);
  EXPECT_FALSE(job.options.method<PlaneOptions>().automatic);
  ASSERT_EQ(job.notices.size(), 3u);
  for (const std::string& n : job.notices) EXPECT_NE(n.find("deprecated"), std::string::npos) << n;
  // The new keys say the same without a notice, and a key given both ways is refused.
  j.erase("plane");
  j.erase("correspondence");
  j["vtpm"].erase("strip_offset_sigma_m");
  j["stochastic"] = {{"strip_offset_sigma_m", 0.0}};
  j["planes"] = {{"regions", "regions.csv"}, {"sigma_m", 0.02}};
  j["correspondences"] = {{"budget", 77}};
  writeJson(path, j);
  const Job now = readJob(path);
  EXPECT_TRUE(now.notices.empty());
  EXPECT_EQ(now.options.method<PlaneOptions>().sigma_m, 0.02);
  EXPECT_EQ(now.options.method<CorrespondenceOptions>().budget, 77);
  EXPECT_EQ(now.planes_path, (dir / "regions.csv").string());
  j["correspondence"] = {{"budget", 78}};
  writeJson(path, j);
  EXPECT_THROW(readJob(path), FileError);
}

TEST(Registry, TrajectoryAccuracyIsReadWrittenBackAndChecked) {
  const fs::path dir = freshDir("trajectory_accuracy");
  json j = minimalJob();
  j["stochastic"] = {{"trajectory", {{"position_sigma_m", 0.05}, {"heading_sigma_deg", 0.02}}}, {"time_offset_sigma_s", 0.003}};
  const std::string path = (dir / "job.json").string();
  writeJson(path, j);
  const Job job = readJob(path);
  EXPECT_EQ(job.options.trajectory.position_sigma_m, 0.05);
  EXPECT_EQ(job.options.trajectory.heading_sigma_deg, 0.02);
  EXPECT_EQ(job.options.trajectory.roll_pitch_sigma_deg, TrajectoryAccuracy().roll_pitch_sigma_deg);  // the default kept
  const std::string again = (dir / "again.json").string();
  std::ofstream(again) << jobJson(job);
  const Job back = readJob(again);
  EXPECT_EQ(back.options.trajectory.position_sigma_m, 0.05);
  EXPECT_EQ(back.options.trajectory.heading_sigma_deg, 0.02);
  EXPECT_EQ(job.options.time_offset_sigma_s, 0.003);
  EXPECT_EQ(back.options.time_offset_sigma_s, 0.003);
  j["stochastic"]["time_offset_sigma_s"] = 11;
  writeJson(path, j);
  EXPECT_THROW(readJob(path), FileError) << "a time offset σ above 10 s";
  j["stochastic"].erase("time_offset_sigma_s");
  j["stochastic"]["trajectory"] = "none";
  writeJson(path, j);
  EXPECT_FALSE(readJob(path).options.trajectory.any());
  j["stochastic"]["trajectory"] = {{"position_sigma_m", -1}};
  expectRefusedNaming(path, j, "position_sigma_m");  // a negative σ
}

// The re-solve check's reject bound (AnalysisOptions::resolve_reject_sigma): a job key, written
// back, and refused below the doubtful bound of 2σ with the key named.
TEST(Registry, TheReSolveRejectBoundIsReadWrittenBackAndChecked) {
  const fs::path dir = freshDir("resolve_reject");
  json j = minimalJob();
  const std::string path = (dir / "job.json").string();
  writeJson(path, j);
  EXPECT_EQ(readJob(path).options.resolve_reject_sigma, 4.5);
  j["solver"] = {{"resolve_reject_sigma", 6.0}};
  writeJson(path, j);
  const Job job = readJob(path);
  EXPECT_EQ(job.options.resolve_reject_sigma, 6.0);
  const std::string again = (dir / "again.json").string();
  std::ofstream(again) << jobJson(job);
  EXPECT_EQ(readJob(again).options.resolve_reject_sigma, 6.0);
  j["solver"]["resolve_reject_sigma"] = 1.5;
  expectRefusedNaming(path, j, "resolve_reject_sigma");  // below the doubtful bound
}

TEST(Registry, TrajectoryCorrectionsAndTheTimeOffsetAreReadWrittenBackAndChecked) {
  const fs::path dir = freshDir("trajectory_corrections");
  json j = minimalJob();
  j["stochastic"] = {{"corrections", {{"position_degree", 2}, {"attitude_degree", 1}, {"heading_sigma_deg", 0.02}}},
                     {"time_offset_sigma_s", 0.004},
                     {"estimate_time_offset", true}};
  const std::string path = (dir / "job.json").string();
  writeJson(path, j);
  const Job job = readJob(path);
  EXPECT_EQ(job.options.corrections.position_degree, 2);
  EXPECT_EQ(job.options.corrections.attitude_degree, 1);
  EXPECT_EQ(job.options.corrections.heading_sigma_deg, 0.02);
  EXPECT_EQ(job.options.corrections.position_sigma_m, TrajectoryCorrections().position_sigma_m);  // the default kept
  EXPECT_TRUE(job.options.estimate_time_offset);
  const std::string again = (dir / "again.json").string();
  std::ofstream(again) << jobJson(job);
  const Job back = readJob(again);
  EXPECT_EQ(back.options.corrections.position_degree, 2);
  EXPECT_EQ(back.options.corrections.attitude_degree, 1);
  EXPECT_EQ(back.options.corrections.heading_sigma_deg, 0.02);
  EXPECT_TRUE(back.options.estimate_time_offset);
  auto refused = [&](const json& bad, const std::string& field) { expectRefusedNaming(path, bad, field); };
  json bad = j;
  bad["stochastic"]["corrections"]["position_degree"] = 4;
  refused(bad, "position_degree");
  bad = j;
  bad["stochastic"]["corrections"]["attitude_degree"] = -1;
  refused(bad, "attitude_degree");
  bad = j;
  bad["stochastic"]["corrections"]["splines"] = true;
  refused(bad, "splines");
  bad = j;
  bad["stochastic"].erase("time_offset_sigma_s");
  refused(bad, "estimate_time_offset");
  // The priors from the trajectory's accuracy: read, written back without the σ keys, and
  // refused beside them (one of the two would be ignored).
  json from = j;
  from["stochastic"]["corrections"] = {{"position_degree", 1}, {"attitude_degree", 1}, {"priors_from_accuracy", true}};
  writeJson(path, from);
  const Job acc = readJob(path);
  EXPECT_TRUE(acc.options.corrections.priors_from_accuracy);
  std::ofstream(again) << jobJson(acc);
  const Job acc_back = readJob(again);
  EXPECT_TRUE(acc_back.options.corrections.priors_from_accuracy);
  EXPECT_EQ(acc_back.options.corrections.attitude_degree, 1);
  EXPECT_FALSE(json::parse(jobJson(acc))["stochastic"]["corrections"].contains("position_sigma_m"));
  bad = from;
  bad["stochastic"]["corrections"]["heading_sigma_deg"] = 0.02;
  refused(bad, "heading_sigma_deg");
}

TEST(ToyMethod, IsListedCalibratesFromAJobAndAppearsInTheResultAndTheReport) {
  const std::string cli = MOUNTCAL_CLI_WITH_TEST_METHODS;
  const CommandRun listing = runCommand(cli, "methods");
  ASSERT_EQ(listing.code, 0) << listing.err;
  EXPECT_NE(listing.out.find("\ntoy\n"), std::string::npos) << listing.out;
  EXPECT_NE(listing.out.find("lever_arm_z_m"), std::string::npos) << listing.out;

  const fs::path dir = freshDir("toy");
  const CommandRun sim = runCommand(cli, "simulate --preset paper-calibration-field --seed 4 --out " + dir.string());
  ASSERT_EQ(sim.code, 0) << sim.err;
  json j = readJson((dir / "job.json").string());
  j["method"] = {"vtpm", "toy"};
  j["toy"] = {{"lever_arm_z_m", 0.1234}, {"sigma_m", 0.002}};
  j["estimate"]["lever_arm"] = {true, true, true};
  const std::string job = (dir / "job_toy.json").string();
  writeJson(job, j);
  const std::string result = (dir / "result_toy.json").string(), report = (dir / "report_toy.html").string();
  const CommandRun cal = runCommand(cli, "calibrate " + job + " --result " + result + " --report " + report);
  ASSERT_EQ(cal.code, 0) << cal.err << cal.out;
  EXPECT_NE(cal.out.find("Toy: measured lever arm z 0.1234 m"), std::string::npos) << cal.out;
  const json r = readJson(result);
  ASSERT_TRUE(r.contains("toy")) << r.dump(1);
  EXPECT_EQ(r["methods"], json({"vtpm", "toy"}));
  // The ties do not see the vertical lever arm: the measurement alone gives it, with its σ.
  EXPECT_NEAR(r["mounting"]["lever_arm_m"][2].get<double>(), 0.1234, 1e-3);
  EXPECT_NEAR(r["sigma"]["lever_arm_m"][2].get<double>(), 0.002, 2e-4);
  EXPECT_NEAR(r["toy"]["estimated_z_m"].get<double>(), r["mounting"]["lever_arm_m"][2].get<double>(), 1e-12);
  EXPECT_TRUE(r.contains("rms_before_m"));  // VTPM's keys, written by VTPM's section
  std::ifstream rep(report);
  std::stringstream html;
  html << rep.rdbuf();
  EXPECT_NE(html.str().find("<h2>Toy: measured lever arm</h2>"), std::string::npos);

  // The toy alone: no tie keys in the result (no zeros that read as a perfect tie fit).
  j["method"] = "toy";
  j["estimate"] = {{"lever_arm", {false, false, true}}, {"boresight", {false, false, false}}};
  writeJson(job, j);
  const CommandRun alone = runCommand(cli, "calibrate " + job + " --quiet --result " + result);
  ASSERT_EQ(alone.code, 0) << alone.err;
  const json a = readJson(result);
  for (const char* key : {"ties", "rms_before_m", "rms_after_m", "residuals"}) EXPECT_TRUE(a[key].is_null()) << key << a.dump(1);
  EXPECT_NEAR(a["mounting"]["lever_arm_m"][2].get<double>(), 0.1234, 1e-9);

  // The shipped command does not know the toy: a job naming it is bad input.
  const CommandRun plain = runCommand(MOUNTCAL_CLI, "calibrate " + job + " --quiet");
  EXPECT_EQ(plain.code, 2);
  EXPECT_NE(plain.err.find("field 'toy': unknown field"), std::string::npos) << plain.err;
}
