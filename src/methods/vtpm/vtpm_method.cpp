// Method "vtpm" as a module (methods/method.hpp): options, observations, Summary section.
#include "vtpm_method.hpp"

#include <map>
#include <sstream>

#include "../common/section_format.hpp"
#include "../common/tie_options.hpp"
#include "mountcal/report/svg_plot.hpp"

namespace mountcal {

namespace {

class VtpmRun final : public MethodRun {
 public:
  explicit VtpmRun(const MethodContext& c) {
    const VtpmOptions& opts = std::any_cast<const VtpmOptions&>(c.options);
    ties_ = std::make_unique<TieObservations>(c.data, c.data.ties, c.data.gcps, opts, opts.vtp, "ties", c.threads);
  }
  std::vector<ObservationSource*> sources() override {
    if (ties_->observationCount() == 0) return {};
    return {ties_.get()};
  }
  std::shared_ptr<const MethodSection> section() const override {
    auto s = std::make_shared<VtpmSection>();
    static_cast<TieSection&>(*s) = ties_->section();
    return s;
  }
  std::string nothingUsable() const override {
    return "no usable tie: " + std::to_string(ties_->section().rejected.size()) + " tie observations rejected (see rejected)";
  }

 private:
  std::unique_ptr<TieObservations> ties_;
};

}  // namespace

namespace {
const std::vector<OptionSpec>& vtpmOptionSpecs() {
  static const std::vector<OptionSpec> specs = detail::tieOptionTable<VtpmOptions>().specs();
  return specs;
}
}  // namespace

std::string VtpmMethod::name() const { return VtpmOptions::kMethod; }
std::string VtpmMethod::description() const {
  return "virtual tie points from the user's tie picks (the first paper, SPEC §3); ground control with a tie's id is a prior on it";
}
MethodInput VtpmMethod::input() const { return {"ties", "", "the ties CSV (tie_id,strip_id,x,y)", true}; }
std::any VtpmMethod::defaultOptions() const { return VtpmOptions{}; }
const std::vector<OptionSpec>& VtpmMethod::options() const { return vtpmOptionSpecs(); }
bool VtpmMethod::validate(const std::any& options, std::string* error) const {
  const VtpmOptions& opts = std::any_cast<const VtpmOptions&>(options);
  return opts.IsValid(error) && detail::vtpOptionsValid(opts.vtp, error);
}
void VtpmMethod::adoptNoise(const NoiseHint& noise, std::any* options) const {
  VtpmOptions& opts = std::any_cast<VtpmOptions&>(*options);
  opts.tie_sigma_xy_m = noise.pick_sigma_xy_m;
  opts.tie_sigma_z_m = noise.pick_sigma_z_m;
  opts.estimate_tie_sigma = false;
}
std::set<std::string> VtpmMethod::claimedGcps(const CalibrationData& data) const {
  std::set<std::string> ids;
  for (const TieObservation& t : data.ties) ids.insert(t.tie_id);
  return ids;
}
std::unique_ptr<MethodRun> VtpmMethod::run(const MethodContext& context) const { return std::make_unique<VtpmRun>(context); }

// ---- the section ------------------------------------------------------------------------------

std::string VtpmSection::brief() const {
  return detail::printfString("%d ties / %d observations (%zu rejected), RMS after (%.3f, %.3f, %.3f) m; ", ties_used, observations_used,
                              rejected.size(), rms_after_m.x(), rms_after_m.y(), rms_after_m.z());
}

std::string VtpmSection::text(const AdjustmentSummary&) const {
  std::ostringstream r;
  r << detail::printfString("\nTies %d, observations %d, rejected %zu\n", ties_used, observations_used, rejected.size());
  if (neighbourhood_motion > 0)
    r << detail::printfString(
        "Picks moved with their neighbourhood's mean displacement (multi-beam strips, each laser the same weight): %d of %d\n",
        neighbourhood_motion, observations_used);
  r << detail::printfString("Ties: RMS before (%.4f, %.4f, %.4f) m, after (%.4f, %.4f, %.4f) m\n", rms_before_m.x(), rms_before_m.y(),
                            rms_before_m.z(), rms_after_m.x(), rms_after_m.y(), rms_after_m.z());
  r << detail::printfString("Tie sigma %s: horizontal %.4f m, vertical %.4f m\n",
                            sigma_estimated ? "estimated from the residuals (variance components)" : "as stated", sigma_xy_m, sigma_z_m);
  for (const RejectedTie& t : rejected) r << "rejected tie " << t.tie_id << " on strip " << t.strip_id << ": " << t.reason << "\n";
  for (const TieResidual& t : residuals)
    if (t.outlier) r << "outlier: tie " << t.tie_id << " on strip " << t.strip_id << ", residual " << t.after_m.norm() << " m\n";
  return r.str();
}

std::string VtpmSection::resultJson(const AdjustmentSummary&) const {
  using nlohmann::json;
  const json rej = detail::rejectedTiesJson(rejected, "tie_id");
  const json res = detail::tieResidualsJson(residuals, "tie_id");
  json j;
  j["ties"] = {{"used", ties_used}, {"observations", observations_used}, {"rejected", rej}};
  j["pick_motion"] = {{"neighbourhood", neighbourhood_motion}, {"triangle", observations_used - neighbourhood_motion}};
  j["rms_before_m"] = detail::vec3Json(rms_before_m);
  j["rms_after_m"] = detail::vec3Json(rms_after_m);
  j["residuals"] = res;
  return j.dump();
}

std::string VtpmSection::html(const AdjustmentSummary&) const {
  using detail::cell;
  using detail::htmlEscape;
  std::ostringstream h;
  h << "<h2>Tie residuals (seed Table 1)</h2><p>" << ties_used << " ties, " << observations_used << " observations, " << rejected.size()
    << " rejected; RMS before (" << cell(rms_before_m.x()) << ", " << cell(rms_before_m.y()) << ", " << cell(rms_before_m.z())
    << ") m, after (" << cell(rms_after_m.x()) << ", " << cell(rms_after_m.y()) << ", " << cell(rms_after_m.z()) << ") m</p>";
  if (neighbourhood_motion > 0)
    h << "<p>" << neighbourhood_motion << " of " << observations_used
      << " picks move with their neighbourhood's mean displacement (multi-beam strips, each laser the same weight), the others with "
         "their triangle (seed Rule 2).</p>";
  std::vector<double> idx, bh, ah, bv, av;
  for (std::size_t i = 0; i < residuals.size(); ++i) {
    const TieResidual& r = residuals[i];
    idx.push_back(static_cast<double>(i + 1));
    bh.push_back(r.before_m.head<2>().norm());
    ah.push_back(r.after_m.head<2>().norm());
    bv.push_back(std::abs(r.before_m.z()));
    av.push_back(std::abs(r.after_m.z()));
  }
  SvgLinePlot plot("Residual size per tie observation", "observation", "residual [m]");
  plot.addSeries("horizontal, before", idx, bh);
  plot.addSeries("horizontal, after", idx, ah);
  plot.addSeries("vertical, before", idx, bv);
  plot.addSeries("vertical, after", idx, av);
  h << plot.render(900, 360);
  h << "<table><tr><th>tie</th><th>strip</th><th>dX before</th><th>dY before</th><th>dZ before</th><th>dX after</th><th>dY after</th>"
       "<th>dZ after</th><th></th></tr>";
  for (const TieResidual& r : residuals) {
    h << "<tr><td class=l>" << htmlEscape(r.tie_id) << "</td><td class=l>" << htmlEscape(r.strip_id) << "</td>";
    for (int a = 0; a < 3; ++a) h << "<td>" << cell(r.before_m[a], "%+.3f") << "</td>";
    for (int a = 0; a < 3; ++a) h << "<td>" << cell(r.after_m[a], "%+.3f") << "</td>";
    h << "<td class=l>" << (r.outlier ? "<span class=bad>outlier</span>" : "") << "</td></tr>";
  }
  h << "</table>";
  if (!rejected.empty()) {
    h << "<h2>Rejected tie observations</h2><table><tr><th>tie</th><th>strip</th><th>reason</th></tr>";
    for (const RejectedTie& r : rejected)
      h << "<tr><td class=l>" << htmlEscape(r.tie_id) << "</td><td class=l>" << htmlEscape(r.strip_id) << "</td><td class=l>"
        << htmlEscape(r.reason) << "</td></tr>";
    h << "</table>";
  }
  return h.str();
}

std::vector<std::string> VtpmSection::warnings() const {
  if (rejected.empty()) return {};
  return {std::to_string(rejected.size()) + " tie observations rejected (reasons in the table below)"};
}

int VtpmSection::outliers() const { return outlierCount(); }

std::vector<PlanResidual> VtpmSection::planResiduals(const CalibrationData& data) const {
  std::map<std::pair<std::string, std::string>, const TieObservation*> pick;
  for (const TieObservation& t : data.ties) pick[{t.tie_id, t.strip_id}] = &t;
  std::vector<PlanResidual> out;
  for (const TieResidual& r : residuals) {
    const auto it = pick.find({r.tie_id, r.strip_id});
    if (it == pick.end()) continue;
    out.push_back({r.tie_id + " on strip " + r.strip_id, it->second->x_m, it->second->y_m, r.before_m, r.after_m});
  }
  return out;
}

}  // namespace mountcal
