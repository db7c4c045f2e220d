// Method "features" as a module (methods/method.hpp): options, observations, Summary section.
#include "features_method.hpp"

#include <optional>
#include <sstream>

#include "../common/laser_intrinsics.hpp"
#include "../common/section_format.hpp"

namespace mountcal {

namespace {

class FeaturesRun final : public MethodRun {
 public:
  explicit FeaturesRun(const MethodContext& c)
      : features_(std::make_unique<FeatureObservations>(c.data, std::any_cast<const FeatureOptions&>(c.options))) {
    if (features_->section().closed_form.valid) start_ = features_->section().closed_form.mounting.toArray();
  }
  std::vector<ObservationSource*> sources() override {
    if (features_->observationCount() == 0) return {};
    return {features_.get()};
  }
  /// The paper's closed form is the starting value of the rigorous solution (seed 002 §2.3).
  const std::array<double, 6>* start() const override { return start_ ? &*start_ : nullptr; }
  std::shared_ptr<const MethodSection> section() const override { return std::make_shared<FeatureSection>(features_->section()); }

 private:
  std::unique_ptr<FeatureObservations> features_;
  std::optional<std::array<double, 6>> start_;
};

/// "Per-laser elevation offsets" when those alone are estimated, else "Per-laser intrinsics".
std::string laserTitle(const LaserIntrinsicEstimates& e) {
  return detail::LaserLayout(1, e.prior_sigma).elevationOnly() ? "Per-laser elevation offsets" : "Per-laser intrinsics";
}

const std::vector<OptionSpec>& featureOptionSpecs() {
  using T = FeatureOptions;
  static const std::vector<OptionSpec> specs =
      detail::laserPriorOptions(
          OptionTable<T>()
              .number(
                  "intensity_threshold", [](T& o) -> double& { return o.intensity_threshold; }, "intensity", 0, 1e6,
                  "target points at or above; 0: Otsu's threshold per region")
              .number(
                  "min_contrast", [](T& o) -> double& { return o.min_contrast; }, "-", 1, 1000, "target to background intensity ratio")
              .number(
                  "growing_distance_m", [](T& o) -> double& { return o.growing_distance_m; }, "m", 0, 100,
                  "region growing distance; 0: from the point spacing")
              .number(
                  "second_group_fraction", [](T& o) -> double& { return o.second_group_fraction; }, "-", 1e-6, 1,
                  "a second bright group this large makes the target ambiguous")
              .number(
                  "ransac_threshold_m", [](T& o) -> double& { return o.ransac_threshold_m; }, "m", 1e-4, 10,
                  "RANSAC inlier distance of the target's plane")
              .integer(
                  "ransac_iterations", [](T& o) -> int& { return o.ransac_iterations; }, 1, 100000, "RANSAC iterations")
              .integer(
                  "min_points", [](T& o) -> int& { return o.min_points; }, 3, 1000000, "a strip's target with fewer inliers is not seen")
              .number(
                  "min_inlier_fraction", [](T& o) -> double& { return o.min_inlier_fraction; }, "-", 1e-6, 1,
                  "fewer of the group's points on its plane: not planar")
              .number(
                  "sigma_in_plane_m", [](T& o) -> double& { return o.sigma_in_plane_m; }, "m", 0, 10,
                  "sigma of a centre in the target's plane; 0: estimated")
              .integer(
                  "edge_points", [](T& o) -> int& { return o.edge_points; }, 0, 1000,
                  "outline points averaged per side for the centre; 0: the mean")
              .integer(
                  "icp_max_iterations", [](T& o) -> int& { return o.icp_max_iterations; }, 1, 10000, "ICP iterations")
              .number(
                  "icp_tolerance_m", [](T& o) -> double& { return o.icp_tolerance_m; }, "m", 1e-12, 1,
                  "ICP stops when the translation changes less")
              .number(
                  "direction_tolerance_deg", [](T& o) -> double& { return o.direction_tolerance_deg; }, "deg", 1e-3, 89.999,
                  "strips within this of each other are one direction")
              .number(
                  "min_height_spread", [](T& o) -> double& { return o.min_height_spread; }, "-", 1e-6, 10,
                  "relative height spread needed for the lever arm from two heights"),
          "multi-beam strips with laser ids: ")
          .specs();
  return specs;
}

}  // namespace

std::string FeaturesMethod::description() const {
  return "the second paper's matched high-intensity targets: extraction, ICP offsets per strip pair, closed form, then rigorous blocks";
}
MethodInput FeaturesMethod::input() const {
  return {"targets", "", "the target regions CSV (plane_id,xmin,ymin,xmax,ymax), each region holding one high-intensity target", true};
}
const std::vector<OptionSpec>& FeaturesMethod::options() const { return featureOptionSpecs(); }
bool FeaturesMethod::validate(const std::any& options, std::string* error) const {
  return std::any_cast<const FeatureOptions&>(options).IsValid(error);
}
void FeaturesMethod::adoptNoise(const NoiseHint& noise, std::any* options) const {
  std::any_cast<FeatureOptions&>(*options).sigma_in_plane_m = std::max(noise.pick_sigma_xy_m, 0.01);
}
std::unique_ptr<MethodRun> FeaturesMethod::run(const MethodContext& context) const { return std::make_unique<FeaturesRun>(context); }

// ---- the section ------------------------------------------------------------------------------

std::string FeatureSection::brief() const {
  return detail::printfString("%d targets / %d views / %zu pairs (%zu rejected); ", targets_used, views_used, pairs.size(),
                              rejected.size());
}

std::string FeatureSection::text(const AdjustmentSummary& summary) const {
  std::ostringstream r;
  r << detail::printfString(
      "\nFeatures (seed 002): %d targets, %d views; centre RMS before (%.4f, %.4f, %.4f) m, after (%.4f, %.4f, %.4f) m; "
      "sigma %s: along the normal %.4f m, in the plane %.4f m (along the track %.4f m, across it %.4f m); extraction %.3f s, "
      "matching %.3f s\n",
      targets_used, views_used, rms_before_m.x(), rms_before_m.y(), rms_before_m.z(), rms_after_m.x(), rms_after_m.y(), rms_after_m.z(),
      sigma_estimated ? "estimated (variance components)" : "as stated", sigma_normal_m, sigma_in_plane_m, sigma_along_track_m,
      sigma_across_track_m, extraction_time_s, matching_time_s);
  r << "  target        A     B     relation   H [m]   y_A [m]   D [m]   offset along/cross/down [m]      ICP it  RMS [m]\n";
  for (const FeaturePairOffset& p : pairs) {
    r << detail::printfString("  %-12s %-5s %-5s %-9s %7.2f %8.2f %7.2f   %+8.4f %+8.4f %+8.4f   %6d %8.4f\n", p.target_id.c_str(),
                              p.strip_a.c_str(), p.strip_b.c_str(), p.relation.c_str(), p.height_m, p.lateral_a_m, p.line_offset_m,
                              p.offset_afd_m.x(), p.offset_afd_m.y(), p.offset_afd_m.z(), p.icp_iterations, p.icp_rms_m);
  }
  const FeatureClosedForm& C = closed_form;
  if (C.valid) {
    const Vec3 cb = C.mounting.boresightDeg(), rb = summary.mounting.boresightDeg();
    r << "Closed form (SPEC §2, seed 002 eqs. 8-10) versus the rigorous adjustment:\n"
         "  angle     closed form [deg]  sigma [deg]  spread [deg]  pairs   rigorous [deg]\n";
    const char* names[3] = {"roll", "pitch", "heading"};
    for (int a = 0; a < 3; ++a) {
      r << detail::printfString("  %-8s %+17.5f %12.5f %13.5f %6d %+16.5f\n", names[a], cb(a), rad2deg(C.boresight_sigma_rad(a)),
                                rad2deg(C.boresight_spread_rad(a)), C.pairs_used[a], rb(a));
    }
    if (C.lever_arm_estimated) {
      r << detail::printfString("  lever arm x, y (two heights): %+.4f, %+.4f m (sigma %.4f, %.4f m)\n", C.mounting.a_b.x(),
                                C.mounting.a_b.y(), C.lever_arm_sigma_m.x(), C.lever_arm_sigma_m.y());
    }
  }
  if (!C.message.empty()) r << "  closed form: " << C.message << "\n";
  if (!laser_intrinsics.empty())
    r << detail::laserIntrinsicsText(laser_intrinsics,
                                     laserTitle(laser_intrinsics) +
                                         " (by laser id; added to the laser table; means of elevation, azimuth and vertical held at 0 "
                                         "over the lasers the targets' outlines use):",
                                     "target points");
  for (const RejectedFeature& t : rejected)
    r << "rejected target " << t.target_id << (t.strip_id.empty() ? "" : " on strip " + t.strip_id) << ": " << t.reason << "\n";
  return r.str();
}

std::string FeatureSection::resultJson(const AdjustmentSummary&) const {
  using detail::numOrNull;
  using detail::vec3Json;
  using nlohmann::json;
  json targets = json::array();
  for (std::size_t k = 0; k < target_ids.size(); ++k) {
    json list = json::array();
    for (const FeatureView& v : views[k]) {
      list.push_back({{"strip_id", v.strip_id},
                      {"points", v.points},
                      {"centroid_m", vec3Json(v.centroid_m)},
                      {"normal", vec3Json(v.normal)},
                      {"plane_sigma_m", v.plane_sigma_m},
                      {"sigma_normal_m", v.sigma_normal_m},
                      {"sigma_in_plane_m", v.sigma_in_plane_m},
                      {"intensity_threshold", v.threshold}});
    }
    targets.push_back({{"target_id", target_ids[k]}, {"views", list}});
  }
  json pair_list = json::array();
  for (const FeaturePairOffset& p : pairs) {
    pair_list.push_back({{"target_id", p.target_id},
                         {"strip_a", p.strip_a},
                         {"strip_b", p.strip_b},
                         {"relation", p.relation},
                         {"offset_m", vec3Json(p.offset_m)},
                         {"offset_along_cross_down_m", vec3Json(p.offset_afd_m)},
                         {"sigma_along_cross_down_m", vec3Json(p.covariance_afd.diagonal().cwiseSqrt())},
                         {"height_m", p.height_m},
                         {"lateral_a_m", p.lateral_a_m},
                         {"line_offset_m", p.line_offset_m},
                         {"icp_iterations", p.icp_iterations},
                         {"icp_rms_m", p.icp_rms_m}});
  }
  json rej = json::array();
  for (const RejectedFeature& r : rejected) rej.push_back({{"target_id", r.target_id}, {"strip_id", r.strip_id}, {"reason", r.reason}});
  json res = json::array();
  for (const Residual& r : residuals)
    res.push_back(
        {{"target_id", r.target_id}, {"strip_id", r.strip_id}, {"before_m", vec3Json(r.before_m)}, {"after_m", vec3Json(r.after_m)}});
  const FeatureClosedForm& C = closed_form;
  json cf = {{"valid", C.valid}, {"message", C.message}};
  if (C.valid) {
    auto orNull = [&](const Vec3& v, double k) {
      json a = json::array();
      for (int i = 0; i < 3; ++i) a.push_back(numOrNull(k * v(i)));
      return a;
    };
    const double deg = 180.0 / kPi;
    cf["mounting"] = {{"lever_arm_m", vec3Json(C.mounting.a_b)}, {"boresight_deg", vec3Json(C.mounting.boresightDeg())}};
    cf["boresight_correction_deg"] = orNull(C.boresight_correction_rad, deg);
    cf["boresight_sigma_deg"] = orNull(C.boresight_sigma_rad, deg);
    cf["boresight_spread_deg"] = orNull(C.boresight_spread_rad, deg);
    cf["pairs_used"] = {C.pairs_used[0], C.pairs_used[1], C.pairs_used[2]};
    cf["lever_arm_estimated"] = C.lever_arm_estimated;
    cf["lever_arm_correction_m"] = orNull(C.lever_arm_correction_m, 1.0);
    cf["lever_arm_sigma_m"] = orNull(C.lever_arm_sigma_m, 1.0);
    cf["pitch_lever_arm_coupled"] = C.pitch_lever_arm_coupled;
  }
  json j;
  j["features"] = {{"targets_used", targets_used},
                   {"views_used", views_used},
                   {"targets", targets},
                   {"pairs", pair_list},
                   {"closed_form", cf},
                   {"rejected", rej},
                   {"residuals", res},
                   {"rms_before_m", vec3Json(rms_before_m)},
                   {"rms_after_m", vec3Json(rms_after_m)},
                   {"sigma_normal_m", sigma_normal_m},
                   {"sigma_in_plane_m", sigma_in_plane_m},
                   {"sigma_along_track_m", sigma_along_track_m},
                   {"sigma_across_track_m", sigma_across_track_m},
                   {"sigma_estimated", sigma_estimated},
                   {"extraction_time_s", extraction_time_s},
                   {"matching_time_s", matching_time_s}};
  // The intrinsics to use from now on (apply and evaluate read them), by laser id.
  if (!laser_intrinsics.empty()) j["intrinsics"] = json::parse(detail::laserIntrinsicsJson(laser_intrinsics));
  return j.dump();
}

std::string FeatureSection::html(const AdjustmentSummary& summary) const {
  using detail::cell;
  using detail::htmlEscape;
  std::ostringstream h;
  h << "<h2>High-intensity targets (the second paper's feature matching)</h2><p>" << targets_used << " targets, " << views_used
    << " strip views; centroid RMS before (" << cell(rms_before_m.x()) << ", " << cell(rms_before_m.y()) << ", " << cell(rms_before_m.z())
    << ") m, after (" << cell(rms_after_m.x()) << ", " << cell(rms_after_m.y()) << ", " << cell(rms_after_m.z()) << ") m</p>";
  const FeatureClosedForm& C = closed_form;
  if (C.valid) {
    const Vec3 cb = C.mounting.boresightDeg(), rb = summary.mounting.boresightDeg();
    h << "<table><tr><th>angle</th><th>closed form [°]</th><th>σ [°]</th><th>spread of the pairs [°]</th><th>pairs</th><th>rigorous "
         "[°]</th>"
         "<th>rigorous σ [°]</th></tr>";
    const char* names[3] = {"roll", "pitch", "heading"};
    for (int a = 0; a < 3; ++a) {
      h << "<tr><td class=l>" << names[a] << "</td><td>" << cell(cb(a), "%+.5f") << "</td><td>"
        << cell(rad2deg(C.boresight_sigma_rad(a)), "%.5f") << "</td><td>" << cell(rad2deg(C.boresight_spread_rad(a)), "%.5f") << "</td><td>"
        << C.pairs_used[a] << "</td><td>" << cell(rb(a), "%+.5f") << "</td><td>" << cell(rad2deg(summary.sigma[3 + a]), "%.5f")
        << "</td></tr>";
    }
    h << "</table>";
  }
  if (!C.message.empty()) h << "<p class=bad>Closed form: " << htmlEscape(C.message) << "</p>";
  h << "<table><tr><th>target</th><th>A / B</th><th>relation</th><th>H [m]</th><th>y<sub>A</sub> [m]</th><th>D [m]</th>"
       "<th>Δ along [m]</th><th>Δ cross [m]</th><th>Δ down [m]</th><th>ICP RMS [m]</th></tr>";
  for (const FeaturePairOffset& p : pairs) {
    h << "<tr><td class=l>" << htmlEscape(p.target_id) << "</td><td class=l>" << htmlEscape(p.strip_a) << " / " << htmlEscape(p.strip_b)
      << "</td><td class=l>" << htmlEscape(p.relation) << "</td><td>" << cell(p.height_m, "%.2f") << "</td><td>"
      << cell(p.lateral_a_m, "%.2f") << "</td><td>" << cell(p.line_offset_m, "%.2f") << "</td><td>" << cell(p.offset_afd_m.x())
      << "</td><td>" << cell(p.offset_afd_m.y()) << "</td><td>" << cell(p.offset_afd_m.z()) << "</td><td>" << cell(p.icp_rms_m)
      << "</td></tr>";
  }
  h << "</table>";
  if (!rejected.empty()) {
    h << "<details open><summary>" << rejected.size()
      << " targets or strip views rejected</summary><table><tr><th>target</th><th>strip</th><th>reason</th></tr>";
    for (const RejectedFeature& r : rejected)
      h << "<tr><td class=l>" << htmlEscape(r.target_id) << "</td><td class=l>" << htmlEscape(r.strip_id) << "</td><td class=l>"
        << htmlEscape(r.reason) << "</td></tr>";
    h << "</table></details>";
  }
  if (!laser_intrinsics.empty()) h << detail::laserIntrinsicsHtml(laser_intrinsics, laserTitle(laser_intrinsics), "target points");
  return h.str();
}

std::vector<std::string> FeatureSection::doubts() const { return detail::laserIntrinsicsDoubts(laser_intrinsics); }

std::vector<std::string> FeatureSection::warnings() const {
  std::vector<std::string> w = doubts();
  if (!rejected.empty()) w.push_back(std::to_string(rejected.size()) + " targets or strip views rejected");
  return w;
}

}  // namespace mountcal
