#pragma once
/// \file methods/correspondence/correspondences.hpp
/// Automatic point-to-plane correspondences between overlapping strips, as in OPALS
/// StripAdjust (Glira, Pfeifer, Briese, Ressl 2015): no user input, re-matched between solves.
///
/// For every pair of strips (A, B) whose coarse voxel hulls overlap, points of A are sampled
/// uniformly in the overlap (spacing ≈ 2r); each sample's neighbours in B are fitted by a plane
/// (≥ 8 points in radius r). A candidate is rejected when B's plane is rough (σ > 0.2 r), when
/// the sample is far from it (> 3 r in the first round), when A's own local normal differs by
/// more than 10°, or when its distance lies beyond 3 σ_MAD of all distances; then normal-space
/// thinning keeps a budget spread over normal directions. Each correspondence is one residual
///
///   r = n_B · ( (x_A(M) + o_A) − (x̄_B(M) + o_B) ) / σ
///
/// with x̄_B the centroid of B's neighbours, every point georeferenced with SPEC §2 eq. 1 (in
/// its exact form relative to the mounting used), n_B held within a round, as a
/// `ceres::NumericDiffCostFunction<…, ceres::CENTRAL, 1, 6, 3, 3>`.

#include <algorithm>
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "mountcal/adjustment/mounting_adjustment.hpp"
#include "mountcal/data.hpp"
#include "mountcal/methods/method.hpp"
#include "mountcal/methods/common/laser_priors.hpp"

