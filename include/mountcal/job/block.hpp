#pragma once
/// \file job/block.hpp
/// A block's correspondence calibration split into jobs for a workflow engine (README
/// "A block on Snakemake"): the strip pairs to match, one pair's candidate neighbourhoods from
/// its two strips alone, and a solve from the pair files. A solve from the files gives the
/// same mounting, to the last bit, as `calibrate` searching the strips itself.

#include <string>
#include <utility>
#include <vector>

#include "mountcal/job/load.hpp"
#include "mountcal/job/schema.hpp"
#include "mountcal/methods/correspondence/correspondences.hpp"

namespace mountcal {

/// The strip pairs (ids, job order) whose files' plan bounding boxes (LAS headers), grown by a
/// margin of max(25 m, 4 coarse voxels estimated from the header's point density), meet: a
/// superset of the pairs whose overlap the correspondence search finds. Reads headers only.
/// Throws FileError for unreadable strips, or a job whose method is not "correspondences" alone.
std::vector<std::pair<std::string, std::string>> jobStripPairs(const Job& job);

/// The job with only the strips `ids` (in that order) and the trajectory or poses: ties, GCPs,
/// plane regions, targets and check data left out — what a per-pair or per-strip job reads.
/// Throws FileError for an unknown strip id or one named twice.
Job jobWithStrips(const Job& job, const std::vector<std::string>& ids);

/// The candidate neighbourhoods of the job's strips `a` and `b` (ids, either order: the result
/// is in job order), loading only those two strips and the trajectory. Throws FileError for an
/// unknown strip id and everything loadJob throws.
PairCandidates jobPairCandidates(const Job& job, const std::string& a, const std::string& b);

/// The pair files (`*.mcpair`) in `dir`, sorted by name. Throws FileError naming `dir` when it
/// is not a folder or cannot be listed.
std::vector<std::string> pairFilesIn(const std::string& dir);

/// What a solve from pair files needs: the trajectory and frame, the strips by id (no points),
/// and every pair file (`*.mcpair`) in `dir` as CalibrationData::correspondence_candidates.
/// Throws FileError naming the file for a corrupt pair file, one matched with other options or
/// another mounting than the job's, two files of one pair, and naming `dir` for a pair of
/// jobStripPairs without its file.
LoadedJob loadJobFromPairFiles(const Job& job, const std::string& dir);

}  // namespace mountcal
