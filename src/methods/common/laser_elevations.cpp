// Per-laser elevation offsets as one nuisance block (laser_elevations.hpp).
#include "methods/common/laser_elevations.hpp"

#include <nlohmann/json.hpp>

#include "methods/common/laser_prior.hpp"
#include "methods/common/section_format.hpp"
#include "mountcal/core/rotation.hpp"

namespace mountcal::detail {

void LaserElevationBlock::setUp(const CalibrationData& data, const std::string& method) {
  int lasers = 0;
  for (const StripData& s : data.strips) {
    if (s.laser.size() != s.r_s.size())
      throw InvalidInput(method + ": per-laser elevation offsets need each point's laser id (job key sensor.laser_field); strip '" + s.id +
                         "' has none");
    for (std::uint16_t id : s.laser) lasers = std::max(lasers, static_cast<int>(id) + 1);
  }
  values_.assign(static_cast<std::size_t>(lasers), 0.0);
  block_ = nullptr;
}

double* LaserElevationBlock::add(AdjustmentProblem* problem, const std::vector<bool>& seen, double sigma_deg) {
  block_ = nullptr;
  const int L = lasers();
  if (L == 0) return nullptr;
  block_ = problem->addNuisanceBlock(L, values_.data(), nullptr, false);
  prior_deg_ = sigma_deg;
  problem->reportCovariance(block_, "the per-laser elevation offsets");  // σ with the trajectory errors in time, as the mounting's
  std::vector<int> mean;
  for (int i = 0; i < L; ++i) {
    addLaserPrior(problem, block_, L, {i}, deg2rad(sigma_deg));
    if (seen[static_cast<std::size_t>(i)]) mean.push_back(i);
  }
  if (!mean.empty()) addLaserPrior(problem, block_, L, mean, 1e-6);
  return block_;
}

LaserElevationOffsets LaserElevationBlock::finish(const AdjustmentProblem& adjustment, const std::vector<int>& points) const {
  LaserElevationOffsets out;
  if (!block_) return out;
  out.prior_deg = prior_deg_;
  const int L = lasers();
  const std::size_t n = static_cast<std::size_t>(L);
  out.lasers.assign(n, LaserCorrection{});
  out.sigma_deg.assign(n, std::nan(""));
  out.points = points;
  out.points.resize(n, 0);
  for (std::size_t i = 0; i < n; ++i) out.lasers[i].elevation_rad = block_[i];
  // In the mounting's stochastic model (AdjustmentProblem::reportCovariance).
  const Eigen::MatrixXd& joint = adjustment.reportedCovariance(block_);
  if (joint.rows() != 6 + L) return out;
  const Eigen::MatrixXd C = joint.bottomRightCorner(L, L);
  for (std::size_t i = 0; i < n; ++i)
    if (out.points[i] > 0) out.sigma_deg[i] = rad2deg(std::sqrt(std::max(C(static_cast<long>(i), static_cast<long>(i)), 0.0)));
  return out;
}

std::string laserElevationTable(const LaserElevationOffsets& e, const std::string& title, const std::string& points_label) {
  std::string r = title + "\n  laser  offset [deg]  sigma [deg]  " + points_label + "\n";
  for (std::size_t i = 0; i < e.lasers.size(); ++i)
    r += printfString("  %5zu  %+12.4f  %11.4f  %*d\n", i, rad2deg(e.lasers[i].elevation_rad), e.sigma_deg[i],
                      static_cast<int>(points_label.size()), e.points[i]);
  return r;
}

std::string laserElevationHtml(const LaserElevationOffsets& e, const std::string& title, const std::string& points_label) {
  std::string h = "<h3>" + htmlEscape(title) + "</h3><table><tr><th>laser</th><th>offset [°]</th><th>σ [°]</th><th>" +
                  htmlEscape(points_label) + "</th></tr>";
  for (std::size_t i = 0; i < e.lasers.size(); ++i)
    h += "<tr><td>" + std::to_string(i) + "</td><td>" + cell(rad2deg(e.lasers[i].elevation_rad), "%+.4f") + "</td><td>" +
         cell(e.sigma_deg[i], "%.4f") + "</td><td>" + std::to_string(e.points[i]) + "</td></tr>";
  return h + "</table>";
}

std::string laserElevationIntrinsics(const LaserElevationOffsets& e) {
  nlohmann::json off = nlohmann::json::array(), sig = nlohmann::json::array(), pts = nlohmann::json::array();
  for (std::size_t i = 0; i < e.lasers.size(); ++i) {
    off.push_back(rad2deg(e.lasers[i].elevation_rad));
    sig.push_back(numOrNull(e.sigma_deg[i]));
    pts.push_back(e.points[i]);
  }
  return nlohmann::json{{"laser_elevation_offset_deg", off}, {"laser_elevation_sigma_deg", sig}, {"laser_points", pts}}.dump();
}

std::vector<std::string> laserElevationDoubts(const LaserElevationOffsets& e) {
  return laserPriorDoubts(e.lasers, e.points, LaserCorrection{deg2rad(e.prior_deg), 0, 0, 0, 0});
}

std::vector<std::string> laserPriorDoubts(const LaserCorrections& lasers, const std::vector<int>& points,
                                          const LaserCorrection& prior_sigma) {
  std::string far;
  int count = 0;
  for (std::size_t i = 0; i < lasers.size(); ++i) {
    if (i < points.size() && points[i] == 0) continue;
    for (const LaserGroup& g : kLaserGroups) {
      const double prior = prior_sigma.*g.field, value = lasers[i].*g.field;
      if (!(prior > 0) || !(std::abs(value) > kLaserPriorDoubt * prior)) continue;
      if (count++ < 4)
        far += printfString("%slaser %zu %s %+.3g %s (%.1f prior σ)", far.empty() ? "" : ", ", i, g.name, value * g.to_unit, g.unit,
                            std::abs(value) / prior);
    }
  }
  if (count == 0) return {};
  if (count > 4) far += printfString(" and %d more", count - 4);
  return {printfString(
      "%d per-laser offset%s beyond %.0f times %s prior σ (%s): the data pull %s where the prior says a table is not off — %s may "
      "absorb another error (the poses, the mounting, a wrong matching) or the laser table is wrong",
      count, count == 1 ? "" : "s", kLaserPriorDoubt, count == 1 ? "its" : "their", far.c_str(), count == 1 ? "it" : "them",
      count == 1 ? "it" : "they")};
}

OneOfBlock::OneOfBlock(ceres::CostFunction* inner, int index, int size) : inner_(inner), index_(index), size_(size) {
  set_num_residuals(inner->num_residuals());
  *mutable_parameter_block_sizes() = inner->parameter_block_sizes();
  mutable_parameter_block_sizes()->back() = size;
}

bool OneOfBlock::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const std::size_t n = parameter_block_sizes().size();
  std::vector<const double*> p(parameters, parameters + n);
  p.back() = parameters[n - 1] + index_;
  if (!jacobians) return inner_->Evaluate(p.data(), residuals, nullptr);
  const int rows = num_residuals();
  std::vector<double> last(static_cast<std::size_t>(rows));
  std::vector<double*> j(jacobians, jacobians + n);
  if (j.back()) j.back() = last.data();
  if (!inner_->Evaluate(p.data(), residuals, j.data())) return false;
  if (double* J = jacobians[n - 1]) {  // row-major rows × size_: the one column of element index_
    std::fill(J, J + static_cast<std::size_t>(rows) * static_cast<std::size_t>(size_), 0.0);
    for (int r = 0; r < rows; ++r) J[r * size_ + index_] = last[static_cast<std::size_t>(r)];
  }
  return true;
}

}  // namespace mountcal::detail
