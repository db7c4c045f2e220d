#include "mountcal/methods/common/tie_observations.hpp"

#include <ceres/ceres.h>

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>

#include "core/parallel.hpp"
#include "methods/common/vtp_cost.hpp"
#include "mountcal/core/error.hpp"

namespace mountcal {

bool TieObservationOptions::IsValid(std::string* error) const {
  if (!(tie_sigma_xy_m > 0) || !(tie_sigma_z_m > 0) || !std::isfinite(tie_sigma_xy_m) || !std::isfinite(tie_sigma_z_m)) {
    if (error) *error = "tie_sigma_xy_m and tie_sigma_z_m must be positive and finite";
    return false;
  }
  return true;
}

namespace {

/// Control: a strip surface farther than this from the control point is another surface [m].
constexpr double kControlGate_m = 1.0;

/// A GCP prior on a tie position: (X_k − X_gcp) / σ, analytic Jacobian.
class GcpPrior final : public ceres::SizedCostFunction<3, 3> {
 public:
  GcpPrior(const Vec3& x, const Vec3& inv_sigma) : x_(x), w_(inv_sigma) {}
  bool Evaluate(double const* const* p, double* r, double** J) const override {
    for (int a = 0; a < 3; ++a) r[a] = (p[0][a] - x_[a]) * w_[a];
    if (J && J[0]) {
      std::fill(J[0], J[0] + 9, 0.0);
      for (int a = 0; a < 3; ++a) J[0][4 * a] = w_[a];
    }
    return true;
  }

