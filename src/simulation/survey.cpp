#include "mountcal/simulation/survey.hpp"
#include "core/parallel.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <random>
#include <set>

#include "core/random.hpp"
#include "mountcal/core/error.hpp"
#include "mountcal/core/georeference_model.hpp"
#include "core/huge_pages.hpp"
#include "core/interval_expansion.hpp"
#include "core/normal_batch.hpp"
#include "core/sincos_batch.hpp"

namespace mountcal::simulation {

NoiseModel NoiseModel::realistic() {
  NoiseModel n;
  n.range_sigma_m = 0.02;
  n.scan_angle_sigma_rad = deg2rad(0.001);
  n.gnss_sigma_m = 0.015;
  n.gnss_correlation_s = 100.0;
  n.attitude_sigma_rad = deg2rad(0.001);
  n.attitude_correlation_s = 0.1;
  n.pick_sigma_m = 0.05;
  return n;
}

NoiseModel NoiseModel::withNavigationDrift(DriftForm form) {
  NoiseModel n = realistic();
  n.drift_form = form;
  n.drift_position_sigma_m = 0.02;
  n.drift_attitude_sigma_rad = deg2rad(0.002);
  return n;
}

namespace {

/// Per-line geometry helpers.
struct LineFrame {
  Vec3 start, u, v;  // start (z = height), along-track and cross-track (to the right) unit vectors
  double t0 = 0, t1 = 0, speed = 0;
  double along(const Vec3& x) const { return (x - start).dot(u); }
  double across(const Vec3& x) const { return (x - start).dot(v); }
};

LineFrame lineFrame(const FlightLine& line, double t0) {
  LineFrame f;
  f.u = Vec3(std::sin(line.heading_rad), std::cos(line.heading_rad), 0.0);
  f.v = Vec3(std::cos(line.heading_rad), -std::sin(line.heading_rad), 0.0);
  f.start = Vec3(line.x0_m, line.y0_m, line.height_m);
  f.t0 = t0;
  f.t1 = t0 + line.length_m / line.speed_mps;
  f.speed = line.speed_mps;
  return f;
}

/// The fraction of its period the mirror has swept at time t after the start of its line.
double mirrorFraction(const LineScannerConfig& c, double t) {
  const double phase = c.scan_rate_hz * t;  // t ≥ 0 within a line: truncation is the floor
  return phase - static_cast<double>(static_cast<long long>(phase));
}

double mirrorAngle(const LineScannerConfig& c, double t) {
  const double frac = mirrorFraction(c, t);
  switch (c.pattern) {
    case MirrorPattern::kSinusoidal:
      return c.half_fov_rad * std::sin(2.0 * kPi * frac);
    case MirrorPattern::kTriangle:  // −1 → 1 → −1 over one period
      return c.half_fov_rad * (frac < 0.5 ? 4.0 * frac - 1.0 : 3.0 - 4.0 * frac);
    case MirrorPattern::kSawtooth:
      return c.half_fov_rad * (2.0 * frac - 1.0);
  }
  return 0.0;
}

void validate(const SurveyConfig& c) {
  if (c.lines.empty()) throw InvalidInput("survey '" + c.name + "': no flight lines");
  for (const FlightLine& l : c.lines) {
    if (!(l.length_m > 0) || !(l.speed_mps > 0) || !(l.height_m > 0)) {
      throw InvalidInput("survey '" + c.name + "': flight line '" + l.id + "' needs a positive length, speed and height");
    }
  }
  if (c.sensor == SensorType::kLine) {
    if (!(c.line.prf_hz > 0) || !(c.line.scan_rate_hz > 0) || !(c.line.half_fov_rad > 0)) {
      throw InvalidInput("survey '" + c.name + "': line scanner needs positive PRF, scan rate, FOV");
    }
  } else if (c.sensor == SensorType::kMultiBeam) {
    if (c.multibeam.model.laserCount() == 0 || !(c.multibeam.rotation_hz > 0)) {
      throw InvalidInput("survey '" + c.name + "': multi-beam needs a laser table and a rotation rate");
    }
    const std::vector<LaserSpec>& e = c.multibeam.laser_errors;
    if (!e.empty() && static_cast<int>(e.size()) != c.multibeam.model.laserCount()) {
      throw InvalidInput("survey '" + c.name + "': " + std::to_string(e.size()) + " laser errors for " +
                         std::to_string(c.multibeam.model.laserCount()) + " lasers");
    }
    for (const LaserSpec& l : e) {
      if (!std::isfinite(l.elevation_rad) || !std::isfinite(l.azimuth_offset_rad) || !std::isfinite(l.vertical_offset_m) ||
          !std::isfinite(l.range_offset_m) || !std::isfinite(l.horizontal_offset_m) || std::abs(l.elevation_rad) > 0.1 ||
          std::abs(l.azimuth_offset_rad) > 0.1 || std::abs(l.vertical_offset_m) > 1.0 || std::abs(l.range_offset_m) > 1.0 ||
          std::abs(l.horizontal_offset_m) > 1.0)
        throw InvalidInput("survey '" + c.name + "': a laser error beyond 0.1 rad or 1 m (or not finite)");
    }
  } else {
    throw InvalidInput("survey '" + c.name + "': the simulator scans with a line or multi-beam sensor");
  }
  if (!(c.trajectory_rate_hz > 0)) throw InvalidInput("survey '" + c.name + "': trajectory rate must be positive");
  for (const FlightLine& l : c.lines) {
    const double duration = l.length_m / l.speed_mps;
    if (duration > c.max_line_duration_s) {
      char why[256];
      std::snprintf(why, sizeof why, "flight line '%s' takes %.0f s (%.0f m at %.2f m/s); the simulator's limit is %.0f s per line",
                    l.id.c_str(), duration, l.length_m, l.speed_mps, c.max_line_duration_s);
      throw InvalidInput("survey '" + c.name + "': " + why);
    }
  }
}

/// First-order Gauss–Markov step: e ← φ e + σ √(1−φ²) w.
double gaussMarkov(double e, double dt, double tau, double sigma, detail::Rng& rng) {
  if (sigma <= 0) return 0.0;
  const double phi = std::exp(-dt / tau);
  return phi * e + sigma * std::sqrt(1.0 - phi * phi) * rng.normal();
}

/// One axis of NoiseModel's navigation drift: Σ_k a sin(2π t / P_k + φ_k) with 8 terms, P_k
/// log-uniform in [p_min, p_max], a = σ √(2/8) so that the RMS is σ.
struct BandLimitedDrift {
  static constexpr int kTerms = 8;
  std::array<double, kTerms> omega{}, phase{};
  double amplitude = 0.0;
  BandLimitedDrift() = default;
  BandLimitedDrift(double sigma, double p_min, double p_max, detail::Rng& rng) : amplitude(sigma * std::sqrt(2.0 / kTerms)) {
    for (int k = 0; k < kTerms; ++k) {
      const double period = p_min * std::pow(p_max / p_min, rng.uniform());
      omega[static_cast<std::size_t>(k)] = 2 * kPi / period;
      phase[static_cast<std::size_t>(k)] = 2 * kPi * rng.uniform();
    }
  }
  double operator()(double t) const {
    if (amplitude == 0.0) return 0.0;
    double v = 0;
    for (int k = 0; k < kTerms; ++k) v += std::sin(omega[static_cast<std::size_t>(k)] * t + phase[static_cast<std::size_t>(k)]);
    return amplitude * v;
  }
};

/// One axis of NoiseModel's navigation drift in its Gauss–Markov form: τ log-uniform in
/// [τ_min, τ_max], started from the stationary distribution, stepped with the trajectory.
struct MarkovDrift {
  double sigma = 0.0, tau = 1.0, value = 0.0;
  MarkovDrift() = default;
  MarkovDrift(double s, double tau_min, double tau_max, detail::Rng& rng)
      : sigma(s), tau(tau_min * std::pow(tau_max / tau_min, rng.uniform())), value(s * rng.normal()) {}
  double step(double dt, detail::Rng& rng) { return value = gaussMarkov(value, dt, tau, sigma, rng); }
};

/// The drift of the six navigation axes (position x, y, z; roll, pitch, heading) of one line,
/// in either form; all zero (and no random number drawn) when the model has none.
struct LineDrift {
  std::array<BandLimitedDrift, 6> band{};
  std::array<MarkovDrift, 6> markov{};
  bool gauss_markov = false;
  /// The six values at time t, `dt` after the previous call (the Gauss–Markov form steps).
  std::array<double, 6> at(double t, double dt, detail::Rng& rng) {
    std::array<double, 6> v{};
    for (std::size_t a = 0; a < 6; ++a) v[a] = gauss_markov ? (markov[a].sigma > 0 ? markov[a].step(dt, rng) : 0.0) : band[a](t);
    return v;
  }
};

LineDrift lineDrift(const NoiseModel& noise, double scale, detail::Rng& rng) {
  LineDrift d;
  d.gauss_markov = noise.drift_form == NoiseModel::DriftForm::kGaussMarkov;
  auto make = [&](std::size_t a, double sigma, double p_min, double p_max) {
    if (d.gauss_markov)
      d.markov[a] = MarkovDrift(sigma, p_min, p_max, rng);
    else
      d.band[a] = BandLimitedDrift(sigma, p_min, p_max, rng);
  };
  if (noise.drift_position_sigma_m > 0)
    for (std::size_t a = 0; a < 3; ++a)
      make(a, scale * noise.drift_position_sigma_m, noise.drift_position_period_min_s, noise.drift_position_period_max_s);
  if (noise.drift_attitude_sigma_rad > 0)
    for (std::size_t a = 0; a < 3; ++a)
      make(3 + a, (a == 2 ? 2.0 : 1.0) * scale * noise.drift_attitude_sigma_rad, noise.drift_attitude_period_min_s,
           noise.drift_attitude_period_max_s);
  return d;
}

}  // namespace

namespace {

/// The true and the measured trajectory of every line (the measured one with Gauss–Markov
/// position and attitude errors), and each line's frame.
void simulateTrajectories(const SurveyConfig& config, SimulatedSurvey* out, std::vector<LineFrame>* frames) {
  detail::Rng rng(config.seed * 0x9E3779B97F4A7C15ull + 1);
  auto phase = [](detail::Rng& r) { return 2 * kPi * r.uniform(); };
  const AttitudeDynamics& dyn = config.dynamics;
  const NoiseModel& noise = config.noise;
  std::vector<TrajectorySample> truth, measured;
  const double dt = 1.0 / config.trajectory_rate_hz;
  const double lead_s = 2.0;  // trajectory before and after each line
  double t_line = config.time_origin_s;
  // The GNSS and attitude errors start from their stationary distribution (as MarkovDrift does):
  // started at 0 the first lines would be quieter than the stated σ — the GNSS error's variance
  // reaching 1 − exp(−2t/τ) of it after t, two thirds after 100 s at τ = 100 s — and a calibration
  // that states that σ would look too cautious there. Drawn from a stream of their own, so that
  // every other draw of a survey stays as it was.
  const Vec3 att_sigma = noise.attitude_sigma_rad * Vec3(1.0, 1.0, 2.0);  // roll, pitch; heading twice
  Vec3 gnss_err = Vec3::Zero(), att_err = Vec3::Zero();
  {
    detail::Rng start(config.seed * 0x9E3779B97F4A7C15ull + 2);
    for (int a = 0; a < 3; ++a) {
      const double g = start.normal(), r = start.normal();
      gnss_err[a] = noise.gnss_sigma_m * g;
      att_err[a] = att_sigma[a] * r;
    }
  }
  double t_prev = t_line - lead_s;
  for (const FlightLine& line : config.lines) {
    const LineFrame f = lineFrame(line, t_line);
    frames->push_back(f);
    const double pr = phase(rng), pp = phase(rng), ph = phase(rng), pz = phase(rng);
    const std::size_t li = frames->size() - 1;
    LineDrift drift = lineDrift(noise, li < noise.drift_scale_by_line.size() ? noise.drift_scale_by_line[li] : 1.0, rng);
    const long n0 = -static_cast<long>(std::ceil(lead_s / dt));
    const long n1 = static_cast<long>(std::ceil((f.t1 - f.t0 + lead_s) / dt));
    for (long k = n0; k <= n1; ++k) {
      const double t = f.t0 + static_cast<double>(k) * dt;
      TrajectorySample s;
      s.time_s = t;
      s.p_m = f.start + f.u * (f.speed * (t - f.t0)) + Vec3(0, 0, 0.5 * std::sin(2 * kPi * t / 30.0 + pz));
      s.roll = dyn.roll_amplitude_rad * std::sin(2 * kPi * t / dyn.roll_period_s + pr);
      s.pitch = dyn.pitch_amplitude_rad * std::sin(2 * kPi * t / dyn.pitch_period_s + pp);
      s.heading = line.heading_rad + dyn.heading_amplitude_rad * std::sin(2 * kPi * t / dyn.heading_period_s + ph);
      truth.push_back(s);
      const double step = std::max(t - t_prev, dt);
      t_prev = t;
      for (int a = 0; a < 3; ++a) {
        gnss_err[a] = gaussMarkov(gnss_err[a], step, noise.gnss_correlation_s, noise.gnss_sigma_m, rng);
        att_err[a] = gaussMarkov(att_err[a], step, noise.attitude_correlation_s, att_sigma[a], rng);
      }
      const std::array<double, 6> d = drift.at(t, dt, rng);
      TrajectorySample m = s;
      m.p_m += gnss_err + Vec3(d[0], d[1], d[2]);
      m.roll += att_err[0] + d[3];
      m.pitch += att_err[1] + d[4];
      m.heading += att_err[2] + d[5];
      measured.push_back(m);
    }
    t_line = f.t1 + config.line_gap_s;
  }
  out->true_trajectory = std::make_shared<const Trajectory>(std::move(truth));
  out->measured_trajectory = std::make_shared<const Trajectory>(std::move(measured));
}

/// What every line's simulation shares: the scene, both trajectories and mountings, the
/// features and the ROI centres (features and check planes) around which pulses are cast.
/// A multi-beam laser's constants for the per-pulse loop: the elevation's sine and cosine as it
/// fires and as the nominal model states it, and the turn from the fired azimuth α_f = α + δα_f
/// to the nominal one α_n = α + δα_n (sin α_n = sin α_f cos d + cos α_f sin d, d = δα_n − δα_f),
/// so that a pulse costs one sine and cosine, taken for a whole firing sequence at once.
struct LaserTrig {
  const LaserSpec* fired;
  const LaserSpec* nominal;
  double ce, se, ce_n, se_n, cd, sd;
  LaserTrig(const LaserSpec& f, const LaserSpec& n)
      : fired(&f),
        nominal(&n),
        ce(std::cos(f.elevation_rad)),
        se(std::sin(f.elevation_rad)),
        ce_n(std::cos(n.elevation_rad)),
        se_n(std::sin(n.elevation_rad)),
        cd(std::cos(n.azimuth_offset_rad - f.azimuth_offset_rad)),
        sd(std::sin(n.azimuth_offset_rad - f.azimuth_offset_rad)) {}
  /// MultiBeamModel::vector of the nominal model (SPEC §2 multi-beam) from the fired azimuth's sine and cosine.
  Vec3 nominalVector(double s_f, double c_f, double range_m) const {
    const double sa = s_f * cd + c_f * sd, ca = c_f * cd - s_f * sd;
    const double rho = range_m + nominal->range_offset_m, H = nominal->horizontal_offset_m;
    return {rho * ce_n * sa - H * ca, rho * ce_n * ca + H * sa, rho * se_n + nominal->vertical_offset_m};
  }
};

struct SurveyContext {
  const SurveyConfig& config;
  const Scene& scene;
  const Trajectory& T_true;
  const Trajectory& T_meas;
  const MountingParameters& M_true;
  const MountingParameters& M_nom;
  Mat3 R_bs_true, R_bs_nom;
  std::set<std::string> check_ids;
  std::vector<const FeaturePoint*> features;
  std::vector<Vec3> roi;
  MultiBeamModel fired;                               // the lasers as they fire: firedModel()
  std::vector<LaserTrig> laser_trig;                  // per laser: fired and nominal constants
  double roi_extra = 0;                               // check planes may be larger than the ROI radius
  mutable std::atomic<std::size_t> points_stored{0};  // by every line: SurveyConfig::max_points

