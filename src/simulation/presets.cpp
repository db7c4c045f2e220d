// The built-in survey presets (SPEC §4 "Simulator output").
#include <algorithm>
#include <cmath>

#include "mountcal/core/error.hpp"
#include "mountcal/simulation/survey.hpp"

namespace mountcal::simulation {

namespace {

/// Truth used by every preset: the example mounting.
MountingParameters presetTruth(const Vec3& nominal_deg = Vec3::Zero()) {
  return MountingParameters::fromDegrees(Vec3(0.10, -0.05, 0.20), Vec3(0.05, -0.08, 0.12), nominal_deg);
}

/// The first paper's calibration field (Anyang): a flat town with road markings, buildings,
/// gable roofs and targets, crossed by four strips — E–W and N–S at 760 m (≈0.5 m spacing),
/// then W–E and S–N at 1310 m (≈0.9 m) — so that opposite directions and two heights separate
/// the mounting parameters.
void calibrationField(std::uint64_t seed, SurveyConfig* c, Scene* s) {
  s->setGround(0.0, 0.001, -0.0015, 40.0f);  // gently sloped (0.1 %, 0.15 %)
  s->addZebraCrossing("zebra_a", -150, -20, deg2rad(90));
  s->addZebraCrossing("zebra_b", 120, 40, deg2rad(0));
  s->addZebraCrossing("zebra_c", 30, 160, deg2rad(45));
  s->addGroundTarget("target_1", -180, 150, 3.0, deg2rad(0));
  s->addGroundTarget("target_2", 180, -160, 3.0, deg2rad(30));
  s->addGroundTarget("target_3", -60, -180, 3.0, deg2rad(0));
  s->addGroundTarget("target_4", 200, 120, 3.0, deg2rad(15));
  s->addGroundTarget("target_5", 0, 0, 3.0, deg2rad(0));
  // Rings of ground targets, the outer one near the edge of the 760 m swath: the heading
  // boresight is seen through along-track offsets that grow with the cross-track distance.
  for (int k = 0; k < 16; ++k) {
    const double az = deg2rad(22.5 * k + 10.0);
    s->addGroundTarget("ring_" + std::to_string(k + 1), 250.0 * std::sin(az), 250.0 * std::cos(az), 3.0, az);
  }
  for (int k = 0; k < 8; ++k) {
    const double az = deg2rad(45.0 * k + 30.0);
    s->addGroundTarget("inner_" + std::to_string(k + 1), 120.0 * std::sin(az), 120.0 * std::cos(az), 3.0, az);
  }
  s->addZebraCrossing("zebra_d", -200, 205, deg2rad(30));
  s->addZebraCrossing("zebra_e", 215, -200, deg2rad(60));
  s->addFlatRoofBuilding("bldg_a", 80, -90, 40, 25, 15, deg2rad(30));
  s->addFlatRoofBuilding("bldg_b", -110, 90, 30, 20, 24, deg2rad(0));
  s->addGableHouse("house_a", -40, 60, 14, 10, 6, 10, deg2rad(20));
  s->addGableHouse("house_b", 150, -40, 16, 12, 5, 9, deg2rad(110));
  s->addBoard("board_a", Vec3(60, 60, 3.0), 3.0, deg2rad(10), deg2rad(20));
  s->addBoard("board_b", Vec3(-170, -110, 2.5), 3.0, deg2rad(-25), 0.0);
  const double trees[][2] = {{-90, -60}, {-20, -120}, {100, 100}, {170, 40}, {-140, 10}, {50, -150}};
  for (const auto& t : trees) s->addTree(t[0], t[1], 4.0, 3.0, 12.0, 0.6);
  s->addCheckPlane("plane_1", -30, -100, -10, -80);
  s->addCheckPlane("plane_2", 100, 160, 130, 190);
  c->check_point_ids = {"inner_2", "inner_4", "inner_6", "inner_8"};
  c->name = "paper-calibration-field";
  c->sensor = SensorType::kLine;
  c->true_mounting = presetTruth();
  c->nominal_mounting = MountingParameters{};
  c->noise = NoiseModel::realistic();
  c->seed = seed;
  c->roi_radius_m = 12.0;
  const double L = 1400;
  c->lines = {
      {"1", -L / 2, 0, deg2rad(90), L, 760, 60},               // E, 760 m
      {"2", 0, -L / 2, deg2rad(0), L, 760, 60},                // N, 760 m
      {"3", L / 2, 60, deg2rad(270), L, 1310, 60, 70e3, 35},   // W, 1310 m, 70 kHz
      {"4", -60, L / 2, deg2rad(180), L, 1310, 60, 70e3, 35},  // S, 1310 m, 70 kHz
  };
  // ALS50-II: 150 kHz, 50 Hz mirror at 760 m; the 1310 m lines use 70 kHz, 35 Hz (≈0.9 m).
  c->line.prf_hz = 150e3;
  c->line.scan_rate_hz = 50;
  c->line.half_fov_rad = deg2rad(20);
}

/// The first paper's check block: four parallel E–W strips at 3200 m (≈2.1 m spacing) with
/// ≈15 % side overlap, flown back and forth; check points at road crossings in the overlaps and
/// two check planes (a road and a sports field).
void checkBlock(std::uint64_t seed, SurveyConfig* c, Scene* s) {
  s->setGround(0.0, 0.0005, 0.0005, 40.0f);
  const double swath = 2 * 3200 * std::tan(deg2rad(20));
  const double spacing = swath * 0.85;
  c->lines.clear();
  const double L = 5000;
  for (int k = 0; k < 4; ++k) {
    const bool east = (k % 2 == 0);
    c->lines.push_back({std::to_string(k + 5), east ? -L / 2 : L / 2, k * spacing, deg2rad(east ? 90 : 270), L, 3200, 65});
  }
  // Check points: ground targets (road crossings) in the three overlaps.
  int id = 1;
  for (int k = 0; k < 3; ++k) {
    const double y = (k + 0.5) * spacing;
    const int n = (k == 1) ? 3 : 2;
    for (int j = 0; j < n; ++j) {
      const double x = -1500 + 3000.0 * (j + 0.5) / n + 200 * k;
      s->addGroundTarget("chk_" + std::to_string(id), x, y + 40 * (j % 2 ? 1 : -1), 8.0, deg2rad(10 * j));
      c->check_point_ids.push_back("chk_" + std::to_string(id));
      ++id;
    }
  }
  // Ties (road crossings) in the overlaps too, so that the block's job.json runs as it is: a
  // calibration from four parallel strips, whose report names what such a block cannot fix.
  for (int k = 0; k < 3; ++k) {
    for (int j = 0; j < 2; ++j) {
      s->addGroundTarget("tie_" + std::to_string(2 * k + j + 1), -2000 + 3500.0 * j + 150 * k, (k + 0.5) * spacing + (j ? 30 : -30), 8.0,
                         deg2rad(20));
    }
  }
  s->addCheckPlane("plane_1", -300, 0.5 * spacing - 40, -200, 0.5 * spacing + 40);  // a road
  s->addCheckPlane("plane_2", 600, 1.5 * spacing - 30, 660, 1.5 * spacing + 30);    // a field
  c->name = "paper-check-block";
  c->sensor = SensorType::kLine;
  c->true_mounting = presetTruth();
  c->nominal_mounting = MountingParameters{};
  c->noise = NoiseModel::realistic();
  c->noise.pick_sigma_m = 0.3;  // 2 m spacing: picking is coarser
  c->seed = seed;
  c->roi_radius_m = 25.0;
  c->line.prf_hz = 32e3;
  c->line.scan_rate_hz = 15;
  c->line.half_fov_rad = deg2rad(20);
}

/// The second paper's UAV survey (seed 002 §3): a VLP-16 (spin axis along the flight direction,
/// R_nom = Ry(90°)) at 50 m, 5 m/s, lines 50 m apart flown back and forth and in the same
/// direction, and the centre line flown back and forth again at a second height (80 m) so that
/// pitch and the along-track lever arm separate; high-intensity ground targets and raised boards,
/// road markings, and low gable-roof houses whose eave corners are the check (seed 002 Tables 1–2).
void uavVlp16(std::uint64_t seed, SurveyConfig* c, Scene* s) {
  s->setGround(0.0, 0.002, 0.0, 35.0f);
  const double tx[] = {-20, 10, 25, 40, 70, -5, 55, 15};
  const double ty[] = {40, 60, 100, 140, 80, 170, 30, 200};
  for (int k = 0; k < 8; ++k) {
    s->addGroundTarget("target_" + std::to_string(k + 1), tx[k], ty[k], 1.5, deg2rad(15.0 * k), 240.0f);
  }
  s->addBoard("board_1", Vec3(30, 120, 1.2), 1.5, deg2rad(0), deg2rad(30), 240.0f);
  s->addBoard("board_2", Vec3(-10, 90, 1.0), 1.5, deg2rad(45), deg2rad(-25), 240.0f);
  s->addZebraCrossing("zebra", 20, 20, deg2rad(90), 5, 3.0);
  s->addMarking(25, 120, 60, 0.15, 0.0, 200.0f);  // centre line
  s->addCheckPlane("plane_1", 35, 150, 45, 160);
  // Low houses with gable roofs (eaves 3 m, ridge 6 m); their eave corners are check points of
  // the absolute check, not ties (a corner cannot be picked on a plane).
  const struct {
    const char* id;
    double x, y, heading_deg;
  } houses[] = {{"house_a", 5, 215, 20}, {"house_b", 45, 215, 100}};
  for (const auto& h : houses) {
    s->addGableHouse(h.id, h.x, h.y, 12, 8, 3, 6, deg2rad(h.heading_deg));
    const Vec3 u(std::sin(deg2rad(h.heading_deg)) * 6, std::cos(deg2rad(h.heading_deg)) * 6, 0);
    const Vec3 v(std::cos(deg2rad(h.heading_deg)) * 4, -std::sin(deg2rad(h.heading_deg)) * 4, 0);
    const Vec3 centre(h.x, h.y, s->groundHeight(h.x, h.y) + 3.0);
    const Vec3 corners[4] = {centre - u - v, centre + u - v, centre + u + v, centre - u + v};
    for (int k = 0; k < 4; ++k) {
      const std::string id = std::string(h.id) + "_corner" + std::to_string(k);
      s->addFeature({id, corners[k], SurfaceKind::kRoof, 0.0});
      c->ignored_feature_ids.push_back(id);
    }
  }
  c->check_point_ids = {"target_3", "target_6"};
  c->name = "uav-vlp16";
  c->sensor = SensorType::kMultiBeam;
  c->multibeam.model = MultiBeamModel::VLP16();
  c->multibeam.rotation_hz = 10.0;
  c->multibeam.max_range_m = 100.0;
  c->true_mounting = MountingParameters::fromDegrees(Vec3(0.10, -0.05, 0.20), Vec3(0.5, -0.8, 1.2), Vec3(0, 90, 0));
  // The paper measures the lever arm (to about a centimetre) and calibrates the boresight.
  c->nominal_mounting = MountingParameters::fromDegrees(Vec3(0.11, -0.06, 0.19), Vec3::Zero(), Vec3(0, 90, 0));
  c->noise = NoiseModel::realistic();
  c->noise.range_sigma_m = 0.03;
  c->noise.pick_sigma_m = 0.03;
  c->noise.gnss_sigma_m = 0.02;
  c->noise.attitude_sigma_rad = deg2rad(0.01);
  c->dynamics.roll_amplitude_rad = deg2rad(1.0);
  c->dynamics.pitch_amplitude_rad = deg2rad(1.0);
  c->dynamics.heading_amplitude_rad = deg2rad(0.5);
  c->seed = seed;
  c->roi_radius_m = 4.0;
  c->trajectory_rate_hz = 200.0;
  c->line_gap_s = 30.0;
  c->lines = {
      {"1", 0, -20, deg2rad(0), 260, 50, 5},    // north
      {"2", 0, 240, deg2rad(180), 260, 50, 5},  // back (opposite direction, same line)
      {"3", 50, -20, deg2rad(0), 260, 50, 5},   // same direction, 50 m to the right
      {"4", 0, -20, deg2rad(0), 260, 80, 5},    // the centre line again at a second height
      {"5", 0, 240, deg2rad(180), 260, 80, 5},  // and back
  };
}

}  // namespace

void makeBlock(int strips, std::uint64_t seed, SurveyConfig* c, Scene* s, BlockLayout layout) {
  if (strips < 4 || strips > 256 || strips % 2 != 0)
    throw InvalidInput("a block has an even number of strips from 4 to 256 (got " + std::to_string(strips) + ")");
  *c = SurveyConfig{};
  *s = Scene{};
  const bool crossing = layout == BlockLayout::kCrossing;
  const int n_ew = crossing ? strips / 2 : strips, n_ns = crossing ? strips - n_ew : 0;
  const double height = 300, half_fov = deg2rad(20);
  const double swath = 2 * height * std::tan(half_fov);
  const double spacing = 0.5 * swath;  // 50 % side overlap
  // Crossing: the E–W lines span the N–S lines and the other way round; parallel: lines of one
  // length (eight line spacings), side by side.
  const double ext_x = crossing ? (n_ns - 1) * spacing : 8 * spacing, ext_y = (n_ew - 1) * spacing;
  s->setGround(0.0, 0.0008, -0.0006, 40.0f);
  // A town on a 70 m grid: gable houses with ridges in every direction (sloped roofs give the
  // horizontal information), flat-roof blocks, and ground targets between them.
  const double grid = 70;
  int k = 0;
  for (double y = -0.5 * spacing; y <= ext_y + 0.5 * spacing; y += grid) {
    for (double x = -0.5 * spacing; x <= ext_x + 0.5 * spacing; x += grid, ++k) {
      const std::string id = std::to_string(k);
      const double heading = deg2rad(std::fmod(37.0 * k, 180.0));
      if (k % 3 == 2)
        s->addFlatRoofBuilding("flat_" + id, x, y, 16, 11, 9, heading);
      else
        s->addGableHouse("house_" + id, x, y, 13, 9, 4, 7.5, heading);
      if (k % 4 == 0) s->addGroundTarget("target_" + id, x + 25, y + 20, 2.0, heading);
    }
  }
  c->name = (crossing ? "block-" : "parallel-block-") + std::to_string(strips);
  c->sensor = SensorType::kLine;
  c->true_mounting = presetTruth();
  c->nominal_mounting = MountingParameters{};
  c->noise = NoiseModel::realistic();
  c->seed = seed;
  c->roi_radius_m = 9.0;
  c->line.prf_hz = 30e3;
  c->line.scan_rate_hz = 40;
  c->line.half_fov_rad = half_fov;
  const double run_in = 0.5 * spacing;
  // E–W lines flown back and forth, then N–S lines crossing them, back and forth.
  for (int j = 0; j < n_ew; ++j) {
    const bool east = j % 2 == 0;
    c->lines.push_back({"ew" + std::to_string(j + 1), east ? -run_in : ext_x + run_in, j * spacing, deg2rad(east ? 90 : 270),
                        ext_x + 2 * run_in, height, 55});
  }
  for (int i = 0; i < n_ns; ++i) {
    const bool north = i % 2 == 0;
    c->lines.push_back({"ns" + std::to_string(i + 1), i * spacing, north ? -run_in : ext_y + run_in, deg2rad(north ? 0 : 180),
                        ext_y + 2 * run_in, height, 55});
  }
  s->build();
}

const std::vector<std::string>& presetNames() {
  static const std::vector<std::string> kNames = {"paper-calibration-field", "paper-check-block", "uav-vlp16", "block"};
  return kNames;
}

void makePreset(const std::string& name, std::uint64_t seed, SurveyConfig* config, Scene* scene) {
  *config = SurveyConfig{};
  *scene = Scene{};
  if (name == "block" || name.rfind("block-", 0) == 0) {
    int n = 12;
    if (name != "block") {
      const std::string digits = name.substr(6);
      if (digits.empty() || digits.size() > 3 || digits.find_first_not_of("0123456789") != std::string::npos)
        throw InvalidInput("unknown simulator preset '" + name + "' (a block is 'block' or 'block-N', N even from 4 to 256)");
      n = std::stoi(digits);
    }
    makeBlock(n, seed, config, scene);
    return;
  }
  if (name == "paper-calibration-field") {
    calibrationField(seed, config, scene);
  } else if (name == "paper-check-block") {
    checkBlock(seed, config, scene);
  } else if (name == "uav-vlp16") {
    uavVlp16(seed, config, scene);
  } else {
    std::string all;
    for (const std::string& n : presetNames()) all += (all.empty() ? "" : ", ") + n;
    throw InvalidInput("unknown simulator preset '" + name + "' (presets: " + all + ")");
  }
  scene->build();
}

void keepOneHeight(SurveyConfig* config) {
  if (config->lines.empty()) return;
  const double h = config->lines.front().height_m;
  config->lines.erase(
      std::remove_if(config->lines.begin(), config->lines.end(), [&](const FlightLine& l) { return std::abs(l.height_m - h) > 1e-9; }),
      config->lines.end());
}

}  // namespace mountcal::simulation