 private:
  Vec3 x_, w_;
};

/// Ground control with a non-VTPM method: the GCP lies on the strip's surface. The surface is
/// the virtual tie point's triangle moved by Rule 2, so r = n · (P_ki(M) + o_i − X_gcp) / σ
/// with n the triangle's normal — a point-to-plane distance that holds wherever the strip is
/// locally planar, whatever its horizontal misalignment (a plan pick on a misaligned strip
/// lands on another ground point, so only the distance across the surface is an observation).
struct ControlResidual {
  const VirtualTiePoint* vtp;
  Vec3 normal;
  Vec3 gcp_rel;  // X_gcp − triangle centroid [m]
  double inv_sigma;
  bool operator()(const double* mounting, const double* offset, double* r) const {
    const Vec3 P_rel = vtp->relativePosition(mounting);
    r[0] = normal.dot(P_rel + Vec3(offset[0], offset[1], offset[2]) - gcp_rel) * inv_sigma;
    return true;
  }
};
/// The same with the strip's attitude error δψ at the pick's time (a random effect): + δψ × u.
struct ControlAttitudeResidual {
  ControlResidual base;
  Vec3 u;
  bool operator()(const double* mounting, const double* offset, const double* dpsi, double* r) const {
    const Vec3 P_rel = base.vtp->relativePosition(mounting);
    const Vec3 rot = Vec3(dpsi[0], dpsi[1], dpsi[2]).cross(u);
    r[0] = base.normal.dot(P_rel + Vec3(offset[0], offset[1], offset[2]) + rot - base.gcp_rel) * base.inv_sigma;
    return true;
  }
};

/// Barycentric weights of the pick in the plan triangle of a virtual tie point (Rule 1).
Vec3 pickWeights(const VirtualTiePoint& v) {
  const auto& V = v.vertices();
  const Vec3& P0 = v.referencePosition();
  Eigen::Matrix2d E;
  E.col(0) = (V[1].x0_m - V[0].x0_m).head<2>();
  E.col(1) = (V[2].x0_m - V[0].x0_m).head<2>();
  Vec3 w = Vec3::Constant(1.0 / 3.0);
  if (std::abs(E.determinant()) > 1e-12 * (E.squaredNorm() + 1e-30)) {
    const Eigen::Vector2d w12 = E.partialPivLu().solve((P0 - V[0].x0_m).head<2>());
    w = Vec3(1.0 - w12.x() - w12.y(), w12.x(), w12.y());
  }
  return w;
}

/// Calls fn(footprint, weight) for each pulse a virtual tie point is an affine combination of:
/// its motion support's with their weights (VtpMotion::kNeighbourhood), else its triangle's with
/// the pick's barycentric weights (Rule 1).
template <class Fn>
void forEachWeightedPulse(const VirtualTiePoint& v, Fn&& fn) {
  if (!v.motionSupport().empty()) {
    for (std::size_t i = 0; i < v.motionSupport().size(); ++i) fn(v.motionSupport()[i], v.motionWeights()[i]);
    return;
  }
  const Vec3 w = pickWeights(v);
  for (int i = 0; i < 3; ++i) fn(v.vertices()[static_cast<std::size_t>(i)], w[i]);
}

/// IMU → tie point vector u = x − p [m] (the beam differs from it by the lever arm only).
Vec3 imuToPoint(const VirtualTiePoint& v) {
  Vec3 p = Vec3::Zero();
  forEachWeightedPulse(v, [&](const LaserFootprint& f, double w) { p += w * f.pose.p_m; });
  return v.referencePosition() - p;
}

Vec3 triangleNormal(const VirtualTiePoint& v) {
  const auto& V = v.vertices();
  Vec3 n = (V[1].x0_m - V[0].x0_m).cross(V[2].x0_m - V[0].x0_m).normalized();
  return n.z() < 0 ? Vec3(-n) : n;
}

/// The normal of the surface a VTP's pick lies on: the local plane VtpStrip fitted, else its
/// triangle's.
Vec3 pickSurfaceNormal(const VirtualTiePoint& v) { return v.surfaceNormal().squaredNorm() > 0 ? v.surfaceNormal() : triangleNormal(v); }

/// The normal of the plane a VTP's height comes from: its neighbourhood's (a motion support's
/// affine combination lies in the local plane), else its triangle's (Rule 1).
Vec3 heightNormal(const VirtualTiePoint& v) { return v.motionSupport().empty() ? triangleNormal(v) : pickSurfaceNormal(v); }

/// The steepest surface gradient a tie's covariance takes, tan 72°: a pick on a wall does not
/// define a height [-].
constexpr double kMaxTieGradient = 3.0;

/// The stochastic model's pulse noise at a virtual tie point [m²]. Attitude and position are
/// common to its three pulses (emitted within a few milliseconds): they move the strip's whole
/// surface there, and the feature the user picks with it, so the tie point moves by the full 3-D
/// error. Range and pointing are independent per pulse: they do not move the pick, which stays at
/// its plan position (Rule 1), only the triangle's height there — each pulse's error across the
/// surface, n·δ_i, raises the plane at the pick by n·δ_i / n_z with the barycentric weight w_i, so
/// their share is vertical, Σ w_i² nᵀ P_i n / n_z² — on a multi-beam strip the neighbourhood's
/// weights (forEachWeightedPulse), Σ w_i² about the inverse of its size. `n`: heightNormal().
Mat3 vtpPulseCovariance(const VirtualTiePoint& v, const Vec3& n, const PulseNoise& noise) {
  const Vec3 u = imuToPoint(v);
  const Mat3 common = noise.pointCovariance(u, u, 0.0);
  const Mat3 independent = noise.pointCovariance(u, u, 1.0) - common;
  const double nz = std::max(n.z(), 1.0 / std::hypot(1.0, kMaxTieGradient));
  Mat3 S = common;
  double w2 = 0;
  forEachWeightedPulse(v, [&](const LaserFootprint&, double w) { w2 += w * w; });
  S(2, 2) += w2 * n.dot(independent * n) / (nz * nz);
  return S;
}

/// The cofactor of a plan pick's error in 3-D: a pick δ = (δx, δy) off in plan lands on the strip's
/// surface there, so the virtual tie point moves by J δ with J = [1 0; 0 1; g_x g_y] and g the
/// surface's gradient (−n_x/n_z, −n_y/n_z): on a roof of slope θ the height follows the pick by
/// tan θ along the fall line. Σ_pick = σ_xy² J Jᵀ (diag(σ², σ², 0) on level ground). `n`: the
/// surface's normal (pickSurfaceNormal), not the triangle's — a pick error of a few point spacings
/// leaves the triangle, whose own tilt is its pulses' noise there: on a UAV flight (points 0.1 m
/// apart, 2 cm range noise) that tilt coupled the heights to the picks' plan errors in the
/// stochastic model, and the VTPM σ of roll came out 1.3× small and the errors larger
/// (Planner.MultiBeamUavPredictionMatchesTheScatter, 2026-12-05).
Mat3 pickCofactor(const Vec3& n) {
  Eigen::Vector2d g = -n.head<2>() / std::max(n.z(), 1e-9);
  if (g.norm() > kMaxTieGradient) g *= kMaxTieGradient / g.norm();
  Eigen::Matrix<double, 3, 2> J;
  J << 1, 0, 0, 1, g.x(), g.y();
  return J * J.transpose();
}

/// Emission time of a virtual tie point: its pulses' weighted mean [s].
double vtpTime(const VirtualTiePoint& v, const CalibrationData& data) {
  for (const StripData& s : data.strips) {
    if (s.id != v.stripId()) continue;
    double t = 0;
    forEachWeightedPulse(v, [&](const LaserFootprint& f, double w) { t += w * s.time_s.at(f.index); });
    return t;
  }
  return 0.0;
}

}  // namespace

TieObservations::~TieObservations() = default;

TieObservations::TieObservations(const CalibrationData& data, const std::vector<TieObservation>& picks,
                                 const std::vector<GroundControlPoint>& gcps, const TieObservationOptions& options, const VtpOptions& vtp,
                                 std::string kind, int threads)
    : kind_(std::move(kind)), options_(options), gcps_(gcps), data_(&data), picks_(picks), vtp_(vtp) {
  threads_ = threads;
  data.requirePoses();
  built_at_ = data.mounting_used.toArray();
  build(data.mounting_used);
}

namespace {

/// Each strip's index by id (ids must be unique), and in `needed` the ids the picks name (each
/// must be a strip of the job).
std::map<std::string, std::size_t> stripsOfPicks(const CalibrationData& data, const std::vector<TieObservation>& picks,
                                                 std::vector<std::string>* needed_out) {
  std::map<std::string, std::size_t> strip_index;
  for (std::size_t i = 0; i < data.strips.size(); ++i) {
    if (!strip_index.emplace(data.strips[i].id, i).second)
      throw InvalidInput("calibrate: strip id '" + data.strips[i].id + "' appears twice");
  }
  std::set<std::string> needed;
  for (const TieObservation& t : picks) {
    if (!strip_index.count(t.strip_id)) {
      throw InvalidInput("tie '" + t.tie_id + "'" + (t.line ? " (line " + std::to_string(t.line) + ")" : std::string()) + " names strip '" +
                         t.strip_id + "', which is not in the job");
    }
    needed.insert(t.strip_id);
  }
  needed_out->assign(needed.begin(), needed.end());
  return strip_index;
}

/// Control points need only the strip points around them: a subset of each strip, within the
/// largest VTP radius and a margin for the mounting's motion of each control point.
StripData nearPicks(const StripData& strip, const std::vector<TieObservation>& picks, const VtpOptions& vtp) {
  const double reach = std::max(vtp.max_radius_m, vtp.radius_m) + 10.0, cell = 2 * reach;
  std::set<std::pair<long, long>> cells;
  for (const TieObservation& t : picks) cells.insert({std::lround(std::floor(t.x_m / cell)), std::lround(std::floor(t.y_m / cell))});
  const std::vector<Vec3>& x = strip.x_m;
  if (!strip.laser.empty() && strip.laser.size() != x.size())
    throw InvalidInput("strip '" + strip.id + "': laser ids and points differ in number");
  StripData sub;
  sub.id = strip.id;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const long cx = std::lround(std::floor(x[i].x() / cell)), cy = std::lround(std::floor(x[i].y() / cell));
    bool near = false;
    for (long dx = -1; dx <= 1 && !near; ++dx)
      for (long dy = -1; dy <= 1 && !near; ++dy) near = cells.count({cx + dx, cy + dy}) > 0;
    if (!near) continue;
    sub.time_s.push_back(strip.time_s[i]);
    sub.r_s.push_back(strip.r_s[i]);
    if (!strip.poses.empty()) sub.poses.push_back(strip.poses[i]);
    if (!strip.laser.empty()) sub.laser.push_back(strip.laser[i]);
  }
  return sub;
}

/// Each needed strip's points and k-d tree at the reference mounting, on all threads (slots
/// filled in parallel, read in order: the result does not depend on the threads).
std::vector<std::unique_ptr<VtpStrip>> vtpStrips(const CalibrationData& data, const std::vector<TieObservation>& picks,
                                                 const VtpOptions& vtp, const std::vector<std::string>& ids,
                                                 const std::map<std::string, std::size_t>& strip_index, const MountingParameters& reference,
                                                 bool control, int threads) {
  std::vector<std::unique_ptr<VtpStrip>> built(ids.size());
  detail::parallelFor(ids.size(), threads, [&](std::size_t k) {
    const StripData& strip = data.strips[strip_index.at(ids[k])];
    if (control && !strip.x_m.empty() && strip.x_m.size() == strip.time_s.size()) {
      StripData sub = nearPicks(strip, picks, vtp);  // georeferenced at the reference mounting by VtpStrip
      if (sub.time_s.size() >= 3)
        built[k] = std::make_unique<VtpStrip>(std::move(sub), data.trajectory, reference);
      else
        built[k] = std::make_unique<VtpStrip>(strip, data.trajectory, data.mounting_used);
    } else if (reference.toArray() == data.mounting_used.toArray()) {
      built[k] = std::make_unique<VtpStrip>(strip, data.trajectory, data.mounting_used);
    } else {
      StripData at = strip;
      at.x_m.clear();  // georeferenced again at the reference mounting
      built[k] = std::make_unique<VtpStrip>(std::move(at), data.trajectory, reference);
    }
  });
  return built;
}

}  // namespace

