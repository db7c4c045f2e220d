#pragma once
// Internal to the tie-based modules (vtpm, control): what they share — their job options, declared
// once, and their result-file lists of rejected picks and residuals.

#include <nlohmann/json.hpp>

#include "mountcal/methods/common/tie_observations.hpp"
#include "section_format.hpp"
#include "mountcal/methods/method.hpp"
#include "mountcal/methods/common/virtual_tie_point.hpp"

namespace mountcal::detail {

/// The options of a module whose options struct T is a TieObservationOptions with a VtpOptions
/// `vtp` (VtpmOptions, ControlOptions). Ranges are physical: a virtual tie point is a local plane
/// of metres; picks are good to centimetres or metres, not kilometres.
template <class T>
OptionTable<T> tieOptionTable() {
  OptionTable<T> t;
  t.number(
      "radius_m", [](T& o) -> double& { return o.vtp.radius_m; }, "m", 0.01, 100.0,
      "search radius around a pick (grown to 2.5 x the point spacing, up to max_radius_m)");
  t.number(
      "max_radius_m", [](T& o) -> double& { return o.vtp.max_radius_m; }, "m", 0.01, 100.0,
      "the grown radius never exceeds this (nor shrinks below radius_m)");
  t.choice(
      "motion", [](T& o) -> VtpMotion& { return o.vtp.motion; }, {"auto", "triangle", "neighbourhood"},
      "how a pick moves with the mounting (Rule 2): its triangle's three pulses, or the mean of its neighbourhood's points "
      "(auto: the neighbourhood on a strip with laser ids)");
  t.number(
      "ransac_threshold_m", [](T& o) -> double& { return o.vtp.ransac_threshold_m; }, "m", 1e-4, 10.0,
      "largest point-to-plane distance of a RANSAC inlier");
  t.number(
      "tie_sigma_xy_m", [](T& o) -> double& { return o.tie_sigma_xy_m; }, "m", 1e-4, 100.0, "a-priori sigma of a pick, horizontal");
  t.number(
      "tie_sigma_z_m", [](T& o) -> double& { return o.tie_sigma_z_m; }, "m", 1e-4, 100.0,
      "a-priori sigma of a pick's height (Rule 1 interpolation)");
  t.boolean(
      "estimate_tie_sigma", [](T& o) -> bool& { return o.estimate_tie_sigma; },
      "estimate the two sigma above from the residuals (variance components)");
  return t;
}

/// The virtual tie point's construction settings, beyond their declared ranges.
inline bool vtpOptionsValid(const VtpOptions& v, std::string* error) {
  if (!(v.radius_m > 0) || !(v.ransac_threshold_m > 0) || v.ransac_iterations < 1) {
    if (error) *error = "vtp radius, RANSAC threshold and iterations must be positive";
    return false;
  }
  return true;
}

/// The result file's list of rejected picks, each named by `id_key` ("tie_id", "gcp_id").
inline nlohmann::json rejectedTiesJson(const std::vector<RejectedTie>& rejected, const char* id_key) {
  nlohmann::json out = nlohmann::json::array();
  for (const RejectedTie& r : rejected) out.push_back({{id_key, r.tie_id}, {"strip_id", r.strip_id}, {"reason", r.reason}});
  return out;
}

/// The result file's list of pick residuals before and after, each named by `id_key`.
inline nlohmann::json tieResidualsJson(const std::vector<TieResidual>& residuals, const char* id_key) {
  nlohmann::json out = nlohmann::json::array();
  for (const TieResidual& r : residuals) {
    out.push_back({{id_key, r.tie_id},
                   {"strip_id", r.strip_id},
                   {"before_m", vec3Json(r.before_m)},
                   {"after_m", vec3Json(r.after_m)},
                   {"outlier", r.outlier}});
  }
  return out;
}

}  // namespace mountcal::detail
