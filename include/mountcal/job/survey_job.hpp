#pragma once
/// \file job/survey_job.hpp
/// A simulated survey written as a ready job (SPEC §4 "Simulator output"): the job layer's part
/// of `mountcal simulate`; the simulator itself (simulation/) knows neither jobs nor methods.

#include <string>

#include "mountcal/simulation/survey.hpp"

namespace mountcal {

/// How a survey is written.
struct SurveyWriteOptions {
  /// Empty: a local-frame job (trajectory.csv, coordinates as simulated). Otherwise a CRS code
  /// ("EPSG:32611"): the simulated ENU frame is placed tangent to WGS84 under the CRS point
  /// (500000, 4000000), strips, ties, check data and GCPs are written in the CRS, the
  /// trajectory as trajectory.sbet (true heading, zero wander), and job.json says
  /// `"frame": {"type": "crs", ...}` — so the same survey can be calibrated both ways.
  std::string crs;
  /// Write ties.csv and a VTPM job. False: no ties file, and a job.json that calibrates
  /// automatically (method "correspondences").
  bool ties = true;
  /// Write the strips as LAZ (strip_ID.laz) instead of LAS.
  bool laz = false;
};

/// Throws InvalidInput for options writeSurvey refuses (a geographic CRS: strips are written in a
/// projected CRS in metres) — for a caller to check before it simulates.
void checkSurveyWriteOptions(const SurveyWriteOptions& options);

/// The id of the first strip of `survey` that holds no point (no ray met the ground: check the
/// mountings and the flight), or empty: a survey with such a strip calibrates nothing.
std::string stripWithoutPoints(const simulation::SimulatedSurvey& survey);

/// Writes the folder layout of SPEC §4: job.json, truth.json, trajectory.csv and
/// trajectory.sbet (a local job's ENU frame placed under UTM 11 N's (500000, 4000000)),
/// strip_<id>.las (LAS 1.4, point format 6, GPS week seconds), raw_<id>.csv, ties.csv,
/// check_points.csv, check_planes.csv, planes.csv (the roof faces, for the plane method), gcps.csv. Creates `dir` if needed. Throws
/// FileError, or InvalidInput for an unknown CRS.
void writeSurvey(const simulation::SimulatedSurvey& survey, const std::string& dir, const SurveyWriteOptions& options = {});

}  // namespace mountcal