void TieObservations::build(const MountingParameters& reference) {
  const CalibrationData& data = *data_;
  const std::vector<TieObservation>& picks = picks_;
  const VtpOptions& vtp = vtp_;
  const bool control = kind_ == "control";
  vtps_.clear();
  ties_.clear();
  section_ = TieSection{};
  // ---- virtual tie points (SPEC §3 steps 1–3) -------------------------------------------
  // Each strip's points and k-d tree, then each pick's virtual tie point, on all threads (slots
  // filled in parallel, read in order: the result does not depend on the threads).
  std::vector<std::string> ids;
  const std::map<std::string, std::size_t> strip_index = stripsOfPicks(data, picks, &ids);
  const std::vector<std::unique_ptr<VtpStrip>> built = vtpStrips(data, picks, vtp, ids, strip_index, reference, control, threads_);
  std::map<std::string, const VtpStrip*> vtp_strips;
  for (std::size_t k = 0; k < ids.size(); ++k) vtp_strips.emplace(ids[k], built[k].get());
  struct Built {
    bool ok = false;
    VirtualTiePoint v;
    std::string reason;
  };
  std::vector<Built> results(picks.size());
  detail::parallelFor(picks.size(), threads_, [&](std::size_t k) {
    Built& r = results[k];
    r.ok = vtp_strips.at(picks[k].strip_id)->build(picks[k], vtp, &r.v, &r.reason);
  });
  vtps_.reserve(picks.size());
  std::map<std::string, std::vector<int>> by_tie;
  for (std::size_t k = 0; k < picks.size(); ++k) {
    const TieObservation& t = picks[k];
    if (results[k].ok) {
      by_tie[t.tie_id].push_back(static_cast<int>(vtps_.size()));
      vtps_.push_back(std::move(results[k].v));
    } else if (!(control && results[k].reason.rfind("too few points", 0) == 0)) {  // control: a strip not covering it
      section_.rejected.push_back({t.tie_id, t.strip_id, results[k].reason});
    }
  }
  std::map<std::string, const GroundControlPoint*> gcp_by_id;
  for (const GroundControlPoint& g : gcps_) gcp_by_id[g.id] = &g;
  for (auto& [id, obs] : by_tie) {
    Tie tie;
    tie.id = id;
    tie.obs = obs;
    auto g = gcp_by_id.find(id);
    if (g != gcp_by_id.end()) tie.gcp = g->second;
    if (control && tie.gcp) {
      // A plan pick on a misaligned strip may land on another surface (off a roof): such a
      // strip surface lies metres from the control point.
      const Vec3 x(tie.gcp->x_m, tie.gcp->y_m, tie.gcp->z_m);
      std::vector<int> near;
      for (int k : tie.obs) {
        const VirtualTiePoint& v = vtps_[static_cast<std::size_t>(k)];
        const double d = std::abs(heightNormal(v).dot(v.referencePosition() - x));
        if (d <= kControlGate_m) {
          near.push_back(k);
        } else {
          char buf[160];
          std::snprintf(buf, sizeof buf, "another surface: the strip's surface is %.2f m from the control point (more than %.1f m)", d,
                        kControlGate_m);
          section_.rejected.push_back({id, v.stripId(), buf});
        }
      }
      tie.obs = near;
      if (tie.obs.empty()) continue;
    }
    if (obs.size() < 2 && !tie.gcp) {
      for (int k : obs)
        section_.rejected.push_back(
            {id, vtps_[static_cast<std::size_t>(k)].stripId(), "the tie has a usable observation on only one strip"});
      continue;
    }
    // seed eq. (7): the tie's mean at M_used, its initial position.
    for (int k : tie.obs) tie.mean_m += vtps_[static_cast<std::size_t>(k)].position(reference);
    tie.mean_m /= static_cast<double>(tie.obs.size());
    ties_.push_back(tie);
  }
  int n_obs = 0;
  for (const Tie& t : ties_) {
    n_obs += static_cast<int>(t.obs.size());
    for (int k : t.obs) section_.neighbourhood_motion += !vtps_[static_cast<std::size_t>(k)].motionSupport().empty();
  }
  section_.ties_used = static_cast<int>(ties_.size());
  section_.observations_used = n_obs;
}