  SurveyContext(const SurveyConfig& c, const Scene& s, const SimulatedSurvey& out)
      : config(c),
        scene(s),
        T_true(*out.true_trajectory),
        T_meas(*out.measured_trajectory),
        M_true(c.true_mounting),
        M_nom(c.nominal_mounting),
        R_bs_true(M_true.R_bs()),
        R_bs_nom(M_nom.R_bs()),
        check_ids(c.check_point_ids.begin(), c.check_point_ids.end()),
        fired(c.sensor == SensorType::kMultiBeam ? firedModel(c.multibeam) : MultiBeamModel{}) {
    const std::set<std::string> ignored(c.ignored_feature_ids.begin(), c.ignored_feature_ids.end());
    for (const FeaturePoint& fp : scene.features())
      if (!ignored.count(fp.id)) features.push_back(&fp);
    if (c.roi_radius_m > 0) {
      for (const FeaturePoint* fp : features) roi.push_back(fp->x_m);
      for (const PlanePatch& p : scene.checkPlanes()) roi.push_back(Vec3(0.5 * (p.xmin + p.xmax), 0.5 * (p.ymin + p.ymax), 0));
    }
    for (const PlanePatch& p : scene.checkPlanes()) roi_extra = std::max(roi_extra, 0.5 * std::hypot(p.xmax - p.xmin, p.ymax - p.ymin));
    if (c.sensor == SensorType::kMultiBeam)
      for (int i = 0; i < fired.laserCount(); ++i) laser_trig.push_back(LaserTrig(fired.laser(i), c.multibeam.model.laser(i)));
  }
};

/// One line of the survey: its pulses (within the ROI windows), its strip and its tie picks.
/// Each line has its own noise streams, seeded by the line's index.
class LineSimulator {
 public:
  LineSimulator(const SurveyContext& context, std::size_t line_index, const LineFrame& frame)
      : c_(context),
        config(context.config),
        noise(context.config.noise),
        scene(context.scene),
        T_true(context.T_true),
        T_meas(context.T_meas),
        M_true(context.M_true),
        M_nom(context.M_nom),
        R_bs_true(context.R_bs_true),
        R_bs_nom(context.R_bs_nom),
        roi(context.roi),
        li(line_index),
        line(context.config.lines[line_index]),
        f(frame),
        prng(config.seed * 1000003ull + li * 7919ull + 11),
        noise_normals(&prng) {
    strip.id = line.id;
    makeWindows();
  }

