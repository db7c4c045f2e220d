#pragma once
/// \file report.hpp
/// A self-contained HTML report of a calibration (tables and inline SVG plots).

#include <string>

#include "mountcal/job.hpp"

namespace mountcal {

/// The report as one HTML document: solver outcome, parameters with sigmas, observability,
/// correlations, per-observation residuals before/after (table and plot), rejected ties, and
/// check-data evaluation when given.
std::string htmlReport(const MountingCalibrator::Summary& summary, const ResultEvaluation* evaluation,
                       const std::string& title);

}  // namespace mountcal
