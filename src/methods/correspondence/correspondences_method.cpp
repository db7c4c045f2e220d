// Method "correspondences" as a module (methods/method.hpp): options, observations, section.
#include "correspondences_method.hpp"

#include <sstream>

#include "../common/laser_intrinsics.hpp"
#include "../common/section_format.hpp"

namespace mountcal {

namespace {

class CorrespondencesRun final : public MethodRun {
 public:
  explicit CorrespondencesRun(const MethodContext& c)
      : corr_(std::make_unique<CorrespondenceObservations>(c.data, std::any_cast<const CorrespondenceOptions&>(c.options), c.threads)) {}
  /// Always a source: it matches at each solve's mounting, so it may find observations later.
  std::vector<ObservationSource*> sources() override { return {corr_.get()}; }
  std::shared_ptr<const MethodSection> section() const override { return std::make_shared<CorrespondenceSection>(corr_->section()); }

 private:
  std::unique_ptr<CorrespondenceObservations> corr_;
};

const std::vector<OptionSpec>& correspondenceOptionSpecs() {
  using T = CorrespondenceOptions;
  static const std::vector<OptionSpec> specs =
      detail::laserPriorOptions(
          OptionTable<T>()
              .number(
                  "apriori_misalignment_m", [](T& o) -> double& { return o.apriori_misalignment_m; }, "m", 0, 1000,
                  "largest strip-to-strip discrepancy expected before calibration; grown from the data when the strips move further")
              .integer(
                  "max_misalignment_growths", [](T& o) -> int& { return o.max_misalignment_growths; }, 0, 20,
                  "how often the candidates may be found again with a grown a-priori misalignment")
              .number(
                  "radius_m", [](T& o) -> double& { return o.radius_m; }, "m", 0, 1000, "plane-fit radius r; 0: 2.5 x the point spacing")
              .number(
                  "sample_spacing_m", [](T& o) -> double& { return o.sample_spacing_m; }, "m", 0, 10000, "spacing of the samples; 0: 2 r")
              .integer(
                  "min_neighbours", [](T& o) -> int& { return o.min_neighbours; }, 3, 1000, "neighbours within r for a plane")
              .integer(
                  "max_neighbours", [](T& o) -> int& { return o.max_neighbours; }, 3, 1000, "neighbours used for the plane")
              .integer(
                  "normal_neighbours", [](T& o) -> int& { return o.normal_neighbours; }, 0, 1000,
                  "dense fine stage: neighbours the plane's normal is fitted from (its centroid from max_neighbours); 0: max_neighbours")
              .number(
                  "max_roughness_factor", [](T& o) -> double& { return o.max_roughness_factor; }, "-", 1e-9, 1e6,
                  "plane sigma above this x r: rough")
              .number(
                  "max_roughness_relative", [](T& o) -> double& { return o.max_roughness_relative; }, "-", 1, 1e6,
                  "plane sigma above this x the median: rough")
              .number(
                  "max_roughness_m", [](T& o) -> double& { return o.max_roughness_m; }, "m", 0, 10,
                  "plane sigma above this: rough (0: off; dense mode: fine stage; multi-beam jobs of a known range accuracy: 1.5 x it)")
              .number(
                  "max_distance_factor", [](T& o) -> double& { return o.max_distance_factor; }, "-", 1e-9, 1e6,
                  "|distance| above this x r: far")
              .number(
                  "max_normal_angle_deg", [](T& o) -> double& { return o.max_normal_angle_deg; }, "deg", 1e-6, 89.999,
                  "largest angle between the two strips' normals")
              .number(
                  "mad_factor", [](T& o) -> double& { return o.mad_factor; }, "-", 1e-9, 1e6,
                  "beyond this x sigma_MAD of the distances: rejected")
              .integer(
                  "budget", [](T& o) -> int& { return o.budget; }, 1, 10000000, "correspondences kept over all pairs")
              .number(
                  "voxel_size_m", [](T& o) -> double& { return o.voxel_size_m; }, "m", 0, 10000, "coarse hull voxel; 0: 4 r, at least 2 m")
              .number(
                  "sigma_m", [](T& o) -> double& { return o.sigma_m; }, "m", 0, 1e3, "a-priori sigma of a distance; 0: from the plane fits")
              .number(
                  "min_spread_ratio", [](T& o) -> double& { return o.min_spread_ratio; }, "-", 0, 0.999999,
                  "neighbourhoods along a line (one scan line) have no plane")
              .boolean(
                  "dense", [](T& o) -> bool& { return o.dense; }, "dense matching of passes of a multi-beam scanner over one object")
              .number(
                  "coarse_radius_m", [](T& o) -> double& { return o.coarse_radius_m; }, "m", 1e-6, 100, "dense mode's coarse stage radius")
              .number(
                  "thin_cell_m", [](T& o) -> double& { return o.thin_cell_m; }, "m", 0, 10,
                  "dense mode: one point per cube of this size; 0: every point"),
          "dense mode: ")
          .specs();
  return specs;
}

}  // namespace

std::string CorrespondencesMethod::description() const {
  return "automatic point-to-plane correspondences between every pair of overlapping strips, re-matched between solves (no user input)";
}
const std::vector<OptionSpec>& CorrespondencesMethod::options() const { return correspondenceOptionSpecs(); }
bool CorrespondencesMethod::validate(const std::any& options, std::string* error) const {
  return std::any_cast<const CorrespondenceOptions&>(options).IsValid(error);
}
void CorrespondencesMethod::adoptNoise(const NoiseHint& noise, std::any* options) const {
  std::any_cast<CorrespondenceOptions&>(*options).sigma_m = std::sqrt(2.0) * noise.point_sigma_m;  // two points' noise
}
std::unique_ptr<MethodRun> CorrespondencesMethod::run(const MethodContext& context) const {
  return std::make_unique<CorrespondencesRun>(context);
}

// ---- the section ------------------------------------------------------------------------------

std::string CorrespondenceSection::brief() const { return detail::printfString("%d correspondences (%d matchings); ", used, rounds); }

std::string CorrespondenceSection::text(const AdjustmentSummary&) const {
  std::ostringstream r;
  r << detail::printfString(
      "\nCorrespondences: %d used after %d matchings (r %.2f m, spacing %.2f m, sigma %.4f m); |distance| median %.4f -> %.4f m, "
      "RMS %.4f -> %.4f m\n",
      used, rounds, radius_m, spacing_m, sigma_m, median_before_m, median_after_m, rms_before_m, rms_after_m);
  if (misalignment_growths > 0)
    r << detail::printfString(
        "  The strips moved against each other beyond the a-priori misalignment: candidates found again %d time(s), "
        "for %.2f m\n",
        misalignment_growths, apriori_misalignment_m);
  r << "  pair        samples  kept  sparse rough  far normal  MAD budget moved   median before/after [m]   RMS before/after [m]\n";
  for (const CorrespondencePairStats& p : pairs) {
    r << detail::printfString("  %-5s %-5s %7d %5d %7d %5d %4d %6d %4d %6d %5d   %10.4f %10.4f   %10.4f %10.4f\n", p.strip_a.c_str(),
                              p.strip_b.c_str(), p.samples, p.kept, p.rejected_sparse, p.rejected_rough, p.rejected_far, p.rejected_normal,
                              p.rejected_mad, p.rejected_budget, p.rejected_moved, p.median_before_m, p.median_after_m, p.rms_before_m,
                              p.rms_after_m);
  }
  if (!laser_intrinsics.empty())
    r << detail::laserIntrinsicsText(
        laser_intrinsics,
        "Per-laser intrinsics (by laser id; added to the laser table; means of elevation, azimuth and vertical "
        "held at 0; sigma in the mounting's stochastic model):",
        "points");
  return r.str();
}

std::string CorrespondenceSection::resultJson(const AdjustmentSummary&) const {
  using nlohmann::json;
  json list = json::array();
  for (const CorrespondencePairStats& p : pairs) {
    list.push_back({{"strip_a", p.strip_a},
                    {"strip_b", p.strip_b},
                    {"samples", p.samples},
                    {"kept", p.kept},
                    {"rejected",
                     {{"sparse", p.rejected_sparse},
                      {"rough", p.rejected_rough},
                      {"far", p.rejected_far},
                      {"normal", p.rejected_normal},
                      {"mad", p.rejected_mad},
                      {"budget", p.rejected_budget},
                      {"moved", p.rejected_moved}}},
                    {"median_before_m", p.median_before_m},
                    {"rms_before_m", p.rms_before_m},
                    {"median_after_m", p.median_after_m},
                    {"rms_after_m", p.rms_after_m}});
  }
  json j;
  j["correspondences"] = {{"used", used},
                          {"matchings", rounds},
                          {"radius_m", radius_m},
                          {"spacing_m", spacing_m},
                          {"sigma_m", sigma_m},
                          {"median_before_m", median_before_m},
                          {"rms_before_m", rms_before_m},
                          {"median_after_m", median_after_m},
                          {"rms_after_m", rms_after_m},
                          {"search_time_s", search_time_s},
                          {"points_searched", points_searched},
                          {"apriori_misalignment_m", apriori_misalignment_m},
                          {"misalignment_growths", misalignment_growths},
                          {"pairs", list}};
  if (!laser_intrinsics.empty()) j["intrinsics"] = json::parse(detail::laserIntrinsicsJson(laser_intrinsics));
  return j.dump();
}

std::string CorrespondenceSection::html(const AdjustmentSummary&) const {
  using detail::cell;
  using detail::htmlEscape;
  std::ostringstream h;
  h << "<h2>Automatic correspondences</h2><p>" << used << " point-to-plane correspondences after " << rounds << " matchings (r "
    << cell(radius_m, "%.2f") << " m, point spacing " << cell(spacing_m, "%.2f") << " m, σ " << cell(sigma_m) << " m); |distance| median "
    << cell(median_before_m) << " → " << cell(median_after_m) << " m, RMS " << cell(rms_before_m) << " → " << cell(rms_after_m) << " m</p>";
  h << "<table><tr><th>strips</th><th>samples</th><th>kept</th><th>sparse</th><th>rough</th><th>far</th><th>normals</th><th>MAD</th>"
       "<th>budget</th><th>moved</th><th>median before [m]</th><th>median after [m]</th><th>RMS before [m]</th><th>RMS after [m]</th></tr>";
  for (const CorrespondencePairStats& p : pairs) {
    h << "<tr><td class=l>" << htmlEscape(p.strip_a) << " / " << htmlEscape(p.strip_b) << "</td><td>" << p.samples << "</td><td>" << p.kept
      << "</td><td>" << p.rejected_sparse << "</td><td>" << p.rejected_rough << "</td><td>" << p.rejected_far << "</td><td>"
      << p.rejected_normal << "</td><td>" << p.rejected_mad << "</td><td>" << p.rejected_budget << "</td><td>" << p.rejected_moved
      << "</td><td>" << cell(p.median_before_m) << "</td><td>" << cell(p.median_after_m) << "</td><td>" << cell(p.rms_before_m)
      << "</td><td>" << cell(p.rms_after_m) << "</td></tr>";
  }
  h << "</table>";
  if (!laser_intrinsics.empty()) h << detail::laserIntrinsicsHtml(laser_intrinsics, "Per-laser intrinsics", "points");
  return h.str();
}

int CorrespondenceSection::rejectedMoved() const {
  int n = 0;
  for (const CorrespondencePairStats& p : pairs) n += p.rejected_moved;
  return n;
}

std::vector<std::string> CorrespondenceSection::warnings() const {
  std::vector<std::string> w = doubts();
  if (const int rejected_moved = rejectedMoved(); rejected_moved > 0) {
    w.push_back(detail::printfString(
        "%d correspondence samples not used: the strips moved against each other beyond the a-priori misalignment of %.2f m that "
        "their candidate neighbourhoods were found for (%.2f m needed)%s",
        rejected_moved, apriori_misalignment_m, needed_misalignment_m,
        candidates_given ? "; match the pairs again (mountcal match) with correspondences.apriori_misalignment_m at least that"
                         : "; raise correspondences.apriori_misalignment_m or max_misalignment_growths"));
  }
  for (std::string& x : detail::laserImplausibleWarnings(laser_intrinsics.lasers)) w.push_back(std::move(x));
  return w;
}

std::vector<std::string> CorrespondenceSection::doubts() const { return detail::laserIntrinsicsDoubts(laser_intrinsics); }

LaserCorrections CorrespondenceSection::laserCorrections() const { return laser_intrinsics.lasers; }

}  // namespace mountcal
