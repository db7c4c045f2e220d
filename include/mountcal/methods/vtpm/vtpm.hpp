#pragma once
/// \file methods/vtpm/vtpm.hpp
/// Method "vtpm": the first paper's virtual tie points (seed 000, SPEC §3) — the user's tie
/// picks (job key "ties"), each turned into a virtual tie point per strip and observed by the
/// one adjustment (methods/common/tie_observations.hpp). Ground control points with a tie's id
/// become priors on that tie's position.

#include "mountcal/methods/common/tie_observations.hpp"
#include "mountcal/methods/method.hpp"
#include "mountcal/methods/common/virtual_tie_point.hpp"

namespace mountcal {

/// Options of method "vtpm" (job object "vtpm"): the tie's stochastic model and the virtual
/// tie point's construction.
struct VtpmOptions : TiePickOptions {
  static constexpr const char* kMethod = "vtpm";
};

/// The Summary section of method "vtpm" (seed Table 1); result-file keys "ties",
/// "rms_before_m", "rms_after_m", "residuals" (SPEC §4).
struct VtpmSection final : TieSection, MethodSection {
  std::string method() const override { return VtpmOptions::kMethod; }
  std::string brief() const override;
  std::string text(const AdjustmentSummary& summary) const override;
  std::string resultJson(const AdjustmentSummary& summary) const override;
  std::string html(const AdjustmentSummary& summary) const override;
  std::vector<std::string> warnings() const override;
  int outliers() const override;
  std::vector<PlanResidual> planResiduals(const CalibrationData& data) const override;
};

}  // namespace mountcal
