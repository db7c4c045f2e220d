#include "mountcal/mounting_calibrator.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>
#include <sstream>

#include "mountcal/core/error.hpp"

namespace mountcal {

bool MountingCalibrator::Options::IsValid(std::string* error) const {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  if (!MountingAdjustment::Options::IsValid(error)) return false;
  if (methods.empty()) return fail("methods is empty: name at least one calibration method");
  if (threads < 0 || threads > 4096) return fail("threads must be in [0, 4096] (0: every core)");
  std::set<std::string> named;
  for (const std::string& name : methods) {
    const Method* m = findMethod(name);
    if (!m || m->implicit()) return fail("unknown method '" + name + "' (methods: " + methodNames() + ")");
    if (!named.insert(name).second) return fail("method '" + name + "' named twice");
  }
  for (const auto& m : registeredMethods()) {
    const std::any defaults = m->defaultOptions();
    if (!validateMethodOptions(*m, method_options.at(m->name(), defaults), error)) return false;
  }
  // One block of per-laser intrinsics per calibration (Method::estimatesLaserIntrinsics).
  std::vector<std::string> laser_methods;
  for (const std::string& name : methods) {
    const Method* m = findMethod(name);
    const std::any defaults = m->defaultOptions();
    if (m->estimatesLaserIntrinsics(method_options.at(name, defaults))) laser_methods.push_back(name);
  }
  if (laser_methods.size() > 1)
    return fail("methods '" + laser_methods[0] + "' and '" + laser_methods[1] +
                "' would each estimate per-laser offsets (their laser_*_sigma options; a multi-beam job's correspondences have "
                "laser_elevation_sigma_deg 0.15 by default): one calibration holds one set of laser corrections — set one "
                "method's laser_*_sigma options to 0");
  return true;
}

const MethodSection* MountingCalibrator::Summary::section(const std::string& method) const {
  for (const auto& s : sections)
    if (s->method() == method) return s.get();
  return nullptr;
}

bool MountingCalibrator::Summary::uses(const std::string& method) const {
  return std::find(methods.begin(), methods.end(), method) != methods.end();
}

LaserCorrections MountingCalibrator::Summary::laserCorrections() const {
  for (const auto& s : sections) {
    LaserCorrections lasers = s->laserCorrections();
    if (!lasers.empty()) return lasers;
  }
  return {};
}

namespace {

/// The modules that run: the named methods and the implicit ones (ground control), in
/// registry order — the order their observations join the adjustment.
std::vector<const Method*> modulesToRun(const std::vector<std::string>& named) {
  std::vector<const Method*> out;
  for (const auto& m : registeredMethods())
    if (m->implicit() || std::find(named.begin(), named.end(), m->name()) != named.end()) out.push_back(m.get());
  return out;
}

/// Ground control points that no named method observes itself.
std::vector<GroundControlPoint> unclaimedGcps(const CalibrationData& data, const std::vector<const Method*>& modules) {
  std::set<std::string> claimed;
  for (const Method* m : modules) {
    if (m->implicit()) continue;
    const std::set<std::string> ids = m->claimedGcps(data);
    claimed.insert(ids.begin(), ids.end());
  }
  std::vector<GroundControlPoint> out;
  for (const GroundControlPoint& g : data.gcps)
    if (!claimed.count(g.id)) out.push_back(g);
  return out;
}

/// Every module's run on the data: the observation sources, and the first start a method
/// offers (e.g. a closed form).
struct Runs {
  std::vector<std::pair<const Method*, std::unique_ptr<MethodRun>>> runs;
  std::vector<ObservationSource*> sources;
  const std::array<double, 6>* start = nullptr;
  bool rematches() const {
    for (const ObservationSource* s : sources)
      if (s->rematches()) return true;
    return false;
  }
};

Runs buildRuns(const CalibrationData& data, const MountingCalibrator::Options& options, const std::vector<const Method*>& modules,
               const std::vector<GroundControlPoint>& free_gcps) {
  Runs out;
  for (const Method* m : modules) {
    const std::any defaults = m->defaultOptions();
    const MethodContext context{data, options.method_options.at(m->name(), defaults), options, options.threads, free_gcps};
    std::unique_ptr<MethodRun> run = m->run(context);
    if (!run) continue;  // an implicit module with nothing to do
    for (ObservationSource* s : run->sources()) out.sources.push_back(s);
    if (!out.start) out.start = run->start();
    out.runs.emplace_back(m, std::move(run));
  }
  return out;
}

/// The adjustment, with the platform's motion (for the time offset) from the trajectory:
/// central differences over ±0.05 s (cut at its ends). Strips with per-point poses carry their
/// own time: no motion for them.
MountingAdjustment adjustment(const MountingCalibrator::Options& options, const CalibrationData& data) {
  MountingAdjustment a(options);
  if (!(options.time_offset_sigma_s > 0) || !data.trajectory) return a;
  std::set<std::string> own_poses;
  for (const StripData& s : data.strips)
    if (!s.poses.empty()) own_poses.insert(s.id);
  std::shared_ptr<const Trajectory> trajectory = data.trajectory;
  a.setMotion([trajectory, own_poses](const std::string& strip, double t, Vec3* v, Vec3* w) {
    if (own_poses.count(strip)) return false;
    const double lo = std::max(trajectory->startTime(), t - 0.05), hi = std::min(trajectory->endTime(), t + 0.05);
    if (!(hi - lo > 1e-3)) return false;
    const Pose a0 = trajectory->pose(lo), a1 = trajectory->pose(hi);
    *v = (a1.p_m - a0.p_m) / (hi - lo);
    const Eigen::AngleAxisd turn(a1.R_mb * a0.R_mb.transpose());  // exp([ω]× Δt)
    *w = turn.angle() / (hi - lo) * turn.axis();
    return true;
  });
  return a;
}

/// AnalysisOptions::resolve_check: the observations built afresh and solved from `summary`'s
/// estimate, so that every matching is done again there.
MountingCalibrator::Summary::ResolveCheck resolveFrom(const MountingCalibrator::Summary& summary, const CalibrationData& data,
                                                      const MountingCalibrator::Options& options, const std::vector<const Method*>& modules,
                                                      const std::vector<GroundControlPoint>& free_gcps) {
  const auto t0 = std::chrono::steady_clock::now();
  MountingCalibrator::Summary::ResolveCheck check;
  Runs again = buildRuns(data, options, modules, free_gcps);
  if (again.sources.empty()) return check;
  const std::array<double, 6> start = summary.mounting.toArray();
  const AdjustmentSummary re = adjustment(options, data).solve(data.mounting_used, again.sources, &start);
  check.done = true;
  check.usable = re.IsSolutionUsable();
  check.mounting = re.mounting;
  const auto a = summary.mounting.toArray(), b = re.mounting.toArray();
  for (int j = 0; j < 6; ++j) {
    if (!summary.estimated[j]) continue;
    check.shift[j] = b[j] - a[j];
    check.shift_in_sigma[j] = std::abs(check.shift[j]) / summary.sigma[j];
  }
  check.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return check;
}

/// Model sensitivity of the per-laser offsets, solved (ModelSensitivity::solved): when their
/// first-order entry moves some parameter by 1σ or more, the observations are built afresh with
/// every method's laser_*_sigma option at 0 and solved from `summary`'s estimate — its matching
/// and weights are the model's own, which the first order keeps (Gravity Car: 0.31° first order).
void solveWithoutLaserOffsets(MountingCalibrator::Summary* summary, const CalibrationData& data, const MountingCalibrator::Options& options,
                              const std::vector<const Method*>& modules, const std::vector<GroundControlPoint>& free_gcps) {
  for (AdjustmentSummary::ModelSensitivity& ms : summary->model_sensitivity) {
    // The reported blocks are the methods' per-laser offsets (reportCovariance's callers); another
    // reported block would need its own switch, so only those are solved again.
    if (ms.part != AdjustmentSummary::ModelSensitivity::Part::kReported || ms.change.find("per-laser") == std::string::npos) continue;
    if (*std::max_element(ms.shift_in_sigma.begin(), ms.shift_in_sigma.end()) < 1.0) continue;
    MountingCalibrator::Options without = options;
    for (const Method* m : modules) {
      std::any& o = without.method_options.at(m->name(), m->defaultOptions());
      for (const OptionSpec& spec : m->options())
        if (spec.key.rfind("laser_", 0) == 0 && spec.key.find("_sigma") != std::string::npos) spec.set(o, 0.0);
    }
    Runs again = buildRuns(data, without, modules, free_gcps);
    if (again.sources.empty()) continue;
    const std::array<double, 6> start = summary->mounting.toArray();
    const AdjustmentSummary re = adjustment(without, data).solve(data.mounting_used, again.sources, &start);
    if (!re.IsSolutionUsable()) continue;
    ms.solved = true;
    const auto a = summary->mounting.toArray(), b = re.mounting.toArray();
    for (int j = 0; j < 6; ++j) {
      if (!summary->estimated[j]) continue;
      ms.solved_shift[j] = b[j] - a[j];
      const double sigma = std::min(summary->sigma[j], re.sigma[j] > 0 ? re.sigma[j] : summary->sigma[j]);
      ms.solved_shift_in_sigma[j] = sigma > 0 ? std::abs(ms.solved_shift[j]) / sigma : 0.0;
    }
  }
}

}  // namespace

double MountingCalibrator::Summary::ResolveCheck::largestInSigma() const {
  double z = 0;
  for (double v : shift_in_sigma) {
    if (std::isnan(v)) return std::numeric_limits<double>::infinity();  // a σ of zero
    z = std::max(z, v);
  }
  return z;
}

std::string MountingCalibrator::Summary::ResolveCheck::text() const {
  if (!done) return "no re-solve check (switched off, or no observation depends on the mounting)";
  if (!usable) return "a re-solve started from the result did not converge: the result depends on where the solve started";
  const auto& names = mountingParameterNames();
  int worst = 0;
  for (int j = 1; j < 6; ++j)
    if (shift_in_sigma[j] > shift_in_sigma[worst]) worst = j;
  char buf[320];
  const double k = worst < 3 ? 1.0 : 180.0 / kPi;
  std::snprintf(buf, sizeof buf, "a re-solve started from the result moves %s by %+.4g %s (%.1fσ)%s", names[worst].c_str(),
                shift[worst] * k, worst < 3 ? "m" : "deg", shift_in_sigma[worst],
                unsettled() ? ": the matching has not settled — the result depends on where the solve started" : "");
  return buf;
}

MountingCalibrator::Summary MountingCalibrator::calibrate(const CalibrationData& data) const {
  const auto t_start = std::chrono::steady_clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count(); };
  // The trajectory's accuracy along its time, when the data carry it and the σ are not off.
  Options with_series;
  const Options* chosen = &options_;
  if (data.trajectory_accuracy && !data.trajectory_accuracy->empty() && options_.trajectory.any() && !options_.trajectory.series) {
    with_series = options_;
    with_series.trajectory.series = data.trajectory_accuracy;
    chosen = &with_series;
  }
  const Options& options = *chosen;
  Summary summary;
  summary.mounting_used = data.mounting_used;
  summary.mounting = data.mounting_used;
  summary.sigma.fill(std::nan(""));
  std::string why;
  if (!options.IsValid(&why)) {
    summary.termination = TerminationType::kInvalidInput;
    summary.message = "invalid options: " + why;
    return summary;
  }
  data.requirePoses();
  const std::vector<const Method*> modules = modulesToRun(options.methods);
  for (const Method* m : modules)
    if (!m->implicit()) summary.methods.push_back(m->name());

