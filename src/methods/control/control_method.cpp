// Ground control as a module (methods/method.hpp): options, observations, Summary section.
#include "control_method.hpp"

#include <sstream>

#include "../common/section_format.hpp"
#include "../common/tie_options.hpp"

namespace mountcal {

namespace {

class ControlRun final : public MethodRun {
 public:
  explicit ControlRun(const MethodContext& c) {
    const ControlOptions& opts = std::any_cast<const ControlOptions&>(c.options);
    control_ = TieObservations::control(c.data, c.unclaimed_gcps, opts, opts.vtp, c.threads);
  }
  std::vector<ObservationSource*> sources() override {
    if (control_->observationCount() == 0) return {};
    return {control_.get()};
  }
  std::shared_ptr<const MethodSection> section() const override {
    const TieSection& t = control_->section();
    if (t.observations_used == 0 && t.rejected.empty()) return nullptr;  // nothing to report
    auto s = std::make_shared<ControlSection>();
    static_cast<TieSection&>(*s) = t;
    return s;
  }

 private:
  std::unique_ptr<TieObservations> control_;
};

const std::vector<OptionSpec>& controlOptionSpecs() {
  static const std::vector<OptionSpec> specs = detail::tieOptionTable<ControlOptions>().specs();
  return specs;
}

}  // namespace

std::string ControlMethod::name() const { return ControlOptions::kMethod; }
std::string ControlMethod::description() const {
  return "ground control with any method: each GCP (not a tie of \"vtpm\") picked on every strip that covers it; runs whenever the job has "
         "such GCPs";
}
MethodInput ControlMethod::input() const { return {"gcps", "", "the GCP CSV (gcp_id,x,y,z,sigma_xy_m,sigma_z_m)", false}; }
std::any ControlMethod::defaultOptions() const { return ControlOptions{}; }
const std::vector<OptionSpec>& ControlMethod::options() const { return controlOptionSpecs(); }
bool ControlMethod::validate(const std::any& options, std::string* error) const {
  const ControlOptions& opts = std::any_cast<const ControlOptions&>(options);
  return opts.IsValid(error) && detail::vtpOptionsValid(opts.vtp, error);
}
void ControlMethod::adoptNoise(const NoiseHint& noise, std::any* options) const {
  ControlOptions& opts = std::any_cast<ControlOptions&>(*options);
  opts.tie_sigma_xy_m = noise.pick_sigma_xy_m;
  opts.tie_sigma_z_m = noise.pick_sigma_z_m;
  opts.estimate_tie_sigma = false;
}
std::unique_ptr<MethodRun> ControlMethod::run(const MethodContext& context) const {
  if (context.unclaimed_gcps.empty()) return nullptr;
  return std::make_unique<ControlRun>(context);
}

// ---- the section ------------------------------------------------------------------------------

std::string ControlSection::brief() const {
  return detail::printfString("%d control points / %d observations; ", ties_used, observations_used);
}

std::string ControlSection::text(const AdjustmentSummary&) const {
  std::ostringstream r;
  r << detail::printfString("\nGround control: %d points, %d observations; RMS after (%.4f, %.4f, %.4f) m\n", ties_used, observations_used,
                            rms_after_m.x(), rms_after_m.y(), rms_after_m.z());
  for (const RejectedTie& t : rejected)
    r << "rejected control point " << t.tie_id << " on strip " << t.strip_id << ": " << t.reason << "\n";
  return r.str();
}

std::string ControlSection::resultJson(const AdjustmentSummary&) const {
  using nlohmann::json;
  const json rej = detail::rejectedTiesJson(rejected, "gcp_id");
  const json res = detail::tieResidualsJson(residuals, "gcp_id");
  json j;
  j["control"] = {{"points", ties_used},
                  {"observations", observations_used},
                  {"rms_before_m", detail::vec3Json(rms_before_m)},
                  {"rms_after_m", detail::vec3Json(rms_after_m)},
                  {"residuals", res},
                  {"rejected", rej}};
  return j.dump();
}

std::string ControlSection::html(const AdjustmentSummary&) const {
  if (observations_used == 0) return "";
  using detail::cell;
  const Vec3 b = rms_before_m, a = rms_after_m;
  std::ostringstream h;
  h << "<h2>Ground control</h2><p>" << ties_used << " control points, " << observations_used
    << " point-to-surface observations; RMS before (" << cell(b.x()) << ", " << cell(b.y()) << ", " << cell(b.z()) << ") m, after ("
    << cell(a.x()) << ", " << cell(a.y()) << ", " << cell(a.z()) << ") m</p>";
  return h.str();
}

std::vector<std::string> ControlSection::warnings() const {
  if (rejected.empty()) return {};
  return {std::to_string(rejected.size()) + " ground control observations rejected"};
}

int ControlSection::outliers() const { return outlierCount(); }

}  // namespace mountcal