  /// At most one return per pulse: a span of d seconds fires at most d·rate pulses plus one (one
  /// sequence of every laser for a multi-beam); with an ROI about half the pulses are cast.
  double expectedPulses() const {
    double fire_time = 0;
    for (const auto& sp : spans) fire_time += sp.second - sp.first;
    const double rate = config.sensor == SensorType::kLine ? (line.prf_hz > 0 ? line.prf_hz : config.line.prf_hz)
                                                           : config.multibeam.model.laserCount() / config.multibeam.model.sequencePeriod();
    const double per_span = config.sensor == SensorType::kLine ? 1.0 : config.multibeam.model.laserCount();
    return fire_time * rate * (roi.empty() ? 1.0 : 0.5) + static_cast<double>(spans.size()) * per_span + 1.0;
  }

  /// Adds the points stored since the last call to the survey's count (every few thousand), and
  /// stops the survey once it exceeds SurveyConfig::max_points.
  void chargeBudget() {
    const std::size_t n = strip.points_m.size();
    if (n - charged_ < 4096) return;
    const std::size_t total = c_.points_stored.fetch_add(n - charged_) + (n - charged_);
    charged_ = n;
    if (static_cast<double>(total) > config.max_points) {
      char why[200];
      std::snprintf(why, sizeof why,
                    "more than %.3g points stored (the simulator's budget, about 180 bytes each): fly fewer, shorter or faster lines, or a "
                    "lower pulse rate",
                    config.max_points);
      throw InvalidInput("survey '" + config.name + "': " + why);
    }
  }