  // ---- each method turns the strips (+ user input) into observation blocks -------------------
  const std::vector<GroundControlPoint> free_gcps = unclaimedGcps(data, modules);
  Runs built = buildRuns(data, options, modules, free_gcps);
  const auto& runs = built.runs;
  const std::vector<ObservationSource*>& sources = built.sources;
  const double construction_s = elapsed();
  auto fillSections = [&] {
    summary.sections.clear();
    for (const auto& [module, run] : runs)
      if (auto s = run->section()) summary.sections.push_back(std::move(s));
  };
  if (sources.empty()) {
    fillSections();
    summary.termination = TerminationType::kInvalidInput;
    const MethodRun* only = nullptr;  // the one named method, if only one was named
    if (options.methods.size() == 1)
      for (const auto& [module, run] : runs)
        if (!module->implicit()) only = run.get();
    summary.message = only ? only->nothingUsable() : "no usable observation: every method's input was rejected (see the rejected lists)";
    summary.time_s = elapsed();
    return summary;
  }

  // ---- one adjustment -------------------------------------------------------------------------
  const std::vector<std::string> names = summary.methods;
  static_cast<AdjustmentSummary&>(summary) = adjustment(options, data).solve(data.mounting_used, sources, built.start);
  summary.methods = names;
  summary.lever_arm_change_warning_m = options_.lever_arm_change_warning_m;
  summary.construction_time_s += construction_s;
  fillSections();
  if (options.resolve_check && summary.IsSolutionUsable() && built.rematches()) {
    summary.resolve = resolveFrom(summary, data, options, modules, free_gcps);
    solveWithoutLaserOffsets(&summary, data, options, modules, free_gcps);
  }
  summary.resolve.reject_sigma = options_.resolve_reject_sigma;
  summary.time_s = elapsed();
  return summary;
}

