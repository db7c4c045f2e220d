#pragma once
/// \file job/apply.hpp
/// Applying a calibrated mounting to a job's strips (`mountcal apply`).

#include <cstdint>
#include <string>

#include "mountcal/job/schema.hpp"

namespace mountcal {

/// Statistics of an apply run.
struct ApplyStats {
  std::size_t strips = 0;
  std::uint64_t points = 0;
  double max_shift_m = 0.0;  ///< largest point displacement [m]
};

/// Rewrites every LAS strip of `job` into `out_dir` (same file names) with `mounting` in place
/// of `mounting_used`: each point is inverse-georeferenced with the used mounting and
/// georeferenced again with the new one, through the job's frame. Every other field, the VLRs,
/// EVLRs and extra bytes are kept; the strips are streamed in chunks of `chunk_points`, so
/// memory does not grow with the strip. Files are written through a temporary name. Throws
/// FileError (raw CSV strips cannot be rewritten; an output path equal to an input).
ApplyStats applyMounting(const Job& job, const MountingParameters& mounting, const std::string& out_dir,
                         std::size_t chunk_points = 1u << 20);

}  // namespace mountcal