  SimulatedStrip& run() {
    reserve();
    for (const auto& span : spans) {
      if (config.sensor == SensorType::kLine)
        fireLineScanner(span);
      else
        fireMultiBeam(span);
    }
    return strip;
  }

  /// The tie picks of this strip's features: the moment the scan plane sweeps each feature,
  /// its apparent position with the measured trajectory and the nominal mounting, plus the
  /// picking noise.
  void pickTies(std::vector<TiePick>* ties_out, std::vector<TiePick>* checks_out) const {
    const std::vector<const FeaturePoint*>& features = c_.features;
    const double scan_axis_index = config.sensor == SensorType::kLine ? 0 : 2;  // scan-plane normal
    detail::Rng krng(config.seed * 2654435761ull + li * 40503ull + 3);
    for (const FeaturePoint* fp : features) {
      const Vec3& F = fp->x_m;
      const double s_c = f.along(Vec3(F.x(), F.y(), line.height_m));
      if (s_c < 0 || s_c > line.length_m) continue;
      // g(t): component of the true scanner-frame vector to F along the scan-plane normal.
      auto vecAt = [&](double t) {
        const Pose p = T_true.pose(t);
        return Vec3(R_bs_true.transpose() * (p.R_mb.transpose() * (F - p.p_m) - M_true.a_b));
      };
      const int axis = static_cast<int>(scan_axis_index);
      double lo = std::max(f.t0, f.t0 + s_c / f.speed - 3.0), hi = std::min(f.t1, f.t0 + s_c / f.speed + 3.0);
      double glo = vecAt(lo)[axis];
      bool bracketed = false;
      for (double t = lo + 0.05; t <= hi + 1e-9; t += 0.05) {
        const double g = vecAt(t)[axis];
        if ((g <= 0) != (glo <= 0)) {
          hi = t;
          bracketed = true;
          break;
        }
        lo = t;
        glo = g;
      }
      if (!bracketed) continue;
      for (int it = 0; it < 80 && hi - lo > 1e-10; ++it) {
        const double mid = 0.5 * (lo + hi);
        const double g = vecAt(mid)[axis];
        if ((g <= 0) == (glo <= 0)) {
          lo = mid;
          glo = g;
        } else {
          hi = mid;
        }
      }
      const double t = 0.5 * (lo + hi);
      const Vec3 r_true = vecAt(t);
      if (hidden(*fp, t)) continue;  // a surveyor cannot pick what the strip does not see
      Vec3 r_s_seen;
      if (config.sensor == SensorType::kLine) {
        const double theta = std::atan2(r_true.y(), r_true.z());
        if (std::abs(theta) > config.line.half_fov_rad * 0.98 || r_true.z() <= 0) continue;
        r_s_seen = LineScannerModel{}.vector(theta, std::hypot(r_true.y(), r_true.z()));
      } else {
        if (r_true.norm() > 0.9 * config.multibeam.max_range_m) continue;
        r_s_seen = r_true;
      }
      TiePick pick;
      pick.tie_id = fp->id;
      pick.strip_id = line.id;
      pick.true_m = F;
      pick.time_s = t;
      pick.apparent_m = georeference(T_meas.pose(t), R_bs_nom, M_nom.a_b, r_s_seen);
      pick.x_m = pick.apparent_m.x() + noise.pick_sigma_m * krng.normal();
      pick.y_m = pick.apparent_m.y() + noise.pick_sigma_m * krng.normal();
      (c_.check_ids.count(fp->id) ? *checks_out : *ties_out).push_back(pick);
    }
  }

 private:
  /// Is feature `fp` hidden from the true scanner position at time t by a solid surface (a roof,
  /// a wall, a board) more than 5 cm before it? Vegetation is not an occluder here: a crown lets
  /// part of the pulses through, and a pick is made on the points that reach the feature.
  bool hidden(const FeaturePoint& fp, double t) const {
    const Pose p = T_true.pose(t);
    const Vec3 origin = p.p_m + p.R_mb * M_true.a_b;
    const Vec3 to = fp.x_m - origin;
    const double range = to.norm();
    if (!(range > 0)) return false;
    Hit hit;
    if (!scene.cast(origin, to / range, 0, &hit, range + 1.0)) return false;
    return hit.range_m < range - 0.05 && hit.kind != SurfaceKind::kVegetation && hit.kind != SurfaceKind::kGround &&
           hit.kind != SurfaceKind::kMarking;
  }

  /// Time windows of the ROI centres along this line, and the time spans to fire in: the whole
  /// line, or the union of the windows.
  void makeWindows() {
    const double margin = line.height_m * std::tan(deg2rad(3.0)) + 1.0;
    for (std::size_t k = 0; k < roi.size(); ++k) {
      const double r = config.roi_radius_m + (k >= c_.features.size() ? c_.roi_extra : 0.0);
      const double s = f.along(Vec3(roi[k].x(), roi[k].y(), line.height_m));
      windows.push_back({f.t0 + (s - r - margin) / f.speed, f.t0 + (s + r + margin) / f.speed, roi[k], r});
    }
    if (roi.empty()) {
      spans.push_back({f.t0, f.t1});
      return;
    }
    for (const Window& w : windows) {
      const double a = std::max(w.t0, f.t0), b = std::min(w.t1, f.t1);
      if (a < b) spans.push_back({a, b});
    }
    std::sort(spans.begin(), spans.end());
    std::vector<std::pair<double, double>> merged;
    for (const auto& s : spans) {
      if (!merged.empty() && s.first <= merged.back().second)
        merged.back().second = std::max(merged.back().second, s.second);
      else
        merged.push_back(s);
    }
    spans.swap(merged);
  }

  static constexpr double kRoiMargin = 3.0;  // [m] beyond a window's radius, inRoi keeps a pulse

  bool inRoi(double t, const Vec3& approx) const {
    if (roi.empty()) return true;
    for (const Window& w : windows) {
      if (t < w.t0 || t > w.t1) continue;
      const double dx = approx.x() - w.c.x(), dy = approx.y() - w.c.y();
      if (dx * dx + dy * dy < (w.r + kRoiMargin) * (w.r + kRoiMargin)) return true;
    }
    return false;
  }

  /// expectedPulses() reserved (at most the points budget): without an ROI the last pulse never
  /// doubles the arrays (a copy of the whole strip and as much memory again).
  void reserve() {
    const std::size_t expected = static_cast<std::size_t>(std::min({expectedPulses(), 5e7, config.max_points + 8192.0}));
    strip.pulses.reserve(expected);
    strip.points_m.reserve(expected);
    strip.true_points_m.reserve(expected);
    strip.kinds.reserve(expected);
    detail::adviseHugePages(strip.pulses);
    detail::adviseHugePages(strip.points_m);
    detail::adviseHugePages(strip.true_points_m);
  }

