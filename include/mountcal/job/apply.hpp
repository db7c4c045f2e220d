#pragma once
/// \file job/apply.hpp
/// Applying a calibrated mounting to a job's strips (`mountcal apply`).

#include <cstdint>
#include <string>

#include "mountcal/job/schema.hpp"

namespace mountcal {

/// Statistics of an apply run.
struct ApplyStats {
  std::size_t strips = 0;  ///< input files rewritten (several strips may share one file)
  std::uint64_t points = 0;
  double max_shift_m = 0.0;  ///< largest point displacement [m]
};

/// The file format `applyMounting` writes: the input's (a LAZ input gives a LAZ output), or
/// LAS or LAZ whatever the input (the output then takes the extension .las or .laz).
enum class StripFormat { same_as_input, las, laz };

/// Rewrites every LAS or LAZ file of `job`'s strips into `out_dir` (same file names, or the extension of `format`; one output per
/// input file, even when several strips are split from one file, and every record of it) with
/// `mounting` in place of `mounting_used`: each point is inverse-georeferenced with the used
/// mounting and georeferenced again with the new one, at its pose (the trajectory at its time,
/// or its per-point pose), through the job's frame. Every other field, the VLRs, EVLRs and
/// extra bytes are kept byte for byte; the files are streamed in chunks of `chunk_points`, so
/// memory does not grow with the strip. All outputs are written under temporary names and placed
/// together at the end (io::placeFilesAtomically): a run that fails leaves every file in
/// `out_dir` as it was, earlier outputs included. Throws
/// FileError, before anything is written, for raw CSV strips (they cannot be rewritten), two
/// inputs with the same file name, or an output that would be one of the job's inputs
/// (`jobInputPaths`) or of `also_inputs` (e.g. the result file read).
/// `lasers` (by laser id, a result's intrinsics) corrects each laser vector by its laser's
/// intrinsics (correctLaserVector) before georeferencing; it needs the job's `sensor.laser_field`.
/// `threads`: files rewritten at once (0: every core); each file's bytes do not depend on it.
ApplyStats applyMounting(const Job& job, const MountingParameters& mounting, const std::string& out_dir,
                         std::size_t chunk_points = 1u << 20, const LaserCorrections& lasers = {},
                         StripFormat format = StripFormat::same_as_input, const std::vector<std::string>& also_inputs = {},
                         int threads = 0);

}  // namespace mountcal