std::unique_ptr<TieObservations> TieObservations::control(const CalibrationData& data, const std::vector<GroundControlPoint>& gcps,
                                                          const TieObservationOptions& options, const VtpOptions& vtp, int threads) {
  std::vector<TieObservation> picks;
  for (const GroundControlPoint& g : gcps)
    for (const StripData& s : data.strips) picks.push_back({g.id, s.id, g.x_m, g.y_m, 0});
  return std::make_unique<TieObservations>(data, picks, gcps, options, vtp, "control", threads);
}

void TieObservations::addBlocks(const std::array<double, 6>& mounting, AdjustmentProblem* problem) {
  // SPEC §3 step 4. Tie blocks do not depend on the mounting they are built at (Rule 2 is a
  // pure function of M), so ties start at their means at M_used every time. Control points
  // are picked again at each new mounting: a plan pick on a strip that is still misaligned
  // lands beside the control point, on a surface that may not be the control point's.
  if (kind_ == "control" && mounting != built_at_) {
    built_at_ = mounting;
    build(data_->mounting_used.withArray(mounting.data()));
  }
  if (!(sigma_xy_m_ > 0)) {
    sigma_xy_m_ = options_.tie_sigma_xy_m;
    sigma_z_m_ = options_.tie_sigma_z_m;
  }
  blocks_.clear();
  whitening_.clear();
  redundancy_.clear();
  pick_cofactor_.clear();
  if (kind_ == "control") {
    for (Tie& tie : ties_) {
      const Vec3 x(tie.gcp->x_m, tie.gcp->y_m, tie.gcp->z_m);
      for (int k : tie.obs) {
        const VirtualTiePoint& v = vtps_[static_cast<std::size_t>(k)];
        const Vec3 n = heightNormal(v);
        // σ across the surface: the GCP's (its normal component) and the strip's (Rule 1).
        const double s_gcp2 = std::pow(tie.gcp->sigma_xy_m, 2) * n.head<2>().squaredNorm() + std::pow(tie.gcp->sigma_z_m * n.z(), 2);
        const double s_pulse2 = problem->pulseNoise().any() ? n.dot(vtpPulseCovariance(v, n, problem->pulseNoise()) * n) : 0.0;
        const double sigma = std::sqrt(s_gcp2 + options_.tie_sigma_z_m * options_.tie_sigma_z_m + s_pulse2);
        ceres::NumericDiffOptions nd;
        nd.relative_step_size = problem->numericDiffRelativeStep();
        const ControlResidual residual{&v, n, x - v.centroid(), 1.0 / sigma};
        if (double* dpsi = problem->attitudeError(v.stripId(), vtpTime(v, *data_))) {
          auto* cost = new ceres::NumericDiffCostFunction<ControlAttitudeResidual, ceres::CENTRAL, 1, 6, 3, 3>(
              new ControlAttitudeResidual{residual, imuToPoint(v)}, ceres::TAKE_OWNERSHIP, 1, nd);
          blocks_.push_back(problem->addResidualBlock(cost, sigma, {problem->mounting(), problem->stripOffset(v.stripId()), dpsi}));
        } else {
          auto* cost = new ceres::NumericDiffCostFunction<ControlResidual, ceres::CENTRAL, 1, 6, 3>(new ControlResidual(residual),
                                                                                                    ceres::TAKE_OWNERSHIP, 1, nd);
          blocks_.push_back(problem->addResidualBlock(cost, sigma, {problem->mounting(), problem->stripOffset(v.stripId())}));
        }
        problem->setEpoch(blocks_.back(), v.stripId(), vtpTime(v, *data_), imuToPoint(v));
      }
    }
    return;
  }
  for (Tie& tie : ties_) {
    tie.X = problem->addNuisanceBlock(3, tie.mean_m.data());
    for (int k : tie.obs) {
      const VirtualTiePoint& v = vtps_[static_cast<std::size_t>(k)];
      // seed eq. (10), whitened by the pick's σ along the surface (pickCofactor), the height's
      // σ from the triangle and, when the stochastic model has it, the pulse noise at this tie point.
      const Vec3 n = heightNormal(v);
      const Mat3 Q_pick = pickCofactor(pickSurfaceNormal(v));
      Mat3 Sigma = sigma_xy_m_ * sigma_xy_m_ * Q_pick;
      Sigma(2, 2) += sigma_z_m_ * sigma_z_m_;
      if (problem->pulseNoise().any()) Sigma += vtpPulseCovariance(v, n, problem->pulseNoise());
      const Mat3 W = Sigma.llt().matrixL().solve(Mat3::Identity());
      whitening_.push_back(W);
      pick_cofactor_.push_back(Q_pick);
      const double k_obs = static_cast<double>(tie.obs.size());
      redundancy_.push_back(tie.gcp ? k_obs / (k_obs + 1.0) : (k_obs - 1.0) / k_obs);
      if (double* dpsi = problem->attitudeError(v.stripId(), vtpTime(v, *data_))) {
        ceres::CostFunction* cost = detail::makeVtpAttitudeCostFunction(&v, W, imuToPoint(v), problem->numericDiffRelativeStep());
        blocks_.push_back(problem->addResidualBlock(cost, options_.tie_sigma_xy_m,
                                                    {problem->mounting(), tie.X, problem->stripOffset(v.stripId()), dpsi}));
      } else {
        ceres::CostFunction* cost = detail::makeVtpCostFunction(&v, W, problem->numericDiffRelativeStep());
        blocks_.push_back(
            problem->addResidualBlock(cost, options_.tie_sigma_xy_m, {problem->mounting(), tie.X, problem->stripOffset(v.stripId())}));
      }
      problem->setEpoch(blocks_.back(), v.stripId(), vtpTime(v, *data_), imuToPoint(v), estimatesSigma());
    }
    if (tie.gcp) {
      const Vec3 x(tie.gcp->x_m, tie.gcp->y_m, tie.gcp->z_m);
      problem->addResidualBlock(new GcpPrior(x, Vec3(1 / tie.gcp->sigma_xy_m, 1 / tie.gcp->sigma_xy_m, 1 / tie.gcp->sigma_z_m)), 0.0,
                                {tie.X});
    }
  }
}