  /// One pulse from the true origin and direction (mapping frame); `measured(r_s)` georeferences
  /// the observed laser vector with the measured trajectory and the nominal mounting.
  /// A line scanner's pulse also brings sin θ and cos θ of its scan angle (`sc`, null otherwise).
  template <class Measured>
  void emit(double t, const Vec3& origin, const Vec3& dir, std::uint64_t pulse_id, Measured&& measured, RawPulse raw, double max_range,
            double range_offset, const double* sc) {
    if (!roi.empty()) {
      const double ground = scene.groundHeight(origin.x(), origin.y());
      if (dir.z() > -1e-6) return;
      const Vec3 approx = origin + dir * ((origin.z() - ground) / -dir.z());
      if (!inRoi(t, approx)) return;
    }
    Hit hit;
    if (!scene.cast(origin, dir, pulse_id, &hit, max_range)) return;
    raw.time_s = t;
    // The sensor model adds its range offset to the measured range: measured = path − offset.
    raw.range_m = hit.range_m - range_offset + (noise.range_sigma_m > 0 ? noise.range_sigma_m * noise_normals.next() : 0.0);
    raw.intensity = hit.intensity;
    Vec3 r_s_obs;
    if (config.sensor == SensorType::kLine) {
      const double theta = raw.angle_rad;
      if (noise.scan_angle_sigma_rad > 0) raw.angle_rad += noise.scan_angle_sigma_rad * noise_normals.next();
      // LineScannerModel{}.vector(θ', ρ) = ρ (0, sin θ', cos θ') with θ' = θ + δ by the angle
      // sum from the block's sin θ, cos θ, and δ's series (δ⁷/7! < 1e-25 for |δ| ≤ 1e-3 rad).
      const double d = raw.angle_rad - theta;
      if (std::abs(d) <= 1e-3) {
        const double d2 = d * d;
        const double sd = d * (1.0 - d2 / 6.0 * (1.0 - d2 / 20.0)), cd = 1.0 - d2 / 2.0 * (1.0 - d2 / 12.0);
        r_s_obs = Vec3(0.0, raw.range_m * (sc[0] * cd + sc[1] * sd), raw.range_m * (sc[1] * cd - sc[0] * sd));
      } else {
        r_s_obs = LineScannerModel{}.vector(raw.angle_rad, raw.range_m);
      }
    } else {
      // sc: the fired azimuth's sine and cosine (fireMultiBeam), so no trigonometry per pulse here
      r_s_obs = c_.laser_trig[static_cast<std::size_t>(raw.laser_id)].nominalVector(sc[0], sc[1], raw.range_m);
    }
    raw.r_s = r_s_obs;
    strip.points_m.push_back(measured(r_s_obs));  // seed eq. (1)
    strip.true_points_m.push_back(hit.point_m);
    strip.kinds.push_back(hit.kind);
    strip.pulses.push_back(raw);
  }

  void fireLineScanner(const std::pair<double, double>& span) {
    const std::size_t li_ = li;
    LineScannerConfig scanner = config.line;
    if (line.prf_hz > 0) scanner.prf_hz = line.prf_hz;
    if (line.scan_rate_hz > 0) scanner.scan_rate_hz = line.scan_rate_hz;
    const double prf = scanner.prf_hz;
    const long k0 = static_cast<long>(std::ceil((span.first - f.t0) * prf));
    const long k1 = static_cast<long>(std::floor((span.second - f.t0) * prf));
    // Both trajectories' attitudes expanded once per interval (detail::IntervalExpansion,
    // exact within 1e-11 m), not a slerp per pulse. Pulses go in blocks: the mirror angles
    // and their sines and cosines for a whole block in one vectorised pass
    // (detail::sinCosBatch, within 4e-16 of libm), then the pulses one by one.
    constexpr long kBlock = 256;
    double t_blk[kBlock], arg_blk[kBlock], theta_blk[kBlock], sin_blk[kBlock], cos_blk[kBlock];
    for (long kb = k0; kb <= k1; kb += kBlock) {
      chargeBudget();
      const std::size_t nb = static_cast<std::size_t>(std::min(kBlock, k1 - kb + 1));
      for (std::size_t j = 0; j < nb; ++j) t_blk[j] = f.t0 + static_cast<double>(kb + static_cast<long>(j)) / prf;
      if (scanner.pattern == MirrorPattern::kSinusoidal) {
        // mirrorAngle(): half_fov · sin(2π frac), the sines of the block at once
        for (std::size_t j = 0; j < nb; ++j) arg_blk[j] = 2.0 * kPi * mirrorFraction(scanner, t_blk[j] - f.t0);
        detail::sinCosBatch(arg_blk, sin_blk, cos_blk, nb);
        for (std::size_t j = 0; j < nb; ++j) theta_blk[j] = scanner.half_fov_rad * sin_blk[j];
      } else {
        for (std::size_t j = 0; j < nb; ++j) theta_blk[j] = mirrorAngle(scanner, t_blk[j] - f.t0);
      }
      detail::sinCosBatch(theta_blk, sin_blk, cos_blk, nb);
      for (std::size_t j = 0; j < nb; ++j) {
        const long k = kb + static_cast<long>(j);
        const double t = t_blk[j];
        RawPulse raw;
        raw.angle_rad = theta_blk[j];
        const double sc[2] = {sin_blk[j], cos_blk[j]};
        const Vec3 dir_s(0.0, sc[0], sc[1]);
        const std::size_t i = T_true.locate(t, &cur_true);
        if (i != e_true.interval) detail::expandInterval(T_true, i, R_bs_true, M_true.a_b, false, &e_true);
        Vec3 origin, dir;
        if (e_true.exact) {
          const Pose truth = T_true.interpolateInInterval(i, t);
          origin = truth.p_m + truth.R_mb * M_true.a_b;
          dir = truth.R_mb * (R_bs_true * dir_s);
        } else {
          origin = detail::originExpanded(e_true, t);
          dir = detail::rotateExpandedYZ(e_true, t, sc[0], sc[1]);
        }
        auto measured = [&](const Vec3& r_s) {
          // Both trajectories were sampled at the same times (above): one interval lookup.
          const std::size_t jm = i;
          if (jm != e_meas.interval) detail::expandInterval(T_meas, jm, R_bs_nom, M_nom.a_b, false, &e_meas);
          return e_meas.exact ? georeference(T_meas.interpolateInInterval(jm, t), R_bs_nom, M_nom.a_b, r_s)
                              : detail::forwardExpandedYZ(e_meas, t, r_s.y(), r_s.z());  // r_s.x() = 0
        };
        emit(t, origin, dir, (static_cast<std::uint64_t>(li_) << 40) + static_cast<std::uint64_t>(k), measured, raw, 1e5, 0.0, sc);
      }
    }
  }

