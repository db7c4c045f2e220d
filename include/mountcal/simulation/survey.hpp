#pragma once
/// \file simulation/survey.hpp
/// A simulated LiDAR survey with known mounting truth (issue "Survey simulator").
///
/// The scanner is flown along straight lines over a Scene with the *true* mounting and the
/// *true* trajectory; the raw observations get range and scan-angle noise; the trajectory the
/// user receives (the *measured* one) gets correlated GNSS and attitude errors; the strips are
/// georeferenced with the *nominal* mounting through the measured trajectory, exactly as a
/// production pipeline would produce them. Everything is seeded and deterministic.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "mountcal/core/mounting.hpp"
#include "mountcal/data.hpp"
#include "mountcal/core/sensor_model.hpp"
#include "mountcal/simulation/scene.hpp"
#include "mountcal/core/trajectory.hpp"

namespace mountcal::simulation {

/// Mirror motion of a line scanner.
enum class MirrorPattern {
  kSinusoidal,  ///< θ = θ_max sin(2π f t) (oscillating mirror, e.g. ALS50-II)
  kTriangle,    ///< constant angular speed back and forth
  kSawtooth,    ///< constant angular speed in one direction (rotating polygon)
};

struct LineScannerConfig {
  double prf_hz = 150e3;                ///< pulse repetition frequency [Hz]
  double scan_rate_hz = 60.0;           ///< full mirror periods per second [Hz]
  double half_fov_rad = deg2rad(20.0);  ///< maximum |θ| [rad]
  MirrorPattern pattern = MirrorPattern::kSinusoidal;
};

struct MultiBeamConfig {
  /// The laser table the strips are georeferenced with (the driver's calibration file).
  MultiBeamModel model = MultiBeamModel::VLP16();
  double rotation_hz = 10.0;   ///< spin rate, 5–20 Hz [Hz]
  double max_range_m = 100.0;  ///< returns beyond this are lost [m]
  /// Per laser id, how the real sensor differs from `model` (empty: not at all): the rays are
  /// cast with elevation + δω, azimuth offset + δα, vertical offset + δz, range offset + δρ and
  /// horizontal offset + δH,
  /// while the points are georeferenced with `model` — as a driver with a slightly wrong
  /// calibration file writes them. Sizes other than 0 or the laser count are refused; the
  /// firing offsets are not used. Tie picks see the true geometry.
  std::vector<LaserSpec> laser_errors;
  /// With an ROI (SurveyConfig::roi_radius_m), set up only the firing sequences whose azimuths can
  /// reach an ROI window (a bound from the scanner's pose every millisecond): the same strips to
  /// the last bit, a fraction of the pulses. false sets up every sequence (the reference).
  bool azimuth_gate = true;
};

/// Per-laser errors of a spinning multi-beam sensor drawn from a seed: each laser's elevation,
/// azimuth, vertical, range and horizontal offsets normal with the given σ, then the mean over
/// the lasers removed from elevation, azimuth and vertical (a common elevation or azimuth offset
/// is the boresight's, a common vertical offset the lever arm's, so a calibration cannot tell
/// them from the mounting).
std::vector<LaserSpec> drawLaserErrors(int lasers, std::uint64_t seed, double elevation_sigma_rad, double azimuth_sigma_rad = 0.0,
                                       double vertical_sigma_m = 0.0, double range_sigma_m = 0.0, double horizontal_sigma_m = 0.0);

/// The σ of drawLaserErrors for a factory laser table's residual errors.
struct LaserErrorSigmas {
  double elevation_rad = 0, azimuth_rad = 0, vertical_m = 0, range_m = 0, horizontal_m = 0;
};
/// The error presets "VLP-16" and "HDL-32E" (scenario key `"laser_errors": {"preset": …}`):
/// assumed magnitudes, not measured ones — range σ a third of the manual's range accuracy
/// (VLP-16 ±3 cm: 10 mm; HDL-32E ±2 cm: 7 mm), elevation and azimuth σ 0.05° (a twentieth of a
/// VLP-16 channel spacing of 2°), vertical and horizontal origin σ 5 mm (the VLP-16 table's own
/// vertical corrections reach 11.2 mm). Throws InvalidInput for another name.
LaserErrorSigmas laserErrorPreset(const std::string& sensor_model);

/// The laser table as the sensor really fires: `config.model` with `config.laser_errors` added to
/// each laser's elevation, azimuth, vertical and range offsets (`config.model` itself when there
/// are none). Throws InvalidInput when the errors are not one per laser.
MultiBeamModel firedModel(const MultiBeamConfig& config);

/// A straight flight line at constant height and speed.
struct FlightLine {
  std::string id;             ///< strip id in the outputs
  double x0_m = 0, y0_m = 0;  ///< start of the line [m]
  double heading_rad = 0;     ///< direction of flight, clockwise from North [rad]
  double length_m = 1000;     ///< [m]
  double height_m = 760;      ///< flying height above the ground datum z = 0 [m]
  double speed_mps = 60;      ///< ground speed [m/s]
  double prf_hz = 0;          ///< line scanner PRF for this line [Hz] (0: the scanner's)
  double scan_rate_hz = 0;    ///< line scanner mirror rate for this line [Hz] (0: the scanner's)
};

/// Attitude dynamics of the platform: slow sinusoidal oscillation of a few tenths of a degree.
struct AttitudeDynamics {
  double roll_amplitude_rad = deg2rad(0.3);
  double pitch_amplitude_rad = deg2rad(0.2);
  double heading_amplitude_rad = deg2rad(0.2);
  double roll_period_s = 9.0, pitch_period_s = 13.0, heading_period_s = 21.0;
};

/// Measurement errors. Position and attitude errors are first-order Gauss–Markov processes
/// (smooth, correlated in time); range, scan-angle and picking noise are white.
struct NoiseModel {
  double range_sigma_m = 0.0;           ///< [m]
  double scan_angle_sigma_rad = 0.0;    ///< [rad]
  double gnss_sigma_m = 0.0;            ///< per axis [m]
  double gnss_correlation_s = 100.0;    ///< [s]
  double attitude_sigma_rad = 0.0;      ///< roll and pitch [rad]; heading gets twice this
  double attitude_correlation_s = 1.0;  ///< [s]
  double pick_sigma_m = 0.0;            ///< tie picking, per horizontal axis [m]
  /// Navigation drift within a strip, as a GNSS/INS solution carries it, in a form unlike the
  /// calibrator's models (a constant offset per strip, a first-order Gauss–Markov attitude): a
  /// band-limited process, per axis the sum of 8 sinusoids of random phase whose periods are
  /// spread log-uniformly over [period_min_s, period_max_s], redrawn for every line. RMS per
  /// axis; the heading's attitude drift is twice the roll/pitch value. 0: off (the other
  /// noise then draws the same numbers as without this field).
  double drift_position_sigma_m = 0.0;         ///< [m]
  double drift_position_period_min_s = 10.0;   ///< [s]
  double drift_position_period_max_s = 100.0;  ///< [s]
  double drift_attitude_sigma_rad = 0.0;       ///< roll and pitch [rad]
  double drift_attitude_period_min_s = 1.0;    ///< [s]
  double drift_attitude_period_max_s = 30.0;   ///< [s]
  /// The drift's form. kBandLimited: the sinusoids above. kGaussMarkov: per line and axis a
  /// first-order Gauss–Markov process (started stationary) whose correlation time is drawn
  /// log-uniformly from [period_min_s, period_max_s] — issue 26's "Gauss–Markov drift with
  /// 10–100 s correlation"; unlike the sinusoids it has the long-period (strip-constant) part
  /// of a real GNSS/INS error, and its correlation time differs from line to line and from
  /// the calibrator's single stated τ. Scenario key `"drift_form"`.
  enum class DriftForm { kBandLimited, kGaussMarkov };
  DriftForm drift_form = DriftForm::kBandLimited;
  /// The drift's RMS on line i is drift_scale_by_line[i] times the values above (a line flown with
  /// fewer satellites, or farther from its base station); lines beyond the list: 1. The same
  /// random numbers are drawn whatever the factors. Scenario key `"drift_scale_by_line"`.
  std::vector<double> drift_scale_by_line;