void TieObservations::solved(const AdjustmentProblem& problem) {
  if (!estimatesSigma() || blocks_.empty()) return;
  // Variance components (Förstner 1979; Koch 1999, §3.6): for component c with cofactor Q_c
  // (Σ = Σ_c Q_c + Σ_pulse), q_c = Σ (Wᵀr)ᵀ Q_c (Wᵀr) with r = W e the whitened residual, and with
  // r_i the observation's redundancy share, ρ_c = Σ r_i tr(Σ⁻¹Q_c), τ_c = Σ r_i tr(Σ⁻¹Q_c Σ⁻¹Q_c).
  // If the component's true variance is λ times the current one, E[q_c] = ρ_c + (λ − 1) τ_c, so
  // λ̂ = 1 + (q_c/ρ_c − 1) / s_c with s_c = τ_c/ρ_c, the component's share of the variance where it
  // acts. (The plain ratio q_c/ρ_c takes s_c = 1: a component that other noise dominates — the
  // tie height beside the pulse noise — then shrinks by a few per cent a solve and never settles.)
  const Mat3 Q_z = Vec3(0, 0, sigma_z_m_ * sigma_z_m_).asDiagonal();
  double q_xy = 0, q_z = 0, r_xy = 0, r_z = 0, t_xy = 0, t_z = 0;
  for (std::size_t i = 0; i < blocks_.size(); ++i) {
    const Mat3& W = whitening_[i];
    const Mat3 Q_xy = sigma_xy_m_ * sigma_xy_m_ * pick_cofactor_[i];
    const Vec3 g = W.transpose() * Vec3(problem.residual(blocks_[i]));  // Σ⁻¹ e
    const Mat3 Sinv = W.transpose() * W;
    const Mat3 A_xy = Sinv * Q_xy, A_z = Sinv * Q_z;
    q_xy += g.dot(Q_xy * g);
    q_z += g.dot(Q_z * g);
    r_xy += redundancy_[i] * A_xy.trace();
    r_z += redundancy_[i] * A_z.trace();
    t_xy += redundancy_[i] * (A_xy * A_xy).trace();
    t_z += redundancy_[i] * (A_z * A_z).trace();
  }
  if (!(r_xy > 0) || !(r_z > 0) || !(t_xy > 0) || !(t_z > 0)) return;
  // Bounded steps (×/÷ 100 in variance at most per solve) keep a degenerate round harmless.
  auto step = [](double q, double r, double t) { return std::clamp(1.0 + (q / r - 1.0) * r / t, 1e-2, 1e2); };
  const double new_xy = sigma_xy_m_ * std::sqrt(step(q_xy, r_xy, t_xy));
  const double new_z = sigma_z_m_ * std::sqrt(step(q_z, r_z, t_z));
  // A component below 0.1 % of the variance where it acts no longer changes the weights.
  auto settled = [](double now, double before, double share) { return std::abs(now / before - 1.0) < 0.01 || share < 1e-3; };
  sigma_settled_ = settled(new_xy, sigma_xy_m_, t_xy / r_xy) && settled(new_z, sigma_z_m_, t_z / r_z);
  if (!sigma_settled_) {
    sigma_xy_m_ = new_xy;
    sigma_z_m_ = new_z;
  }
}