  void fireMultiBeam(const std::pair<double, double>& span) {
    const MultiBeamModel& mb = config.multibeam.model;
    const double period = mb.sequencePeriod();
    const long s0 = static_cast<long>(std::ceil((span.first - f.t0) / period));
    const long s1 = static_cast<long>(std::floor((span.second - f.t0) / period));
    const int n_lasers = mb.laserCount();
    // One firing sequence at a time: its times and fired azimuths α_f = α + δα_f, then their sines
    // and cosines in one vectorised pass (detail::sinCosBatch, within 4e-16 of libm).
    std::vector<double> t_seq(static_cast<std::size_t>(n_lasers)), az_seq(t_seq.size()), alpha_seq(t_seq.size()), sin_seq(t_seq.size()),
        cos_seq(t_seq.size());
    AzimuthGate gate(*this);
    for (long s = s0; s <= s1; ++s) {
      if ((s & 63) == 0) chargeBudget();
      if (!gate.mayHit(f.t0 + mb.firingTime(0, s), f.t0 + mb.firingTime(n_lasers - 1, s))) continue;
      int n_fire = 0;
      for (int laser = 0; laser < n_lasers; ++laser, ++n_fire) {
        const double t = f.t0 + mb.firingTime(laser, s);
        if (t > f.t1) break;
        const double az = 2 * kPi * config.multibeam.rotation_hz * (t - f.t0);
        t_seq[static_cast<std::size_t>(laser)] = t;
        az_seq[static_cast<std::size_t>(laser)] = az - 2 * kPi * std::floor(az / (2 * kPi));
        alpha_seq[static_cast<std::size_t>(laser)] =
            az_seq[static_cast<std::size_t>(laser)] + c_.laser_trig[static_cast<std::size_t>(laser)].fired->azimuth_offset_rad;
      }
      detail::sinCosBatch(alpha_seq.data(), sin_seq.data(), cos_seq.data(), static_cast<std::size_t>(n_fire));
      for (int laser = 0; laser < n_fire; ++laser) {
        const std::size_t k = static_cast<std::size_t>(laser);
        const double t = t_seq[k];
        const std::size_t i = T_true.locate(t, &cur_true);
        if (i != e_true.interval) detail::expandInterval(T_true, i, R_bs_true, M_true.a_b, false, &e_true);
        RawPulse raw;
        raw.laser_id = laser;
        raw.angle_rad = az_seq[k];
        const LaserTrig& lt = c_.laser_trig[k];  // as it really fires (MultiBeamConfig::laser_errors)
        const LaserSpec& spec = *lt.fired;
        const double sa = sin_seq[k], ca = cos_seq[k];
        const Vec3 dir_s(lt.ce * sa, lt.ce * ca, lt.se);
        // r_s = ρ' u + H (−cos α', sin α', 0) + (0, 0, V) (MultiBeamModel::vector)
        const Vec3 origin_s(-spec.horizontal_offset_m * ca, spec.horizontal_offset_m * sa, spec.vertical_offset_m);
        Vec3 origin, dir;
        if (e_true.exact) {
          const Pose truth = T_true.interpolateInInterval(i, t);
          origin = truth.p_m + truth.R_mb * (R_bs_true * origin_s + M_true.a_b);
          dir = truth.R_mb * (R_bs_true * dir_s);
        } else {  // the interval's expansion, as the line scanner's loop (interval_expansion.hpp)
          detail::rayExpanded(e_true, t, origin_s, dir_s, &origin, &dir);
        }
        auto measured = [&](const Vec3& r_s) {
          const std::size_t jm = T_meas.locate(t, &cur_meas);
          if (jm != e_meas.interval) detail::expandInterval(T_meas, jm, R_bs_nom, M_nom.a_b, false, &e_meas);
          return e_meas.exact ? georeference(T_meas.interpolateInInterval(jm, t), R_bs_nom, M_nom.a_b, r_s)
                              : detail::forwardExpanded(e_meas, t, r_s);
        };
        const double sc[2] = {sa, ca};
        emit(t, origin, dir,
             (static_cast<std::uint64_t>(li) << 40) + static_cast<std::uint64_t>(s) * 64u + static_cast<std::uint64_t>(laser), measured,
             raw, config.multibeam.max_range_m, spec.range_offset_m, sc);
      }
    }
  }

  struct Window {
    double t0, t1;
    Vec3 c;
    double r;
  };

  /// Which firing sequences of a spinning scanner can reach an ROI window at all: emit() keeps a
  /// pulse whose ray meets the horizontal plane of the ground under the sensor within r + 3 m of
  /// an open window's centre (inRoi). Those points lie in a ball of that radius around the centre
  /// on that plane, and a ray's azimuth in the scanner frame is its laser's fired azimuth, so a
  /// sequence can reach the window only if its azimuths fall within asin(R / ρ) of the centre's
  /// (ρ: the centre's distance from the spin axis; R widened by the lasers' horizontal origin
  /// offsets and a margin). The bearing is evaluated on a 1 ms grid of the true trajectory and the
  /// two grid points around a sequence are united, with 0.5° for the motion between them. A
  /// skipped sequence is one whose every pulse emit() would have dropped, and the noise streams
  /// are drawn per emitted pulse, so the survey is the same to the last bit — 10–20× fewer pulses
  /// set up for a UAV's ROI survey.
  class AzimuthGate {
   public:
    explicit AzimuthGate(const LineSimulator& sim) : sim_(sim) {
      const MultiBeamModel& mb = sim.c_.fired;
      for (int l = 0; l < mb.laserCount(); ++l) {
        const LaserSpec& spec = mb.laser(l);
        lo_offset_ = std::min(lo_offset_, spec.azimuth_offset_rad);
        hi_offset_ = std::max(hi_offset_, spec.azimuth_offset_rad);
        origin_ = std::max(origin_, std::abs(spec.horizontal_offset_m));
      }
      cache_.assign(2 * sim.windows.size(), {});  // two slots per window (bearing())
    }

    /// May a sequence fired from t_first to t_last reach an open window?
    bool mayHit(double t_first, double t_last) {
      if (sim_.roi.empty() || !sim_.config.multibeam.azimuth_gate) return true;
      const double k = std::floor((t_first - sim_.f.t0) / kStep);
      const double two_pi = 2 * kPi, rate = two_pi * sim_.config.multibeam.rotation_hz;
      // The sequence's azimuths [a_lo, a_lo + width], a_lo in [0, 2π).
      double a_lo = rate * (t_first - sim_.f.t0) + lo_offset_ - kMargin;
      a_lo -= two_pi * std::floor(a_lo / two_pi);
      const double width = rate * (t_last - t_first) + hi_offset_ - lo_offset_ + 2 * kMargin;
      if (width >= kPi) return true;
      for (std::size_t w = 0; w < sim_.windows.size(); ++w) {
        const Window& win = sim_.windows[w];
        if (t_last < win.t0 || t_first > win.t1) continue;
        for (double g : {k, k + 1}) {
          const Bearing& b = bearing(w, g);
          if (b.half >= kPi) return true;
          // The bearing's distance from the azimuths, modulo 2π: d in [0, 2π) past a_lo.
          double d = b.phi - a_lo;  // in (−3π, π]
          while (d < 0) d += two_pi;
          if (d <= width + b.half || two_pi - d <= b.half) return true;
        }
      }
      return false;
    }