// ---- reports ----------------------------------------------------------------------------------

namespace {
std::string methodList(const std::vector<std::string>& m) {
  std::string s;
  for (const auto& x : m) s += (s.empty() ? "" : "+") + x;
  return s.empty() ? "none" : s;
}
}  // namespace

std::string MountingCalibrator::Summary::BriefReport() const {
  char buf[640];
  const Vec3 b = mounting.boresightDeg();
  std::string what;
  for (const auto& s : sections)
    if (uses(s->method())) what += s->brief();
  std::snprintf(buf, sizeof buf,
                "mountcal %s: %s, %d iterations, cost %.4g -> %.4g, %slever arm (%.4f, %.4f, %.4f) m, boresight (%.5f, %.5f, %.5f) deg",
                methodList(methods).c_str(), toString(termination), iterations, initial_cost, final_cost, what.c_str(), mounting.a_b.x(),
                mounting.a_b.y(), mounting.a_b.z(), b.x(), b.y(), b.z());
  return buf;
}

std::string MountingCalibrator::Summary::FullReport() const {
  std::ostringstream r;
  char buf[320];
  r << "mountcal — mounting calibration (" << methodList(methods) << ")\n\n";
  r << "Termination: " << toString(termination) << " (" << message << ")\n";
  std::snprintf(buf, sizeof buf, "Iterations %d, cost %.6g -> %.6g, %.3f s (construction %.3f, solve %.3f, analysis %.3f)\n", iterations,
                initial_cost, final_cost, time_s, construction_time_s, solve_time_s, analysis_time_s);
  r << buf;
  if (rematch_rounds > 1)
    r << "Solves between matchings " << rematch_rounds
      << (boresight_first_restart ? " (started again with the boresight first: the lever arm had moved beyond "
                                    "analysis.lever_arm_change_warning_m)\n"
                                  : "\n");
  for (const auto& k : kinds) {
    r << "  " << k.kind << ": " << k.blocks << " residual blocks, " << k.residuals << " residuals";
    if (k.covariance_scale < 1.0) {
      std::snprintf(buf, sizeof buf,
                    "; its σ of a distance, estimated where the calibration started, is %.2f times what its residuals show "
                    "(σ₀² %.3g): the σ below take the residuals' scatter",
                    1.0 / std::sqrt(k.covariance_scale), k.variance_factor);
      r << buf;
    }
    r << "\n";
  }
  std::snprintf(buf, sizeof buf, "Degrees of freedom %d, variance factor %.4g\n\n", degrees_of_freedom, variance_factor);
  r << buf;
  r << "parameter            used            estimated       sigma             formal sigma\n";
  const auto& names = mountingParameterNames();
  const auto used = mounting_used.toArray(), est = mounting.toArray();
  for (int j = 0; j < 6; ++j) {
    const bool lin = j < 3;
    const double k = lin ? 1.0 : 180.0 / kPi;
    const char* unit = lin ? "m  " : "deg";
    std::string sig = estimated[j] ? "" : "fixed";
    if (estimated[j]) {
      std::snprintf(buf, sizeof buf, "%.6f %s      %.6f %s", sigma[j] * k, unit, formal_sigma[j] * k, unit);
      sig = buf;
    } else if (std::find(unobservable.begin(), unobservable.end(), names[j]) != unobservable.end()) {
      sig = "undeterminable";
    }
    std::snprintf(buf, sizeof buf, "%-18s %+12.6f %s %+12.6f %s  %s\n", names[j].c_str(), used[j] * k, unit, est[j] * k, unit, sig.c_str());
    r << buf;
  }
  r << "sigma: " << sigma_model << (sigma_model == "formal" ? "\n" : " (formal: observations taken as independent)\n");
  if (!observability_report.empty()) r << "\nObservability:\n" << observability_report;
  if (!std::isnan(time_offset_s)) {
    std::snprintf(buf, sizeof buf, "Time offset (%s): %+.4g ms, sigma %.4g ms\n",
                  time_offset_in_solve ? "estimated with the mounting" : "first order, not applied", 1e3 * time_offset_s,
                  1e3 * time_offset_sigma_s);
    r << buf;
  }
  if (!strip_corrections.empty()) {
    r << "Trajectory corrections per strip (estimated with the mounting; at the start -> end of each strip):\n";
    for (const auto& c : strip_corrections) {
      std::snprintf(
          buf, sizeof buf,
          "  %-12s %8.1f s  position %+.3f %+.3f %+.3f -> %+.3f %+.3f %+.3f m  attitude %+.4f %+.4f %+.4f -> %+.4f %+.4f %+.4f deg\n",
          c.strip_id.c_str(), c.t_end_s - c.t_start_s, c.position_start_m.x(), c.position_start_m.y(), c.position_start_m.z(),
          c.position_end_m.x(), c.position_end_m.y(), c.position_end_m.z(), rad2deg(c.attitude_start_rad.x()),
          rad2deg(c.attitude_start_rad.y()), rad2deg(c.attitude_start_rad.z()), rad2deg(c.attitude_end_rad.x()),
          rad2deg(c.attitude_end_rad.y()), rad2deg(c.attitude_end_rad.z()));
      r << buf;
      std::snprintf(buf, sizeof buf, "  %-12s %8s  prior sigma at the end  %.3f %.3f %.3f m  attitude %.4f %.4f %.4f deg\n", "", "",
                    c.prior_end_position_m.x(), c.prior_end_position_m.y(), c.prior_end_position_m.z(),
                    rad2deg(c.prior_end_attitude_rad.x()), rad2deg(c.prior_end_attitude_rad.y()), rad2deg(c.prior_end_attitude_rad.z()));
      r << buf;
    }
  }
  for (const auto& ms : model_sensitivity) r << "Model sensitivity: " << ms.text() << "\n";
  if (resolve.done) r << "Re-solve check: " << resolve.text() << "\n";
  std::snprintf(buf, sizeof buf, "\nCondition number of the estimated block (normalised): %.3g\n", condition_number);
  r << buf;
  r << "\nCorrelations:\n";
  for (int a = 0; a < 6; ++a) {
    for (int b = 0; b < 6; ++b) {
      if (std::isnan(correlation(a, b)))
        r << "      -";
      else {
        std::snprintf(buf, sizeof buf, " %+6.3f", correlation(a, b));
        r << buf;
      }
    }
    r << "   " << names[a] << "\n";
  }
  for (const auto& s : sections) r << s->text(*this);
  const Verdict v = verdict();
  r << "\nVerdict: " << v.name();
  for (std::size_t i = 0; i < v.reasons.size(); ++i) r << (i ? "; " : " — ") << v.reasons[i];
  r << "\n";
  return r.str();
}