namespace mountcal {

namespace detail {
class Matcher;
class DenseMatcher;
struct LaserLayout;
}  // namespace detail

/// Settings of the correspondence search. Every length has a default derived from the point
/// spacing and the a-priori misalignment when left at 0 [m, deg].
/// Dense mode, multi-beam strips with laser ids (StripData::laser): the per-laser intrinsics'
/// priors (LaserIntrinsicsPriors) — the sparse correspondences estimate none.
struct CorrespondenceOptions : LaserIntrinsicsPriors {
  static constexpr const char* kMethod = "correspondences";
  /// The largest strip-to-strip discrepancy expected before calibration [m] (first-round
  /// distance gate: max(3 r, 2 × this)); also the margin of each sample's candidate
  /// neighbourhood (PairCandidates). A start, not a limit: when a matching finds that the strips
  /// have moved against each other beyond it (a sample's neighbours at the current mounting
  /// reach past what its candidates hold), the candidates are found again with a margin grown
  /// from what the data showed — at most `max_misalignment_growths` times; candidates given as
  /// pair files cannot grow (those samples are rejected, and the section warns).
  double apriori_misalignment_m = 1.0;
  /// How often the candidates may be found again with a grown misalignment [-].
  int max_misalignment_growths = 4;
  double radius_m = 0.0;              ///< r, the plane-fit radius; 0: 2.5 × the point spacing [m]
  double sample_spacing_m = 0.0;      ///< 0: 2 r [m]
  int min_neighbours = 8;             ///< in radius r [-]
  double max_roughness_factor = 0.2;  ///< plane σ > this × r: rough [-]
  /// …or plane σ > this × the median σ of all candidates (at least 5 mm): rough, as across a
  /// ridge, an eave or a wall edge [-].
  double max_roughness_relative = 4.0;
  /// …or plane σ > this (0: no such bound; dense mode: its fine stage only) [m]. The sensor's own
  /// noise bounds a plane fit's σ whatever the radius, so a larger one is roughness; a job of a
  /// named multi-beam model (VLP-16, HDL-32E) takes 1.5 × its range accuracy by default — the
  /// 97.5 % point of the σ of a plane fitted to 10 points of that noise (√(χ²₇,0.975 / 7) = 1.51).
  double max_roughness_m = 0.0;
  /// The largest plane σ a neighbourhood of radius r may have: max_roughness_factor × r, and
  /// max_roughness_m when set and `absolute` [m].
  double maxPlaneSigma(double r, bool absolute = true) const {
    return absolute && max_roughness_m > 0 ? std::min(max_roughness_factor * r, max_roughness_m) : max_roughness_factor * r;
  }
  double max_distance_factor = 3.0;    ///< |distance| > this × r: far [-]
  double max_normal_angle_deg = 10.0;  ///< [deg]
  double mad_factor = 3.0;             ///< beyond this × σ_MAD of the distances: rejected [-]
  int budget = 3000;                   ///< correspondences kept over all pairs [-]
  double voxel_size_m = 0.0;           ///< coarse hull voxel; 0: 4 r, at least 2 m [m]
  /// A-priori σ of a correspondence distance [m]; 0: from the neighbourhoods' plane fits.
  double sigma_m = 0.0;
  int max_neighbours = 16;  ///< neighbours used for B's plane [-]
  /// Dense mode's fine stage: B's plane normal from this many of B's nearest points, its centroid
  /// (where the distance is taken) from the `max_neighbours` nearest; 0 or fewer than
  /// max_neighbours: both from max_neighbours. A normal from ten points on one or two of a
  /// multi-beam scanner's rings tilts with their noise, and the distance of a sample between
  /// the rings takes that tilt times its offset from the centroid — an error every sample there
  /// shares, which the per-laser elevation offsets absorb (docs/model-and-methods.md) [-].
  int normal_neighbours = 30;
  /// A neighbourhood whose points lie along a line (√(λ_mid/λ_max) below this: one scan line of
  /// a multi-beam scanner) has no plane: rejected as rough [-].
  double min_spread_ratio = 0.1;
  /// Dense matching, for passes of a dense multi-beam scanner over one object (a UAV over a
  /// truck): both directions of every strip pair (each strip's points on the other's planes),
  /// every point a candidate (evenly strided to `budget` per direction), k-d trees of the
  /// points at the current estimate (mounting and intrinsics) in every round, and two stages:
  ///  - coarse, until the mounting stops moving (< 1 mm, 1e-4 rad) or for 6 rounds: the
  ///    plane of the 30 nearest within `coarse_radius_m`, σ ≤ max_roughness_factor ×
  ///    coarse radius, normals within 2 × max_normal_angle_deg, budget / 4 samples, distance gate
  ///    2 × apriori_misalignment_m, robust loss bending at 0.3 × coarse radius;
  ///  - fine: the plane of the `max_neighbours` nearest, spread ≤ radius_m (√λ_max), σ ≤
  ///    max_roughness_factor × radius_m, √(λ_mid/λ_max) ≥ min_spread_ratio for both strips'
  ///    planes, normals within max_normal_angle_deg, a distance gate starting at
  ///    max_distance_factor × radius_m and shrinking to max(r/2, 10 σ_MAD), the solver's loss;
  ///    at most 6 fine matchings, then the last matches are kept until the solve settles.
  /// The residual is exact (no linearisation about the mounting used), with analytic
  /// derivatives.
  bool dense = false;
  double coarse_radius_m = 1.0;  ///< dense mode's coarse stage [m]
  /// Dense mode: strips are thinned to one point per cube of this size before matching (the
  /// first in file order); 0: every point [m].
  double thin_cell_m = 0.0;
  bool IsValid(std::string* error) const;
};

/// One correspondence: a sample of strip A and the local plane of strip B.
struct Correspondence {
  int strip_a = 0, strip_b = 0;       ///< indices into CalibrationData::strips
  std::size_t point_a = 0;            ///< the sample in A
  std::vector<std::size_t> points_b;  ///< B's neighbours (the plane)
  Vec3 normal = Vec3::UnitZ();        ///< B's plane normal at the matching mounting [-]
  double distance_m = 0.0;            ///< signed point-to-plane distance at the matching mounting [m]
  double roughness_m = 0.0;           ///< σ of B's plane fit [m]
};

/// Statistics of one strip pair.
struct CorrespondencePairStats {
  std::string strip_a, strip_b;
  int samples = 0;  ///< samples of A in the overlap
  int kept = 0;     ///< after every rejection and the budget
  int rejected_sparse = 0, rejected_rough = 0, rejected_far = 0, rejected_normal = 0, rejected_mad = 0, rejected_budget = 0;
  /// Samples whose neighbours at this matching's mounting reach past the candidates found at the
  /// mounting used (the strips moved against each other beyond the a-priori misalignment): their
  /// neighbourhood may miss points of the strip, so they are not used [-].
  int rejected_moved = 0;
  double median_before_m = 0, rms_before_m = 0;  ///< |distance| at M_used [m]
  double median_after_m = 0, rms_after_m = 0;    ///< at M̂ with the strip offsets [m]
};

/// What findCorrespondences returns.
struct CorrespondenceSet {
  std::vector<Correspondence> correspondences;
  std::vector<CorrespondencePairStats> pairs;  ///< every pair whose hulls overlap
  double radius_m = 0.0;                       ///< r used: the largest over the pairs (each pair: 2.5 × its coarser spacing) [m]
  double spacing_m = 0.0;                      ///< point spacing measured [m]
  double sigma_m = 0.0;                        ///< σ of a distance [m]
  double max_distance_m = 0.0;                 ///< largest distance gate used [m]
  /// The a-priori misalignment that would have held every rejected_moved sample's neighbourhood
  /// (0 when none was rejected so) [m].
  double needed_misalignment_m = 0.0;
  double seconds = 0.0;             ///< wall time [s]
  std::size_t points_searched = 0;  ///< strip points in overlap hulls (throughput) [-]
};

/// The correspondences of every overlapping strip pair at `mounting` (MountingIndex order
/// [m, rad]). `first_round`: the gates of a first matching before calibration (distance gate
/// max(3 r, 2 × the a-priori misalignment), no MAD rejection); otherwise 3 r and 3 σ_MAD.
/// `threads`: the pairs are searched on this many threads (0: every core); the result does
/// not depend on it. Throws InvalidInput for invalid options or strips.
CorrespondenceSet findCorrespondences(const CalibrationData& data, const std::array<double, 6>& mounting,
                                      const CorrespondenceOptions& options, bool first_round = true, int threads = 0);

/// A point of a strip pair's candidate neighbourhoods, with what a matching at any mounting
/// needs: its position at the mounting used, the IMU attitude that measured it and its laser
/// vector (SPEC §2 eq. 1: x(M) = x0 + R_mb (ΔR_bs r_s + Δa_b)).
struct PairPoint {
  std::uint64_t index = 0;       ///< the point's index in its strip
  double time_s = 0.0;           ///< its time [s]
  Vec3 x0_m = Vec3::Zero();      ///< at the mounting used [m]
  Mat3 R_mb = Mat3::Identity();  ///< body to mapping frame: the pose at time_s (or the point's own pose) [-]
  Vec3 r_s_m = Vec3::Zero();     ///< laser vector in the scanner frame [m]
};

/// The candidate neighbourhoods of one strip pair (A, B), found from the two strips alone at
/// the mounting used — the part of the correspondence search that does not depend on the
/// mounting, and the work of one `mountcal match` job. For every sample of A in the pair's
/// overlap: A's local plane there (normal and spread of its max_neighbours nearest within r, at
/// the mounting used; A's points move together, so it holds at any mounting up to the
/// mounting's rotation, well inside the normal-angle gate); and every point of B that a later
/// matching can take as a neighbour of a sample — within the distance of the sample's
/// max_neighbours-th nearest point of B plus `apriori_misalignment_m`. Every matching searches
/// these points of B as the whole search would search all of B's, so a calibration from these
/// sets (CalibrationData::correspondence_candidates) equals one that searched the strips itself,
/// and both find the neighbours the full strips would give while A and B move against each
/// other by less than the a-priori misalignment.
struct PairCandidates {
  std::string strip_a, strip_b;                 ///< strip ids
  bool overlap = false;                         ///< the pair's coarse voxel hulls meet
  bool attitudes_stored = false;                ///< per-point poses: R_mb is data, not the trajectory's at time_s
  double radius_m = 0.0;                        ///< r of the pair [m]
  double spacing_a_m = 0.0, spacing_b_m = 0.0;  ///< each strip's point spacing [m]
  std::uint64_t overlap_points = 0;             ///< A's and B's points in the overlap hulls
  int sparse_samples = 0;                       ///< samples with fewer than min_neighbours points near them (rejected as sparse)
  std::vector<PairPoint> samples_a;             ///< the samples of A
  std::vector<Vec3> normal_a;                   ///< A's plane normal at each sample [-]
  std::vector<double> spread_a;                 ///< √(λ_mid/λ_max) of A's plane at each sample [-]
  std::vector<PairPoint> points_b;              ///< B's points near the samples, in strip order
  std::size_t samples() const { return samples_a.size() + static_cast<std::size_t>(sparse_samples); }
  /// R_mb of every point from `trajectory` at its time (pair files of trajectory jobs store the
  /// time, not the attitude).
  void attitudesFrom(const Trajectory& trajectory);
};

/// Strip pairs (a < b, strip order) worth searching: their points' bounding boxes, grown by
/// twice the pair's voxel, meet. A superset of the pairs whose hulls overlap.
std::vector<std::pair<int, int>> candidateStripPairs(const CalibrationData& data, const CorrespondenceOptions& options);

/// The candidate neighbourhoods of strips `a` and `b` of `data` (indices, a ≠ b). Throws
/// InvalidInput for invalid options or strips.
PairCandidates findPairCandidates(const CalibrationData& data, int a, int b, const CorrespondenceOptions& options);

/// The matching options a pair file records: a solve refuses candidates found with others.
bool sameMatchingOptions(const CorrespondenceOptions& x, const CorrespondenceOptions& y);

/// Pair files (`mountcal match --out`): PairCandidates in a documented little-endian binary
/// format (README "Correspondence pair files"), with the matching options and the mounting
/// used they were found with. Every double is stored exactly. Written through a temporary
/// name; reading throws FileError naming the file and the byte offset where it went wrong.
void writePairCandidates(const std::string& path, const PairCandidates& pair, const CorrespondenceOptions& options,
                         const std::array<double, 6>& mounting_used);
PairCandidates readPairCandidates(const std::string& path, CorrespondenceOptions* options = nullptr,
                                  std::array<double, 6>* mounting_used = nullptr);
/// The same from bytes in memory (`name` for messages; the fuzz target's entry).
PairCandidates parsePairCandidates(const std::string& name, const std::uint8_t* data, std::size_t size,
                                   CorrespondenceOptions* options = nullptr, std::array<double, 6>* mounting_used = nullptr);

/// The residual section of the correspondences.
struct CorrespondenceSection : MethodSection {
  std::string method() const override { return "correspondences"; }
  std::string brief() const override;
  std::string text(const AdjustmentSummary& summary) const override;
  std::string resultJson(const AdjustmentSummary& summary) const override;
  std::string html(const AdjustmentSummary& summary) const override;
  std::vector<std::string> warnings() const override;
  /// Per-laser parameters estimated beyond kLaserPriorDoubt times their prior σ (one sentence
  /// naming them): the data pull them where the prior says a sensor's table is not off — they
  /// absorb another error (the poses, the mounting, a wrong matching) or the table is wrong.
  std::vector<std::string> doubts() const override;
  LaserCorrections laserCorrections() const override;
  int used = 0;
  int rounds = 0;  ///< matchings
  double radius_m = 0.0, sigma_m = 0.0, spacing_m = 0.0;
  std::vector<CorrespondencePairStats> pairs;
  double median_before_m = 0, rms_before_m = 0, median_after_m = 0, rms_after_m = 0;  ///< |distance| [m]
  double search_time_s = 0;                                                           ///< all matchings [s]
  std::size_t points_searched = 0;
  /// The a-priori misalignment the last candidates were found with: the option's, or grown from
  /// the data (`misalignment_growths` times) [m].
  double apriori_misalignment_m = 0.0;
  int misalignment_growths = 0;
  bool candidates_given = false;       ///< pair files (cannot grow)
  double needed_misalignment_m = 0.0;  ///< the last matching's CorrespondenceSet::needed_misalignment_m [m]
  /// The last matching's samples rejected as moved (CorrespondencePairStats::rejected_moved), over all pairs.
  int rejectedMoved() const;
  /// Dense mode with per-laser intrinsics: per laser id the estimates, their σ (NaN for a group
  /// not estimated or a laser no used correspondence saw), the priors, the used correspondences'
  /// points per laser (A's and B's), each laser's largest |correlation| with a boresight angle,
  /// and the correlation screening.
  LaserIntrinsicEstimates laser_intrinsics;
};

class CorrespondenceObservations final : public ObservationSource {
 public:
  /// Throws InvalidInput for invalid options or inconsistent strips.
  /// `threads`: the searches run on this many threads (0: every core); results do not depend on it.
  CorrespondenceObservations(const CalibrationData& data, const CorrespondenceOptions& options, int threads = 0);
  ~CorrespondenceObservations() override;

