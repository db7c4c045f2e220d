#pragma once
/// \file methods/control/control.hpp
/// Ground control (job key "gcps") with any method: each ground control point not already a
/// tie of method "vtpm" is picked at its plan position on every strip whose points cover it,
/// as a virtual tie point whose position has the GCP's coordinates as a prior
/// (methods/common/tie_observations.hpp). It runs whenever the job has such points; it is not
/// named in "method".

#include "mountcal/methods/common/tie_observations.hpp"
#include "mountcal/methods/method.hpp"
#include "mountcal/methods/common/virtual_tie_point.hpp"

namespace mountcal {

/// Options of ground control (job object "control"): the picks' stochastic model and the
/// virtual tie point's construction, as for method "vtpm".
struct ControlOptions : TiePickOptions {
  static constexpr const char* kMethod = "control";
};

/// The Summary section of ground control; result-file key "control".
struct ControlSection final : TieSection, MethodSection {
  std::string method() const override { return ControlOptions::kMethod; }
  std::string brief() const override;
  std::string text(const AdjustmentSummary& summary) const override;
  std::string resultJson(const AdjustmentSummary& summary) const override;
  std::string html(const AdjustmentSummary& summary) const override;
  std::vector<std::string> warnings() const override;
  int outliers() const override;
};

}  // namespace mountcal