MountingCalibrator::Verdict MountingCalibrator::Summary::verdict() const {
  Verdict v;
  std::size_t rejecting = 0;  // the reasons that reject come first, in the order found
  auto reject = [&](const std::string& why) {
    v.kind = Verdict::Kind::kReject;
    v.reasons.insert(v.reasons.begin() + static_cast<long>(rejecting++), why);
  };
  auto doubt = [&](const std::string& why) {
    if (v.kind == Verdict::Kind::kAccept) v.kind = Verdict::Kind::kDoubtful;
    v.reasons.push_back(why);
  };
  char buf[200];
  if (!IsSolutionUsable()) reject(std::string("the solve is not usable (") + toString(termination) + ")");
  int asked = static_cast<int>(unobservable.size()), determined = 0;
  for (int j = 0; j < 6; ++j) determined += estimated[j];
  asked += determined;
  if (asked > 0 && determined == 0) reject("nothing asked for could be determined from these observations");
  if (degrees_of_freedom <= 0) {
    doubt("no redundancy (" + std::to_string(degrees_of_freedom) + " degrees of freedom): nothing checks the result");
  } else {
    if (variance_factor > 10.0) {
      std::snprintf(buf, sizeof buf, "σ₀² = %.3g: the residuals are %.1f times the stated σ (outliers, a wrong model or wrong σ)",
                    variance_factor, std::sqrt(variance_factor));
      reject(buf);
    } else if (variance_factor > 2.0) {
      std::snprintf(buf, sizeof buf, "σ₀² = %.3g: the stated σ are smaller than the residuals show, so the σ are optimistic",
                    variance_factor);
      doubt(buf);
    } else if (variance_factor < 0.3) {
      // Not where every kind's σ came from the data at the start and its covariance already takes
      // the residuals' scatter (AdjustmentSummary::KindCount::covariance_scale).
      bool taken = !kinds.empty();
      for (const auto& k : kinds) taken = taken && (k.residuals == 0 || k.covariance_scale < 1.0);
      std::snprintf(buf, sizeof buf, "σ₀² = %.3g: the stated σ are larger than the residuals show", variance_factor);
      if (!taken) doubt(buf);
    }
    if (degrees_of_freedom < 10) doubt("few observations: " + std::to_string(degrees_of_freedom) + " degrees of freedom");
  }
  for (const std::string& held : unobservable) doubt(held + " was asked for but held at its used value (not determined by the data)");
  for (const auto& ms : model_sensitivity)
    if (ms.model_dependent()) doubt(ms.text());
  const auto& names = mountingParameterNames();
  for (int j = 0; j < 3; ++j) {
    const double moved = std::abs(mounting.a_b[j] - mounting_used.a_b[j]);
    if (!estimated[j] || !(moved > lever_arm_change_warning_m)) continue;
    std::snprintf(buf, sizeof buf,
                  "%s moved %.2f m from its used value: mountings are not mis-measured by that much — it may absorb a model error "
                  "(time offset, laser offsets); tape it and give its σ",
                  names[j].c_str(), moved);
    doubt(buf);
  }
  if (resolve.rejects()) {
    std::snprintf(buf, sizeof buf, " (beyond %.3gσ: its σ claim a precision that the data do not give)", resolve.reject_sigma);
    reject(resolve.text() + buf);
  } else if (resolve.unsettled()) {
    doubt(resolve.text());
  }
  for (const auto& s : sections)
    for (const std::string& d : s->doubts()) doubt(d);
  int outliers = 0, observations = 0;
  for (const auto& s : sections) outliers += s->outliers();
  for (const auto& k : kinds) observations += k.residuals;
  if (observations > 0 && outliers > 0.05 * observations)
    doubt(std::to_string(outliers) + " of " + std::to_string(observations) + " observations are flagged as outliers");
  return v;
}

MountingCalibrator::Summary calibrate(const CalibrationData& data, const MountingCalibrator::Options& options) {
  return MountingCalibrator(options).calibrate(data);
}

}  // namespace mountcal