void TieObservations::finish(const std::array<double, 6>& m0, const std::array<double, 6>& m, const AdjustmentProblem& problem,
                             const AnalysisOptions& analysis) {
  section_.residuals.clear();
  section_.sigma_xy_m = sigma_xy_m_ > 0 ? sigma_xy_m_ : options_.tie_sigma_xy_m;
  section_.sigma_z_m = sigma_z_m_ > 0 ? sigma_z_m_ : options_.tie_sigma_z_m;
  section_.sigma_estimated = estimatesSigma();
  Vec3 ss_before = Vec3::Zero(), ss_after = Vec3::Zero();
  std::vector<double> norms;
  if (kind_ == "control") {
    // The distances across the surface, as vectors along the normal of the VTP's height.
    for (const Tie& tie : ties_) {
      const Vec3 x(tie.gcp->x_m, tie.gcp->y_m, tie.gcp->z_m);
      for (int k : tie.obs) {
        const VirtualTiePoint& v = vtps_[static_cast<std::size_t>(k)];
        const Vec3 n = heightNormal(v);
        TieResidual r;
        r.tie_id = tie.id;
        r.strip_id = v.stripId();
        r.before_m = n * n.dot(v.position(m0.data()) - x);
        r.after_m = n * n.dot(v.position(m.data()) + problem.stripOffsetValue(v.stripId()) - x);
        ss_before += r.before_m.cwiseAbs2();
        ss_after += r.after_m.cwiseAbs2();
        norms.push_back(r.after_m.norm());
        section_.residuals.push_back(r);
      }
    }
  }
  for (const Tie& tie : ties_) {
    if (kind_ == "control") break;
    for (int k : tie.obs) {
      const VirtualTiePoint& v = vtps_[static_cast<std::size_t>(k)];
      TieResidual r;
      r.tie_id = tie.id;
      r.strip_id = v.stripId();
      r.before_m = v.position(m0.data()) - tie.mean_m;  // seed eq. (8)
      r.after_m = v.position(m.data()) + problem.stripOffsetValue(v.stripId()) - Eigen::Map<const Vec3>(tie.X);
      ss_before += r.before_m.cwiseAbs2();
      ss_after += r.after_m.cwiseAbs2();
      norms.push_back(r.after_m.norm());
      section_.residuals.push_back(r);
    }
  }
  const int n = section_.observations_used;
  if (n == 0) return;
  section_.rms_before_m = (ss_before / n).cwiseSqrt();
  section_.rms_after_m = (ss_after / n).cwiseSqrt();
  const double robust_sigma = robustScaleFromNorms(norms, kind_ == "control" ? 1 : 3);  // per axis, from the median norm
  const double threshold =
      std::max(analysis.outlier_factor * robust_sigma, 3.0 * std::min(options_.tie_sigma_xy_m, options_.tie_sigma_z_m));
  for (std::size_t i = 0; i < section_.residuals.size(); ++i) section_.residuals[i].outlier = norms[i] > threshold;
}

}  // namespace mountcal