  static NoiseModel none() { return {}; }
  /// realistic() plus survey-grade navigation drift: position 2 cm RMS (periods 10–100 s),
  /// attitude 0.002° roll/pitch and 0.004° heading RMS (periods 1–30 s) — issue 26's spectra.
  static NoiseModel withNavigationDrift(DriftForm form = DriftForm::kBandLimited);
  /// A post-processed airborne survey: 2 cm range, 0.001° scan-angle encoder, 1.5 cm
  /// strip-to-strip GNSS (PPK, Gauss–Markov 100 s), 0.001° roll/pitch and 0.002° heading
  /// noise (Gauss–Markov 0.1 s), 5 cm tie picking.
  static NoiseModel realistic();
};

/// Everything that defines a simulated survey.
struct SurveyConfig {
  std::string name = "survey";
  SensorType sensor = SensorType::kLine;
  LineScannerConfig line;
  MultiBeamConfig multibeam;
  MountingParameters true_mounting;     ///< the mounting that produced the data
  MountingParameters nominal_mounting;  ///< the mounting used to georeference the strips
  std::vector<FlightLine> lines;
  AttitudeDynamics dynamics;
  NoiseModel noise;
  std::uint64_t seed = 1;
  /// Lines simulated at once (0: every core); the survey does not depend on it.
  int threads = 0;
  double trajectory_rate_hz = 200.0;
  /// Budgets of the whole survey. Points stored (returns), about 180 bytes each with the strips
  /// and their calibration data (12 M ≈ 2 GB; block-N fits up to N ≈ 100): simulate() stops with
  /// InvalidInput as soon as the lines together store more. Pulses cast (time: a few million per
  /// second and core): refused before any work, from the lines' durations and pulse rates.
  double max_points = 12e6;
  double max_pulses = 2e9;
  /// The longest line [s] (length / speed): its trajectory is sampled at trajectory_rate_hz.
  double max_line_duration_s = 7200.0;
  double time_origin_s = 100000.0;  ///< GPS week seconds of the first line's start [s]
  double line_gap_s = 120.0;        ///< time between the end of a line and the next start [s]
  /// Simulate only the pulses landing within this distance of a feature point, a check plane
  /// or a tie [m] (0 = whole strips).
  double roi_radius_m = 0.0;
  /// Feature ids that become check points instead of ties (their picks go to check_points).
  std::vector<std::string> check_point_ids;
  /// Features to leave out of both ties and check points.
  std::vector<std::string> ignored_feature_ids;
};

/// One simulated strip.
struct SimulatedStrip {
  std::string id;
  std::vector<RawPulse> pulses;     ///< raw observations (with noise), one per return
  std::vector<Vec3> points_m;       ///< georeferenced with the nominal mounting [m]
  std::vector<Vec3> true_points_m;  ///< where the ray really hit [m]
  std::vector<SurfaceKind> kinds;   ///< what it hit
};

/// The plan position of a feature as picked on one strip (SPEC §4 Ties CSV).
struct TiePick {
  std::string tie_id;
  std::string strip_id;
  double x_m = 0, y_m = 0;         ///< picked plan position in the strip [m]
  Vec3 apparent_m = Vec3::Zero();  ///< the feature as the strip shows it, no picking noise
  Vec3 true_m = Vec3::Zero();      ///< the feature's true position [m]
  double time_s = 0;               ///< when the scanner saw it [s]
};

struct SimulatedSurvey {
  SurveyConfig config;
  std::shared_ptr<const Trajectory> true_trajectory;
  std::shared_ptr<const Trajectory> measured_trajectory;  ///< what the user receives
  std::vector<SimulatedStrip> strips;
  std::vector<TiePick> ties;
  std::vector<TiePick> check_points;
  std::vector<PlanePatch> check_planes;
  std::vector<PlanePatch> plane_regions;   ///< calibration patches (roof faces) for the plane method
  std::vector<PlanePatch> target_regions;  ///< regions around the high-intensity targets for the feature method
  std::vector<FeaturePoint> gcps;          ///< true positions of the tie features (for GCP tests)
};

/// Keeps only the lines flown at the first line's height (scenario key `"one_height"`).
void keepOneHeight(SurveyConfig* config);

/// Runs the survey. Throws InvalidInput for an inconsistent configuration, before any work for a
/// line longer than max_line_duration_s or more pulses than max_pulses, and as soon as the
/// strips hold more than max_points (each named with its figures).
SimulatedSurvey simulate(const SurveyConfig& config, const Scene& scene);

/// Per-laser errors of `sigmas` drawn from `seed` for the lasers that see the survey: a first
/// flight of `config` (its laser errors left out) counts each laser's returns; a laser with fewer
/// than `min_points` gets none, and the common elevation, azimuth and vertical parts are removed
/// over the others — what a calibration that holds those means over the lasers it sees can
/// recover. Throws what simulate() throws.
std::vector<LaserSpec> drawLaserErrorsOnSeenLasers(const SurveyConfig& config, const Scene& scene, std::uint64_t seed,
                                                   const LaserErrorSigmas& sigmas, int min_points = 2000);

/// The survey as a calibrator sees it: the measured trajectory, the nominal mounting, every
/// strip's raw vectors and georeferenced points, and the ties (or the check points when
/// `use_check_points`), and the scene's plane regions. No file round trip, so no LAS
/// quantisation.
CalibrationData toCalibrationData(const SimulatedSurvey& survey, bool use_check_points = false);

/// The first paper's experiment 1 on the `paper-calibration-field` preset: five ties and twelve
/// observations (three ties on two strips, two on three: two ring targets near the swath edge,
/// a crossing, a roof, a target), as picked on the survey's strips.
std::vector<TieObservation> paperFiveTies(const SimulatedSurvey& survey);

/// Plane regions of bare, nearly flat ground on `paper-calibration-field`: a square of side
/// 2 × `half_size_m` around each ring target's centre — the plane method's weak case.
std::vector<PlaneRegion> flatGroundRegions(const SimulatedSurvey& survey, double half_size_m = 4.0);

/// The names of the built-in presets (SPEC §4): "paper-calibration-field",
/// "paper-check-block", "uav-vlp16", "block" (also "block-N", see makeBlock).
const std::vector<std::string>& presetNames();

/// A block for automatic correspondences and workflows (preset "block" = 12 strips, "block-N"):
/// N/2 E–W lines and N/2 N–S lines crossing them, each set flown back and forth with 50 % side
/// overlap, at 300 m with a line scanner (30 kHz, 40 Hz, ±20°; ≈ 0.5 m spacing), over a town on a
/// 70 m grid (gable houses with ridges in every direction, flat roofs, targets) simulated within
/// 9 m of its features. The area grows with N. Throws InvalidInput unless N is even in [4, 256].
/// BlockLayout::kParallel instead: N E–W lines of one length (≈ 870 m) side by side, flown back
/// and forth — the overlapping pairs (and each pair's size) grow linearly with N.
enum class BlockLayout { kCrossing, kParallel };
void makeBlock(int strips, std::uint64_t seed, SurveyConfig* config, Scene* scene, BlockLayout layout = BlockLayout::kCrossing);

/// A preset's scene and configuration; `seed` varies the noise. Throws InvalidInput for an
/// unknown name (the message lists the presets).
void makePreset(const std::string& name, std::uint64_t seed, SurveyConfig* config, Scene* scene);

/// Loads a scenario file: a preset with overrides. Fields (all but "preset" optional):
/// `{"preset": NAME, "seed": N, "true_mounting": {"lever_arm_m": [..], "boresight_deg": [..]},
///   "nominal_mounting": {...}, "noise": "none" | "realistic" | {"range_sigma_m", ...},
///   "roi_radius_m": R, "laser_errors": {"preset", "elevation_sigma_deg", "azimuth_sigma_deg",
///   "vertical_sigma_m", "range_sigma_m", "horizontal_sigma_m", "seed"}}` (the last for a
///   multi-beam preset: per-laser errors drawn by drawLaserErrors, "preset" "VLP-16" or "HDL-32E"
///   giving laserErrorPreset's σ for the keys not given). Throws FileError naming the file and the field for
///   anything unknown or malformed.
void loadScenario(const std::string& path, SurveyConfig* config, Scene* scene);

}  // namespace mountcal::simulation