   private:
    struct Bearing {
      double phi = 0, half = kPi;
    };
    static constexpr double kStep = 1e-3;                 // [s] the bearing's grid
    static constexpr double kMargin = 0.5 * kPi / 180.0;  // [rad] the motion within a step, and more
    static constexpr double kSlack = 0.5;                 // [m] the ground under each laser's origin, and more

    const Bearing& bearing(std::size_t w, double grid) {
      // Two slots per window, by the grid point's parity: a sequence asks for k and k + 1.
      const long key = static_cast<long>(grid);  // ≥ 0: a span starts at or after the line's t0
      Slot& slot = cache_[2 * w + static_cast<std::size_t>(key & 1)];
      if (slot.first != key) slot = {key, compute(sim_.windows[w], sim_.f.t0 + grid * kStep)};
      return slot.bearing;
    }

    Bearing compute(const Window& win, double t) const {
      const Pose p = sim_.T_true.pose(t);
      const Mat3 R_ms = p.R_mb * sim_.R_bs_true;
      const Vec3 o = p.p_m + p.R_mb * sim_.M_true.a_b;
      const Vec3 centre(win.c.x(), win.c.y(), sim_.scene.groundHeight(o.x(), o.y()));
      const Vec3 v_s = R_ms.transpose() * (centre - o);
      const double rho = std::hypot(v_s.x(), v_s.y()), radius = win.r + kRoiMargin + origin_ + kSlack;
      Bearing b;
      if (rho > radius) b = {std::atan2(v_s.x(), v_s.y()), std::asin(radius / rho)};
      return b;
    }

