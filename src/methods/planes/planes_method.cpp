// Method "planes" as a module (methods/method.hpp): options, observations, Summary section.
#include "planes_method.hpp"

#include <sstream>

#include "../common/laser_intrinsics.hpp"
#include "../common/section_format.hpp"
#include "mountcal/core/rotation.hpp"
#include "mountcal/report/svg_plot.hpp"

namespace mountcal {

namespace {

class PlanesRun final : public MethodRun {
 public:
  explicit PlanesRun(const MethodContext& c)
      : planes_(std::make_unique<PlaneObservations>(c.data, std::any_cast<const PlaneOptions&>(c.options))) {}
  std::vector<ObservationSource*> sources() override {
    if (planes_->observationCount() == 0) return {};
    return {planes_.get()};
  }
  std::shared_ptr<const MethodSection> section() const override { return std::make_shared<PlaneSection>(planes_->section()); }
  std::string nothingUsable() const override {
    return "no usable plane patch: " + std::to_string(planes_->section().rejected.size()) +
           " patches or strip parts rejected (see rejected)";
  }

 private:
  std::unique_ptr<PlaneObservations> planes_;
};

const std::vector<OptionSpec>& planeOptionSpecs() {
  using T = PlaneOptions;
  static const std::vector<OptionSpec> specs =
      detail::laserPriorOptions(
          OptionTable<T>()
              .number(
                  "sigma_m", [](T& o) -> double& { return o.sigma_m; }, "m", 0, 1e3,
                  "a-priori sigma of a point-to-plane distance; 0: pooled from the patches' fits")
              .number(
                  "ransac_threshold_m", [](T& o) -> double& { return o.ransac_threshold_m; }, "m", 1e-6, 1e3,
                  "RANSAC inlier distance of a strip's plane in a region")
              .integer(
                  "ransac_iterations", [](T& o) -> int& { return o.ransac_iterations; }, 1, 100000, "RANSAC iterations")
              .integer(
                  "min_points_per_strip", [](T& o) -> int& { return o.min_points_per_strip; }, 3, 1000000,
                  "fewer inliers: the strip does not see the patch")
              .integer(
                  "max_points_per_strip", [](T& o) -> int& { return o.max_points_per_strip; }, 3, 1000000,
                  "inliers used per patch and strip (and laser, with per-laser offsets), evenly thinned")
              .number(
                  "max_normal_angle_deg", [](T& o) -> double& { return o.max_normal_angle_deg; }, "deg", 1e-6, 89.999,
                  "a strip's plane tilted more than this from the others' is another surface")
              .number(
                  "max_plane_offset_m", [](T& o) -> double& { return o.max_plane_offset_m; }, "m", 1e-6, 1e4,
                  "…or parallel but farther than this")
              .number(
                  "cell_size_m", [](T& o) -> double& { return o.cell_size_m; }, "m", 0, 1000,
                  "automatic patches: plan grid cell; 0: 5 x the point spacing, at least 1.5 m")
              .number(
                  "max_roughness_m", [](T& o) -> double& { return o.max_roughness_m; }, "m", 1e-6, 1e3,
                  "automatic patches: a cell is planar below this plane-fit sigma (doubled, at most twice, while fewer than three patches "
                  "are used)")
              .number(
                  "growing_angle_deg", [](T& o) -> double& { return o.growing_angle_deg; }, "deg", 1e-6, 89.999,
                  "automatic patches: region growing joins cells whose normals differ less")
              .number(
                  "edge_margin_m", [](T& o) -> double& { return o.edge_margin_m; }, "m", 0, 1000,
                  "automatic patches: a patch's box shrinks by this on every side")
              .number(
                  "max_patch_size_m", [](T& o) -> double& { return o.max_patch_size_m; }, "m", 1e-6, 10000,
                  "automatic patches: largest plan extent")
              .integer(
                  "max_patches", [](T& o) -> int& { return o.max_patches; }, 1, 100000,
                  "automatic patches: kept, spread over normal directions")
              .number(
                  "search_margin_m", [](T& o) -> double& { return o.search_margin_m; }, "m", 0, 100,
                  "points this close to a region are re-selected at each mounting"),
          "multi-beam strips with laser ids: ")
          .specs();
  return specs;
}

}  // namespace

std::string PlanesMethod::description() const {
  return "plane patches seen by two or more strips, one unknown plane per patch (Attune / Skaloud-Lichti); given regions or found "
         "automatically";
}
MethodInput PlanesMethod::input() const {
  return {"planes", "auto", "a regions CSV (plane_id,xmin,ymin,xmax,ymax), or \"auto\" to find the patches in the overlaps", true};
}
const std::vector<OptionSpec>& PlanesMethod::options() const { return planeOptionSpecs(); }
void PlanesMethod::adoptInput(const std::string& value, std::any* options) const {
  std::any_cast<PlaneOptions&>(*options).automatic = value == "auto";
}
bool PlanesMethod::validate(const std::any& options, std::string* error) const {
  return std::any_cast<const PlaneOptions&>(options).IsValid(error);
}
void PlanesMethod::adoptNoise(const NoiseHint& noise, std::any* options) const {
  std::any_cast<PlaneOptions&>(*options).sigma_m = noise.point_sigma_m;
}
std::unique_ptr<MethodRun> PlanesMethod::run(const MethodContext& context) const { return std::make_unique<PlanesRun>(context); }

// ---- the section ------------------------------------------------------------------------------

namespace {
double tiltDeg(const Vec3& n) { return rad2deg(std::acos(std::min(1.0, std::abs(n.z())))); }
double aspectDeg(const Vec3& n) { return std::fmod(rad2deg(std::atan2(n.x(), n.y())) + 360.0, 360.0); }
}  // namespace

std::string PlaneSection::brief() const { return detail::printfString("%d patches / %d points; ", patches_used, points_used); }

std::string PlaneSection::text(const AdjustmentSummary&) const {
  std::ostringstream r;
  r << detail::printfString("\nPlanes (%s): %d patches, %d points, sigma %.4f m; RMS before %.4f m, after %.4f m\n",
                            automatic ? "found automatically" : "given regions", patches_used, points_used, sigma_m, rms_before_m,
                            rms_after_m);
  if (roughness_growths > 0)
    r << detail::printfString(
        "  found with the cells' roughness bound grown to %.3f m (fewer than three patches used within %.3f m, max_roughness_m): the "
        "strips' own looks at a cell disagreed where they were searched\n",
        roughness_bound_m, roughness_bound_m / static_cast<double>(1 << roughness_growths));
  if (points_off_surface > 0)
    r << "  " << points_off_surface
      << " points set aside after a solve: off their patch's surface (beyond 5 x its robust scale, 2 sigma and "
         "ransac_threshold_m / 10; another surface within ransac_threshold_m)\n";
  if (patch_searches > 1) {
    r << "  found again " << patch_searches - 1 << (patch_searches == 2 ? " time" : " times")
      << " where the strips lay once a solve had moved them (beyond the roughness bound at the first solution, beyond the "
         "search margin after it); patches used (roughness bound):";
    for (std::size_t k = 0; k < search_bounds_m.size() && k < search_patches.size(); ++k)
      r << detail::printfString("%s %d (%.3f m)", k ? "," : "", search_patches[k], search_bounds_m[k]);
    r << "\n";
  }
  r << "  patch                 strips points  tilt[deg] aspect[deg]  RMS before [m]  after [m]\n";
  for (const PatchResidual& p : patches) {
    r << detail::printfString("  %-22s %5d %6d %9.1f %10.1f %15.4f %10.4f%s\n", p.patch_id.c_str(), p.strips, p.points, tiltDeg(p.normal),
                              aspectDeg(p.normal), p.rms_before_m, p.rms_after_m, p.outlier ? "  outlier" : "");
  }
  if (!laser_intrinsics.empty())
    r << detail::laserIntrinsicsText(
        laser_intrinsics,
        "Per-laser intrinsics (by laser id; added to the laser table; means of elevation, azimuth and vertical "
        "held at 0 over the lasers the patches use; sigma in the mounting's stochastic model):",
        "patch points");
  for (const RejectedPatch& p : rejected)
    r << "rejected patch " << p.patch_id << (p.strip_id.empty() ? "" : " on strip " + p.strip_id) << ": " << p.reason << "\n";
  return r.str();
}

std::string PlaneSection::resultJson(const AdjustmentSummary&) const {
  using nlohmann::json;
  json list = json::array();
  for (const PatchResidual& r : patches) {
    list.push_back({{"patch_id", r.patch_id},
                    {"centre_m", detail::vec3Json(r.centre_m)},
                    {"normal", detail::vec3Json(r.normal)},
                    {"points", r.points},
                    {"strips", r.strips},
                    {"rms_before_m", r.rms_before_m},
                    {"rms_after_m", r.rms_after_m},
                    {"outlier", r.outlier}});
  }
  json rej = json::array();
  for (const RejectedPatch& r : rejected) rej.push_back({{"patch_id", r.patch_id}, {"strip_id", r.strip_id}, {"reason", r.reason}});
  json j;
  j["planes"] = {
      {"automatic", automatic}, {"patches_used", patches_used}, {"points_used", points_used}, {"points_off_surface", points_off_surface},
      {"sigma_m", sigma_m},     {"rms_before_m", rms_before_m}, {"rms_after_m", rms_after_m}, {"patches", list},
      {"rejected", rej}};
  if (automatic) {
    j["planes"]["patch_searches"] = patch_searches;
    j["planes"]["roughness_bound_m"] = roughness_bound_m;
    j["planes"]["roughness_growths"] = roughness_growths;
    j["planes"]["search_bounds_m"] = search_bounds_m;
    j["planes"]["search_patches"] = search_patches;
  }
  // The intrinsics to use from now on (apply and evaluate read them), by laser id.
  if (!laser_intrinsics.empty()) j["intrinsics"] = json::parse(detail::laserIntrinsicsJson(laser_intrinsics));
  return j.dump();
}

std::string PlaneSection::html(const AdjustmentSummary&) const {
  using detail::cell;
  using detail::htmlEscape;
  std::ostringstream h;
  h << "<h2>Plane patches (" << (automatic ? "found automatically" : "given regions") << ")</h2><p>" << patches_used << " patches, "
    << points_used << " points, σ of a point-to-plane distance " << cell(sigma_m) << " m; RMS before " << cell(rms_before_m) << " m, after "
    << cell(rms_after_m) << " m</p>";
  std::vector<double> idx, b, a;
  for (std::size_t i = 0; i < patches.size(); ++i) {
    idx.push_back(static_cast<double>(i + 1));
    b.push_back(patches[i].rms_before_m);
    a.push_back(patches[i].rms_after_m);
  }
  if (!idx.empty()) {
    SvgLinePlot plot("RMS distance to the patch's plane, per patch", "patch", "RMS [m]");
    plot.addSeries("before", idx, b);
    plot.addSeries("after", idx, a);
    h << plot.render(900, 320);
  }
  h << "<table><tr><th>patch</th><th>strips</th><th>points</th><th>tilt [°]</th><th>aspect [°]</th><th>RMS before [m]</th>"
       "<th>RMS after [m]</th><th></th></tr>";
  for (const PatchResidual& r : patches) {
    h << "<tr><td class=l>" << htmlEscape(r.patch_id) << "</td><td>" << r.strips << "</td><td>" << r.points << "</td><td>"
      << cell(tiltDeg(r.normal), "%.1f") << "</td><td>" << cell(aspectDeg(r.normal), "%.1f") << "</td><td>" << cell(r.rms_before_m)
      << "</td><td>" << cell(r.rms_after_m) << "</td><td class=l>" << (r.outlier ? "<span class=bad>outlier</span>" : "") << "</td></tr>";
  }
  h << "</table>";
  if (!rejected.empty()) {
    h << "<details><summary>" << rejected.size()
      << " patches or strip parts rejected</summary><table><tr><th>patch</th><th>strip</th><th>reason</th></tr>";
    for (const RejectedPatch& r : rejected)
      h << "<tr><td class=l>" << htmlEscape(r.patch_id) << "</td><td class=l>" << htmlEscape(r.strip_id) << "</td><td class=l>"
        << htmlEscape(r.reason) << "</td></tr>";
    h << "</table></details>";
  }
  if (!laser_intrinsics.empty()) h << detail::laserIntrinsicsHtml(laser_intrinsics, "Per-laser intrinsics", "patch points");
  return h.str();
}

std::vector<std::string> PlaneSection::warnings() const {
  std::vector<std::string> w = doubts();
  if (!rejected.empty()) w.push_back(std::to_string(rejected.size()) + " plane patches or strip parts rejected");
  for (std::string& x : detail::laserImplausibleWarnings(laser_intrinsics.lasers)) w.push_back(std::move(x));
  return w;
}

std::vector<std::string> PlaneSection::doubts() const { return detail::laserIntrinsicsDoubts(laser_intrinsics); }

int PlaneSection::outliers() const {
  int n = 0;
  for (const PatchResidual& r : patches) n += r.outlier;
  return n;
}

std::vector<PlanMark> PlaneSection::planMarks() const {
  std::vector<PlanMark> out;
  for (const PatchResidual& p : patches) out.push_back({"patch " + p.patch_id, p.centre_m.x(), p.centre_m.y()});
  return out;
}

}  // namespace mountcal
