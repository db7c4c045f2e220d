#pragma once
/// \file job.hpp
/// The job module (SPEC §4): the typed job schema, loading (frames, strips, user input),
/// applying a mounting, and the result file. One header per concept under job/.

#include "mountcal/job/apply.hpp"
#include "mountcal/job/block.hpp"
#include "mountcal/job/load.hpp"
#include "mountcal/job/result.hpp"
#include "mountcal/job/schema.hpp"
#include "mountcal/job/survey_job.hpp"