    struct Slot {
      long first = -1;  // the grid point held; −1: none yet
      Bearing bearing;
    };
    const LineSimulator& sim_;
    double lo_offset_ = 0, hi_offset_ = 0, origin_ = 0;
    std::vector<Slot> cache_;
  };
  const SurveyContext& c_;
  const SurveyConfig& config;
  const NoiseModel& noise;
  const Scene& scene;
  const Trajectory& T_true;
  const Trajectory& T_meas;
  const MountingParameters& M_true;
  const MountingParameters& M_nom;
  const Mat3& R_bs_true;
  const Mat3& R_bs_nom;
  const std::vector<Vec3>& roi;
  const std::size_t li;
  const FlightLine& line;
  const LineFrame& f;
  detail::Rng prng;
  detail::BufferedNormals noise_normals;  // prng's normal deviates, drawn in batches
  std::vector<Window> windows;
  std::vector<std::pair<double, double>> spans;
  SimulatedStrip strip;
  std::size_t charged_ = 0;  // points of this strip already added to the survey's count
  std::size_t cur_true = 0, cur_meas = 0;
  detail::IntervalExpansion e_true, e_meas;
};

/// Keeps only features seen on at least two strips, sorted by id.
void pruneSingleViews(std::vector<TiePick>* picks) {
  std::map<std::string, int> count;
  for (const TiePick& p : *picks) ++count[p.tie_id];
  picks->erase(std::remove_if(picks->begin(), picks->end(), [&](const TiePick& p) { return count[p.tie_id] < 2; }), picks->end());
  std::stable_sort(picks->begin(), picks->end(), [](const TiePick& a, const TiePick& b) { return a.tie_id < b.tie_id; });
}

}  // namespace

SimulatedSurvey simulate(const SurveyConfig& config, const Scene& scene) {
  validate(config);
  SimulatedSurvey out;
  out.config = config;
  std::vector<LineFrame> frames;
  simulateTrajectories(config, &out, &frames);
  const SurveyContext context(config, scene, out);
  // Each line on its own thread (its own noise streams, seeded by the line's index), merged in
  // line order: the survey does not depend on the number of threads.
  const std::size_t n_lines = config.lines.size();
  std::vector<SimulatedStrip> strips_out(n_lines);
  std::vector<std::vector<TiePick>> ties_out(n_lines), checks_out(n_lines);
  std::vector<std::unique_ptr<LineSimulator>> lines;  // the windows of every line, to check the budget first
  double pulses = 0;
  for (std::size_t li = 0; li < n_lines; ++li) {
    lines.push_back(std::make_unique<LineSimulator>(context, li, frames[li]));
    pulses += lines.back()->expectedPulses();
  }
  if (pulses > config.max_pulses) {
    char why[256];
    std::snprintf(why, sizeof why,
                  "%.3g pulses to cast over %zu lines; the simulator's budget is %.3g: fly fewer, shorter or faster lines, or a lower "
                  "pulse rate",
                  pulses, n_lines, config.max_pulses);
    throw InvalidInput("survey '" + config.name + "': " + why);
  }
  detail::parallelFor(n_lines, config.threads, [&](std::size_t li) {
    LineSimulator& line = *lines[li];
    SimulatedStrip& strip = line.run();
    line.pickTies(&ties_out[li], &checks_out[li]);
    strips_out[li] = std::move(strip);
    lines[li].reset();
  });
  for (std::size_t li = 0; li < n_lines; ++li) {
    out.strips.push_back(std::move(strips_out[li]));
    out.ties.insert(out.ties.end(), ties_out[li].begin(), ties_out[li].end());
    out.check_points.insert(out.check_points.end(), checks_out[li].begin(), checks_out[li].end());
  }
  pruneSingleViews(&out.ties);
  pruneSingleViews(&out.check_points);
  std::set<std::string> tie_ids;
  for (const TiePick& p : out.ties) tie_ids.insert(p.tie_id);
  for (const FeaturePoint* fp : context.features)
    if (tie_ids.count(fp->id)) out.gcps.push_back(*fp);
  out.check_planes = scene.checkPlanes();
  out.plane_regions = scene.planeRegions();
  out.target_regions = scene.targetRegions();
  return out;
}

CalibrationData toCalibrationData(const SimulatedSurvey& survey, bool use_check_points) {
  CalibrationData d;
  d.trajectory = survey.measured_trajectory;
  d.mounting_used = survey.config.nominal_mounting;
  const bool lasers = survey.config.sensor == SensorType::kMultiBeam;
  for (const SimulatedStrip& s : survey.strips) {
    StripData strip;
    strip.id = s.id;
    strip.time_s.reserve(s.pulses.size());
    strip.r_s.reserve(s.pulses.size());
    for (const RawPulse& p : s.pulses) {
      strip.time_s.push_back(p.time_s);
      strip.r_s.push_back(p.r_s);
      strip.intensity.push_back(p.intensity);
      if (lasers) strip.laser.push_back(static_cast<std::uint16_t>(p.laser_id));
    }
    strip.x_m = s.points_m;
    d.strips.push_back(std::move(strip));
  }
  for (const TiePick& p : use_check_points ? survey.check_points : survey.ties) {
    d.ties.push_back({p.tie_id, p.strip_id, p.x_m, p.y_m, 0});
  }
  for (const PlanePatch& p : survey.plane_regions) d.plane_regions.push_back({p.id, p.xmin, p.ymin, p.xmax, p.ymax});
  for (const PlanePatch& p : survey.target_regions) d.target_regions.push_back({p.id, p.xmin, p.ymin, p.xmax, p.ymax});
  return d;
}

std::vector<LaserSpec> drawLaserErrors(int lasers, std::uint64_t seed, double elevation_sigma_rad, double azimuth_sigma_rad,
                                       double vertical_sigma_m, double range_sigma_m, double horizontal_sigma_m) {
  if (lasers <= 0) return {};
  detail::Rng rng(seed);
  std::vector<LaserSpec> e(static_cast<std::size_t>(lasers));
  LaserSpec mean;
  for (LaserSpec& l : e) {
    l.elevation_rad = elevation_sigma_rad * rng.normal();
    l.azimuth_offset_rad = azimuth_sigma_rad * rng.normal();
    l.vertical_offset_m = vertical_sigma_m * rng.normal();
    l.range_offset_m = range_sigma_m * rng.normal();
    // Drawn last and only when asked for, so that a seed draws the other groups as before.
    if (horizontal_sigma_m > 0) l.horizontal_offset_m = horizontal_sigma_m * rng.normal();
    mean.elevation_rad += l.elevation_rad / lasers;
    mean.azimuth_offset_rad += l.azimuth_offset_rad / lasers;
    mean.vertical_offset_m += l.vertical_offset_m / lasers;
  }
  // The common parts are the mounting's (see the declaration); a common range offset is not.
  for (LaserSpec& l : e) {
    l.elevation_rad -= mean.elevation_rad;
    l.azimuth_offset_rad -= mean.azimuth_offset_rad;
    l.vertical_offset_m -= mean.vertical_offset_m;
  }
  return e;
}

LaserErrorSigmas laserErrorPreset(const std::string& sensor_model) {
  LaserErrorSigmas s;
  s.elevation_rad = s.azimuth_rad = deg2rad(0.05);
  s.vertical_m = s.horizontal_m = 0.005;
  if (sensor_model == "VLP-16") {
    s.range_m = 0.010;
  } else if (sensor_model == "HDL-32E") {
    s.range_m = 0.007;
  } else {
    throw InvalidInput("laser error preset '" + sensor_model + "': expected \"VLP-16\" or \"HDL-32E\"");
  }
  return s;
}

std::vector<LaserSpec> drawLaserErrorsOnSeenLasers(const SurveyConfig& config, const Scene& scene, std::uint64_t seed,
                                                   const LaserErrorSigmas& sigmas, int min_points) {
  SurveyConfig clean = config;
  clean.multibeam.laser_errors.clear();
  const int L = clean.multibeam.model.laserCount();
  std::vector<int> points(static_cast<std::size_t>(L), 0);
  for (const SimulatedStrip& st : simulate(clean, scene).strips)
    for (const RawPulse& q : st.pulses)
      if (q.laser_id >= 0 && q.laser_id < L) ++points[static_cast<std::size_t>(q.laser_id)];
  std::vector<LaserSpec> e =
      drawLaserErrors(L, seed, sigmas.elevation_rad, sigmas.azimuth_rad, sigmas.vertical_m, sigmas.range_m, sigmas.horizontal_m);
  LaserSpec mean;
  int seen = 0;
  for (std::size_t i = 0; i < e.size(); ++i) {
    if (points[i] < min_points) {
      e[i] = LaserSpec{};
      continue;
    }
    ++seen;
    mean.elevation_rad += e[i].elevation_rad;
    mean.azimuth_offset_rad += e[i].azimuth_offset_rad;
    mean.vertical_offset_m += e[i].vertical_offset_m;
  }
  for (std::size_t i = 0; i < e.size() && seen > 0; ++i) {
    if (points[i] < min_points) continue;
    e[i].elevation_rad -= mean.elevation_rad / seen;
    e[i].azimuth_offset_rad -= mean.azimuth_offset_rad / seen;
    e[i].vertical_offset_m -= mean.vertical_offset_m / seen;
  }
  return e;
}

MultiBeamModel firedModel(const MultiBeamConfig& config) {
  MultiBeamModel m = config.model;
  if (config.laser_errors.empty()) return m;
  if (static_cast<int>(config.laser_errors.size()) != m.laserCount())
    throw InvalidInput(std::to_string(config.laser_errors.size()) + " laser errors for " + std::to_string(m.laserCount()) + " lasers");
  for (std::size_t i = 0; i < config.laser_errors.size(); ++i) {
    LaserSpec& l = m.lasers()[i];
    const LaserSpec& e = config.laser_errors[i];
    l.elevation_rad += e.elevation_rad;
    l.azimuth_offset_rad += e.azimuth_offset_rad;
    l.vertical_offset_m += e.vertical_offset_m;
    l.range_offset_m += e.range_offset_m;
    l.horizontal_offset_m += e.horizontal_offset_m;
  }
  return m;
}

std::vector<TieObservation> paperFiveTies(const SimulatedSurvey& s) {
  const std::vector<std::pair<std::string, std::vector<std::string>>> plan = {{"ring_1", {"1", "3"}},
                                                                              {"ring_5", {"2", "4"}},
                                                                              {"zebra_a_c0", {"1", "2"}},
                                                                              {"ring_13", {"2", "3", "4"}},
                                                                              {"bldg_a_r2", {"1", "3", "4"}}};
  std::vector<TieObservation> out;
  for (const auto& [tie, strips] : plan)
    for (const std::string& strip : strips)
      for (const TiePick& p : s.ties)
        if (p.tie_id == tie && p.strip_id == strip) out.push_back({tie, strip, p.x_m, p.y_m, 0});
  return out;
}

std::vector<PlaneRegion> flatGroundRegions(const SimulatedSurvey& s, double h) {
  std::vector<PlaneRegion> out;
  for (const FeaturePoint& f : s.gcps) {
    if (f.id.rfind("ring_", 0) != 0 || f.id.find('_', 5) != std::string::npos) continue;  // ring centres only
    out.push_back({"ground_" + f.id, f.x_m.x() - h, f.x_m.y() - h, f.x_m.x() + h, f.x_m.y() + h});
  }
  return out;
}

}  // namespace mountcal::simulation