  std::string kind() const override { return "correspondences"; }
  bool rematches() const override { return true; }
  void addBlocks(const std::array<double, 6>& mounting, AdjustmentProblem* problem) override;
  void finish(const std::array<double, 6>& mounting_used, const std::array<double, 6>& mounting, const AdjustmentProblem& problem,
              const AnalysisOptions& analysis) override;
  bool settled() const override;
  void solved(const AdjustmentProblem& problem) override;
  const CorrespondenceSection& section() const { return section_; }
  const CorrespondenceSet& lastMatching() const { return set_; }

 private:
  const CalibrationData& data_;
  CorrespondenceOptions options_;
  int threads_ = 0;
  CorrespondenceSet set_;
  std::vector<int> blocks_;
  std::unique_ptr<detail::Matcher> matcher_;
  // A matching at `mounting`, the candidates found again with a grown a-priori misalignment
  // while the strips have moved against each other beyond it.
  void matchGrowing(const std::array<double, 6>& mounting);
  std::unique_ptr<detail::DenseMatcher> dense_;
  double* laser_block_ = nullptr;  // this round's per-laser intrinsics block (dense mode; detail::LaserLayout)
  std::vector<double> laser_dl_;   // its values, carried from solve to solve [rad, m]
  PointShifts shifts_;             // the last solve's strip offsets, corrections and time offset
  bool coarse_ = true;
  std::array<double, 6> last_{};
  double fine_gate_m_ = 0.0;
  int fine_rounds_ = 0;
  void addDenseBlocks(const std::array<double, 6>& mounting, AdjustmentProblem* problem);
  detail::LaserLayout laserLayout() const;  // of the dense matcher's lasers and the options
  void fillLaserSection(const AdjustmentProblem& problem);
  void finishDense(const std::array<double, 6>& mounting_used, const std::array<double, 6>& mounting, const AdjustmentProblem& problem,
                   const AnalysisOptions& analysis);
  // The section's distances: before as given (each correspondence's at the mounting used),
  // after from the residuals.
  void fillSection(const AdjustmentProblem& problem, const std::vector<double>& distance_before_m);
  CorrespondenceSection section_;
};

}  // namespace mountcal
