// Per-laser intrinsics as one nuisance block (laser_intrinsics.hpp).
#include "methods/common/laser_intrinsics.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "methods/common/laser_prior.hpp"
#include "methods/common/section_format.hpp"
#include "mountcal/core/error.hpp"
#include "mountcal/core/rotation.hpp"

namespace mountcal::detail {

LaserLayout::LaserLayout(int laser_count, const LaserCorrection& prior) : lasers(laser_count) {
  for (std::size_t g = 0; g < 5; ++g) {
    if (!(prior.*kLaserGroups[g].field > 0) || laser_count <= 0) continue;
    offset[g] = size;
    size += laser_count;
  }
}

LaserCorrection LaserLayout::correction(const double* block, int laser) const {
  LaserCorrection c;
  for (std::size_t g = 0; g < 5; ++g)
    if (offset[g] >= 0) c.*kLaserGroups[g].field = block[offset[g] + laser];
  return c;
}

LaserCorrections LaserLayout::corrections(const double* block) const {
  LaserCorrections out;
  if (empty()) return out;
  for (int l = 0; l < lasers; ++l) out.push_back(correction(block, l));
  return out;
}

void addLaserPriors(AdjustmentProblem* problem, double* block, const LaserLayout& layout, const LaserCorrection& prior,
                    const std::vector<bool>& seen) {
  for (std::size_t g = 0; g < 5; ++g) {
    const int o = layout.offset[g];
    if (o < 0) continue;
    std::vector<int> mean;
    for (int i = 0; i < layout.lasers; ++i) {
      addLaserPrior(problem, block, layout.size, {o + i}, prior.*kLaserGroups[g].field);
      if (seen[static_cast<std::size_t>(i)]) mean.push_back(o + i);
    }
    if ((g == 0 || g == 1 || g == 3) && !mean.empty()) addLaserPrior(problem, block, layout.size, mean, g == 3 ? 1e-7 : 1e-6);
  }
}

LaserIntrinsicEstimates laserEstimates(const AdjustmentProblem& adjustment, const double* block, const LaserLayout& layout,
                                       const LaserCorrection& prior, const std::vector<int>& points, const Eigen::MatrixXd& block_change) {
  LaserIntrinsicEstimates out;
  if (!block || layout.empty()) return out;
  const int L = layout.lasers;
  const std::size_t n_lasers = static_cast<std::size_t>(L);
  static const char* const kMounting[6] = {"lever arm x", "lever arm y", "lever arm z", "roll", "pitch", "heading"};
  const double nan = std::nan("");
  out.lasers = layout.corrections(block);
  out.prior_sigma = prior;
  out.points = points;
  out.points.resize(n_lasers, 0);
  out.sigma.assign(n_lasers, LaserCorrection{nan, nan, nan, nan, nan});
  out.boresight_correlation.assign(n_lasers, nan);
  const Eigen::MatrixXd& joint = adjustment.reportedCovariance(block);
  const int n = layout.size;
  if (joint.rows() != 6 + n) return out;
  Eigen::MatrixXd C_ll = joint.bottomRightCorner(n, n);
  if (block_change.rows() == n && block_change.cols() == n) C_ll += block_change;
  const Eigen::MatrixXd C_lm = joint.bottomLeftCorner(n, 6), C_mm = joint.topLeftCorner(6, 6);
  constexpr double kUnseparated = 0.95;
  auto corr = [](double cab, double va, double vb) { return va > 0 && vb > 0 ? cab / std::sqrt(va * vb) : 0.0; };
  for (int i = 0; i < L; ++i) {
    if (out.points[static_cast<std::size_t>(i)] == 0) continue;
    double rho = 0;
    for (std::size_t g = 0; g < 5; ++g) {
      if (layout.offset[g] < 0) continue;
      const int k = layout.offset[g] + i;
      const double v = C_ll(k, k);
      out.sigma[static_cast<std::size_t>(i)].*kLaserGroups[g].field = std::sqrt(std::max(v, 0.0));
      for (int j = 0; j < 6; ++j) {
        if (!std::isfinite(C_mm(j, j))) continue;  // a held mounting parameter
        const double r = corr(C_lm(k, j), v, C_mm(j, j));
        if (j >= 3) rho = std::max(rho, std::abs(r));
        if (std::abs(r) >= kUnseparated)
          out.unseparated.push_back(printfString("laser %d %s ~ %s (%+.2f)", i, kLaserGroups[g].name, kMounting[j], r));
      }
      for (std::size_t h = g + 1; h < 5; ++h) {
        if (layout.offset[h] < 0) continue;
        const int k2 = layout.offset[h] + i;
        const double r = corr(C_ll(k, k2), v, C_ll(k2, k2));
        if (std::abs(r) >= kUnseparated)
          out.unseparated.push_back(printfString("laser %d %s ~ laser %d %s (%+.2f)", i, kLaserGroups[g].name, i, kLaserGroups[h].name, r));
      }
    }
    out.boresight_correlation[static_cast<std::size_t>(i)] = rho;
  }
  return out;
}

namespace {
/// The groups estimated (prior σ > 0), in LaserCorrection's order.
std::vector<const LaserGroup*> estimatedGroups(const LaserIntrinsicEstimates& e) {
  std::vector<const LaserGroup*> out;
  for (const LaserGroup& g : kLaserGroups)
    if (e.prior_sigma.*g.field > 0) out.push_back(&g);
  return out;
}
double at(const std::vector<double>& v, std::size_t i) { return i < v.size() ? v[i] : std::nan(""); }
}  // namespace

std::string laserIntrinsicsText(const LaserIntrinsicEstimates& e, const std::string& title, const std::string& points_label) {
  std::ostringstream r;
  r << title << "\n  laser";
  const std::vector<const LaserGroup*> groups = estimatedGroups(e);
  for (const LaserGroup* g : groups) r << printfString("  %10s [%s] %9s", g->name, g->unit, "sigma");
  r << "  max|corr| boresight  " << points_label << "\n";
  for (std::size_t i = 0; i < e.lasers.size(); ++i) {
    r << printfString("  %5zu", i);
    for (const LaserGroup* g : groups)
      r << printfString("  %+16.4f %9.4f", e.lasers[i].*g->field * g->to_unit, e.sigma[i].*g->field * g->to_unit);
    r << printfString("  %19.2f  %*d\n", at(e.boresight_correlation, i), static_cast<int>(points_label.size()), e.points[i]);
  }
  if (e.unseparated.empty()) {
    r << "  Correlation screening: every laser parameter separated from the others and from the mounting (|corr| < 0.95).\n";
  } else {
    r << "  Correlation screening: " << e.unseparated.size() << " pair(s) the data do not separate (|corr| >= 0.95):";
    for (std::size_t k = 0; k < e.unseparated.size() && k < 12; ++k) r << (k ? "; " : " ") << e.unseparated[k];
    r << (e.unseparated.size() > 12 ? "; ...\n" : "\n");
  }
  return r.str();
}

std::string laserIntrinsicsHtml(const LaserIntrinsicEstimates& e, const std::string& title, const std::string& points_label) {
  const std::vector<const LaserGroup*> groups = estimatedGroups(e);
  std::string h = "<h3>" + htmlEscape(title) + "</h3><table><tr><th>laser</th>";
  for (const LaserGroup* g : groups) {
    const std::string unit = g->to_unit != 1 ? "°" : "m";
    h += std::string("<th>") + g->name + " [" + unit + "]</th><th>σ [" + unit + "]</th>";
  }
  h += "<th>max |corr| boresight</th><th>" + htmlEscape(points_label) + "</th></tr>";
  for (std::size_t i = 0; i < e.lasers.size(); ++i) {
    h += "<tr><td>" + std::to_string(i) + "</td>";
    for (const LaserGroup* g : groups)
      h += "<td>" + cell(e.lasers[i].*g->field * g->to_unit, "%+.4f") + "</td><td>" + cell(e.sigma[i].*g->field * g->to_unit, "%.4f") +
           "</td>";
    h += "<td>" + cell(at(e.boresight_correlation, i), "%.2f") + "</td><td>" + std::to_string(e.points[i]) + "</td></tr>";
  }
  h += "</table>";
  if (!e.unseparated.empty()) {
    h += "<p>Not separated by the data (|corr| ≥ 0.95):";
    for (std::size_t k = 0; k < e.unseparated.size() && k < 12; ++k) h += (k ? "; " : " ") + htmlEscape(e.unseparated[k]);
    h += e.unseparated.size() > 12 ? "; …</p>" : "</p>";
  }
  return h;
}

std::string laserIntrinsicsJson(const LaserIntrinsicEstimates& e) {
  using nlohmann::json;
  // The complete intrinsics to use from now on (apply and evaluate read them), by laser id.
  json j = json::object();
  for (const LaserGroup* g : estimatedGroups(e)) {
    json v = json::array(), s = json::array();
    for (std::size_t i = 0; i < e.lasers.size(); ++i) {
      v.push_back(e.lasers[i].*g->field * g->to_unit);
      s.push_back(numOrNull(e.sigma[i].*g->field * g->to_unit));
    }
    j[std::string("laser_") + g->name + "_offset_" + g->unit] = v;
    j[std::string("laser_") + g->name + "_sigma_" + g->unit] = s;
  }
  json cor = json::array(), pts = json::array();
  for (std::size_t i = 0; i < e.lasers.size(); ++i) {
    cor.push_back(numOrNull(at(e.boresight_correlation, i)));
    pts.push_back(e.points[i]);
  }
  j["laser_boresight_correlation"] = cor;
  j["laser_points"] = pts;
  j["laser_unseparated"] = e.unseparated;
  return j.dump();
}

std::vector<std::string> laserIntrinsicsDoubts(const LaserIntrinsicEstimates& e) {
  return laserPriorDoubts(e.lasers, e.points, e.prior_sigma);
}

std::vector<std::string> laserImplausibleWarnings(const LaserCorrections& lasers) {
  // Beyond these a per-laser correction is not a calibration residual of a working sensor: the
  // makers' range accuracy is a few centimetres (MultiBeamModel::rangeAccuracy: VLP-16 3 cm, HDL-32E 2 cm).
  constexpr double kPlausibleRangeM = 0.10, kPlausibleOriginM = 0.05, kPlausibleAngleDeg = 1.0;
  std::vector<std::string> w;
  for (std::size_t i = 0; i < lasers.size(); ++i) {
    const LaserCorrection& l = lasers[i];
    const double angle = rad2deg(std::max(std::abs(l.elevation_rad), std::abs(l.azimuth_rad)));
    if (std::abs(l.range_m) > kPlausibleRangeM || std::max(std::abs(l.vertical_m), std::abs(l.horizontal_m)) > kPlausibleOriginM ||
        angle > kPlausibleAngleDeg) {
      w.push_back(printfString(
          "laser %zu: intrinsics beyond a working sensor's (range %+.3f m, origin %+.3f / %+.3f m, angles up to %.2f deg; plausible "
          "within %.2f m, %.2f m, %.1f deg): check the laser table, the laser ids and the data before using them",
          i, l.range_m, l.vertical_m, l.horizontal_m, angle, kPlausibleRangeM, kPlausibleOriginM, kPlausibleAngleDeg));
    }
  }
  return w;
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

void LaserIntrinsicsBlock::setUp(const CalibrationData& data, const std::string& method, const LaserCorrection& prior) {
  int lasers = 0;
  for (const StripData& s : data.strips) {
    if (s.laser.size() != s.r_s.size())
      throw InvalidInput(method + ": per-laser intrinsics need each point's laser id (job key sensor.laser_field); strip '" + s.id +
                         "' has none");
    for (std::uint16_t id : s.laser) lasers = std::max(lasers, static_cast<int>(id) + 1);
  }
  prior_ = prior;
  layout_ = LaserLayout(lasers, prior);
  values_.assign(static_cast<std::size_t>(layout_.size), 0.0);
  block_ = nullptr;
}

double* LaserIntrinsicsBlock::add(AdjustmentProblem* problem, const std::vector<bool>& seen) {
  block_ = nullptr;
  if (layout_.empty()) return nullptr;
  block_ = problem->addNuisanceBlock(layout_.size, values_.data(), nullptr, false);
  problem->reportCovariance(block_, "the per-laser intrinsics");  // σ with the trajectory errors in time, as the mounting's
  addLaserPriors(problem, block_, layout_, prior_, seen);
  return block_;
}

LaserIntrinsicEstimates LaserIntrinsicsBlock::finish(const AdjustmentProblem& adjustment, const std::vector<int>& points,
                                                     const Eigen::MatrixXd& block_change) const {
  return laserEstimates(adjustment, block_, layout_, prior_, points, block_change);
}

OneLaserOfBlock::OneLaserOfBlock(ceres::CostFunction* inner, const LaserLayout& layout, int laser) : inner_(inner), size_(layout.size) {
  for (std::size_t g = 0; g < 5; ++g) index_[g] = layout.offset[g] < 0 ? -1 : layout.offset[g] + laser;
  set_num_residuals(inner->num_residuals());
  *mutable_parameter_block_sizes() = inner->parameter_block_sizes();
  mutable_parameter_block_sizes()->back() = size_;
}

bool OneLaserOfBlock::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const std::size_t n = parameter_block_sizes().size();
  std::array<double, 5> mine{};
  for (std::size_t g = 0; g < 5; ++g)
    if (index_[g] >= 0) mine[g] = parameters[n - 1][index_[g]];
  std::vector<const double*> p(parameters, parameters + n);
  p.back() = mine.data();
  if (!jacobians) return inner_->Evaluate(p.data(), residuals, nullptr);
  const int rows = num_residuals();
  std::vector<double> last(static_cast<std::size_t>(rows) * 5);
  std::vector<double*> j(jacobians, jacobians + n);
  if (j.back()) j.back() = last.data();
  if (!inner_->Evaluate(p.data(), residuals, j.data())) return false;
  if (double* J = jacobians[n - 1]) {  // row-major rows × size_: the columns of this laser's estimated groups
    std::fill(J, J + static_cast<std::size_t>(rows) * static_cast<std::size_t>(size_), 0.0);
    for (int r = 0; r < rows; ++r)
      for (std::size_t g = 0; g < 5; ++g)
        if (index_[g] >= 0) J[r * size_ + index_[g]] = last[static_cast<std::size_t>(r) * 5 + g];
  }
  return true;
}

}  // namespace mountcal::detail
