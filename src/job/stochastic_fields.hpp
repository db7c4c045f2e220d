#pragma once
/// \file stochastic_fields.hpp
/// The trajectory model of a job's or a plan's "stochastic" object (internal): the time offset
/// (`time_offset_sigma_s`, `estimate_time_offset`) and the per-strip trajectory corrections
/// (`corrections`), read into StochasticOptions with the file's messages.

#include "io/json_fields.hpp"
#include "mountcal/adjustment/mounting_adjustment.hpp"

namespace mountcal::detail {

/// Reads the keys above from `stochastic` (the caller lists the object's allowed keys); a key
/// left out keeps the value already in `options`.
void readTrajectoryModel(const Fields& stochastic, StochasticOptions* options);

}  // namespace mountcal::detail
