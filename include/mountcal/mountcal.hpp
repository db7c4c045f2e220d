#pragma once
/// \file mountcal.hpp
/// Umbrella header: the whole public API of mountcal.

#include "mountcal/error.hpp"
#include "mountcal/error_curves.hpp"
#include "mountcal/evaluation.hpp"
#include "mountcal/georeference_model.hpp"
#include "mountcal/io/atomic_file.hpp"
#include "mountcal/io/csv.hpp"
#include "mountcal/io/las.hpp"
#include "mountcal/job.hpp"
#include "mountcal/mounting.hpp"
#include "mountcal/mounting_calibrator.hpp"
#include "mountcal/observations.hpp"
#include "mountcal/report.hpp"
#include "mountcal/rotation.hpp"
#include "mountcal/sensor_model.hpp"
#include "mountcal/simulation/scene.hpp"
#include "mountcal/simulation/survey.hpp"
#include "mountcal/svg_plot.hpp"
#include "mountcal/trajectory.hpp"
#include "mountcal/version.hpp"
#include "mountcal/virtual_tie_point.hpp"
