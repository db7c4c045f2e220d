#pragma once
/// \file methods/planes/plane_observations.hpp
/// Plane-based calibration (the principle of Leica Attune, after Skaloud & Lichti 2006, that
/// the first paper compares VTPM with): planar patches seen by two or more strips, one unknown
/// plane per patch, and a point-to-plane residual per strip point used.
///
/// Each patch's plane is a nuisance block (unit normal on the sphere + offset, relative to the
/// patch's centre), eliminated in the observability analysis like tie positions. Each strip
/// point j of strip i in the patch gives
///
///   r = ( n̂ · (x_j(M) + o_i − c) − d ) / σ,   x_j(M) = p_m(t_j) + R_mb(t_j) (R_bs(M) r_s + a_b)
///
/// (SPEC §2 eq. 1, evaluated relative to the point's position at the mounting used, which is
/// exact) as a `ceres::NumericDiffCostFunction<…, ceres::CENTRAL, 1, 6, 4, 3>`. With per-laser
/// intrinsics θ_l (LaserIntrinsicsPriors) a multi-beam point's laser vector is corrected first,
/// exactly, as apply corrects it: r_s' = LaserCorrector(θ_l)(r_s).

#include <memory>
#include <string>
#include <vector>

#include "mountcal/adjustment/mounting_adjustment.hpp"
#include "mountcal/data.hpp"
#include "mountcal/methods/method.hpp"
#include "mountcal/methods/common/laser_priors.hpp"

namespace mountcal {

namespace detail {
class LaserIntrinsicsBlock;
}

/// Settings of the plane method. Lengths [m], angles [deg].
/// Multi-beam strips with laser ids: the per-laser intrinsics' priors (LaserIntrinsicsPriors),
/// estimated with the mounting from the patch points (a patch point's laser vector corrected
/// exactly, LaserCorrector).
struct PlaneOptions : LaserIntrinsicsPriors {
  static constexpr const char* kMethod = "planes";
  /// Find the patches in the overlaps automatically (job: `"planes": "auto"`) instead of
  /// taking CalibrationData::plane_regions.
  bool automatic = false;
  /// A-priori standard deviation of a point-to-plane distance [m]; 0: pooled from the patches'
  /// own plane fits (robust median of their σ).
  double sigma_m = 0.0;
  /// RANSAC inlier distance when a strip's points in a region are fitted by a plane [m].
  double ransac_threshold_m = 0.10;
  int ransac_iterations = 200;
  int min_points_per_strip = 10;  ///< fewer inliers: the strip does not see the patch
  /// Inliers used per patch and strip (and laser, when per-laser intrinsics are
  /// estimated), evenly thinned.
  int max_points_per_strip = 24;
  /// A strip's plane that differs from the other strips' by more than this is another surface.
  double max_normal_angle_deg = 10.0;
  /// …or parallel to it but farther than this (a flat roof and the ground beside it) [m].
  double max_plane_offset_m = 1.5;
  // ---- automatic patches ----------------------------------------------------------------
  /// Plan grid cell of the search [m]; 0: 5 × the point spacing, at least 1.5 m.
  double cell_size_m = 0.0;
  /// A cell is planar on a strip when its points' plane fit σ is below this [m].
  double max_roughness_m = 0.05;
  /// Region growing joins cells whose normals differ by less than this [deg].
  double growing_angle_deg = 5.0;
  /// A found patch's box is shrunk by this on every side (at most a quarter of its size) [m].
  double edge_margin_m = 1.0;
  double max_patch_size_m = 10.0;  ///< a patch's plan extent is capped (flat ground splits) [m]
  int max_patches = 120;           ///< kept, spread over normal directions (normal-space)
  /// Points within this of a region are candidates: as the mounting changes, the points in
  /// each region are selected again (RANSAC at the current mounting) between solves [m].
  double search_margin_m = 3.0;
  bool IsValid(std::string* error) const;
};

/// One patch in the adjustment: its plane and how well the strips agree on it.
struct PatchResidual {
  std::string patch_id;
  Vec3 centre_m = Vec3::Zero();  ///< [m]
  Vec3 normal = Vec3::UnitZ();   ///< unit normal, upwards [-]
  int points = 0;                ///< point-to-plane residuals
  int strips = 0;                ///< strips that see it
  double rms_before_m = 0.0;     ///< all strips' points at M_used about their best-fit plane, seed eq. (13) [m]
  double rms_after_m = 0.0;      ///< residual distances to the estimated plane at M̂ [m]
  bool outlier = false;          ///< RMS after far beyond the other patches'
};

/// A patch (or one strip's part of it) left out, and why.
struct RejectedPatch {
  std::string patch_id, strip_id;  ///< strip_id empty when the whole patch is rejected
  std::string reason;
};

/// The residual section of the planes.
struct PlaneSection : MethodSection {
  std::string method() const override { return "planes"; }
  std::string brief() const override;
  std::string text(const AdjustmentSummary& summary) const override;
  std::string resultJson(const AdjustmentSummary& summary) const override;
  std::string html(const AdjustmentSummary& summary) const override;
  std::vector<std::string> warnings() const override;
  int outliers() const override;
  std::vector<PlanMark> planMarks() const override;
  bool automatic = false;
  /// Automatic patches: how often they were searched for (1: at the used mounting only; more:
  /// found again where the strips lay once the first solve had moved them beyond the roughness
  /// bound, or a later one beyond the search margin).
  int patch_searches = 1;
  /// Automatic patches: the cells' roughness bound the last search used [m] — the option's
  /// `max_roughness_m`, or doubled (`roughness_growths` times, at most twice) while the search gave
  /// fewer than three patches used: at a mounting far from the truth a strip's own looks at one cell
  /// disagree (a spinning scanner's lasers and the two sides of its turn), and a cell is rough by
  /// the misalignment, not by its surface.
  double roughness_bound_m = 0.0;
  int roughness_growths = 0;
  /// Automatic patches, per search (the first at the used mounting): the roughness bound it
  /// used [m] and the patches it gave (used, at the mounting it searched at).
  std::vector<double> search_bounds_m;
  std::vector<int> search_patches;
  int patches_used = 0;
  int points_used = 0;
  /// Points set aside after a solve as off their patch's surface (beyond 5 × its robust scale, 2σ
  /// and ransac_threshold_m / 10): where a patch meets another surface within ransac_threshold_m.
  int points_off_surface = 0;
  double sigma_m = 0.0;  ///< σ of a point-to-plane distance used [m]
  std::vector<PatchResidual> patches;
  std::vector<RejectedPatch> rejected;
  double rms_before_m = 0.0, rms_after_m = 0.0;  ///< over all points [m]
  /// With per-laser intrinsics estimated: their estimates, σ and screening.
  LaserIntrinsicEstimates laser_intrinsics;
  LaserCorrections laserCorrections() const override { return laser_intrinsics.lasers; }
  /// Intrinsics estimated beyond kLaserPriorDoubt times their prior σ (one sentence naming them).
  std::vector<std::string> doubts() const override;
};

/// A planar patch found in the overlaps (findPlanarPatches).
struct PlanarPatch {
  PlaneRegion region;           ///< plan bounding box of the patch [m]
  Vec3 normal = Vec3::UnitZ();  ///< [-]
  int cells = 0;                ///< grid cells grown into it
};

/// Finds planar patches seen by two or more strips (region growing over a plan grid of
/// per-strip plane fits, then RANSAC per strip), keeping at most `max_patches` spread over
/// normal directions so that roofs of every aspect survive beside flat ground.
std::vector<PlanarPatch> findPlanarPatches(const CalibrationData& data, const PlaneOptions& options);

class PlaneObservations final : public ObservationSource {
 public:
  /// Selects every patch's points (regions from `data.plane_regions`, or found automatically)
  /// at `data.mounting_used`. Throws InvalidInput for invalid options or inconsistent strips.
  PlaneObservations(const CalibrationData& data, const PlaneOptions& options);
  ~PlaneObservations() override;

  std::string kind() const override { return "planes"; }
  /// The points in each region are selected again at each new mounting, and automatic patches
  /// found again once some point has moved beyond the search margin (at least half a plan cell)
  /// since they were found, and once where a solve first moved the strips by more than the
  /// cells' roughness bound (at most kMaxPatchSearches searches).
  bool rematches() const override { return true; }
  /// False in the round after the automatic patches were found again (a new set of patches).
  /// And in the round after points off a patch's surface were set aside (solved()).
  bool settled() const override { return !refound_ && !trimmed_; }
  /// The σ of a distance pooled from the strips' own plane fits where the patches were first
  /// selected (at the mounting used), floored at 2 mm — unless PlaneOptions::sigma_m states it.
  StartSigma sigmaFromStart() const override;
  void addBlocks(const std::array<double, 6>& mounting, AdjustmentProblem* problem) override;
  void solved(const AdjustmentProblem& problem) override;
  void finish(const std::array<double, 6>& mounting_used, const std::array<double, 6>& mounting, const AdjustmentProblem& problem,
              const AnalysisOptions& analysis) override;

  int observationCount() const { return section_.points_used; }
  const PlaneSection& section() const { return section_; }

  /// One point of a patch with what re-georeferencing it needs.
  struct PatchPoint {
    std::string strip_id;
    Vec3 x0_rel = Vec3::Zero();  ///< position at M_used minus the patch centre [m]
    Mat3 R_mb = Mat3::Identity();
    Vec3 r_s = Vec3::Zero();
    double time_s = 0.0;          ///< the pulse's time [s] (trajectory errors in time)
    int laser = -1;               ///< laser id when per-laser intrinsics are estimated
    std::uint32_t candidate = 0;  ///< its index among its region's candidates
  };
  struct Patch {
    std::string id;
    Vec3 centre_m = Vec3::Zero();
    Eigen::Vector4d plane0 = Eigen::Vector4d(0, 0, 1, 0);  ///< (n, d) at M_used
    std::vector<PatchPoint> points;
    int strips = 0;
    double* block = nullptr;  ///< the plane block of the current problem
    std::size_t region = 0;   ///< its region (the candidates its points are selected from)
  };
  const std::vector<Patch>& patches() const { return patches_; }

 private:
  struct Candidate {
    std::string strip_id;
    Vec3 x0 = Vec3::Zero();  ///< at M_used [m]
    Mat3 R_mb = Mat3::Identity();
    Vec3 r_s = Vec3::Zero();
    double time_s = 0.0;  ///< the pulse's time [s] (trajectory errors in time)
    int laser = -1;
    bool off_surface = false;  ///< found off its patch's surface after a solve: not selected again
  };
  struct Region {
    PlaneRegion box;
    std::vector<Candidate> candidates;
  };
  /// Selects every region's points (RANSAC per strip) and builds the patches at mounting m.
  void select(const std::array<double, 6>& m);
  /// regions_ from the boxes: each strip's points within a box (grown by the search margin) at
  /// mounting m (null: at M_used).
  void collectCandidates(const CalibrationData& data, const std::vector<PlaneRegion>& regions, const std::array<double, 6>* m);
  /// The largest move of a probe point between the mounting the patches were found at and m [m].
  double movedSinceFound(const std::array<double, 6>& m) const;
  /// Automatic patches found at mounting m (null: M_used), their candidates collected and
  /// selected; the roughness bound doubled while fewer than three patches are used.
  void search(const std::array<double, 6>* m);
  /// Searches for automatic patches at most (the first included).
  static constexpr int kMaxPatchSearches = 6;
  struct Probe {
    Mat3 R_mb;
    Vec3 r_s;
  };
  /// Patch points per laser id (per-laser intrinsics estimated).
  std::vector<int> laserPoints() const;

  PlaneOptions options_;
  MountingParameters used_;
  std::vector<Region> regions_;
  std::vector<std::string> strip_order_;
  std::array<double, 6> selected_at_{};
  // Automatic patches: the data they are found in (the caller's, alive during the calibration),
  // the mounting of the last search, its plan cell and the probes of movedSinceFound.
  const CalibrationData* data_ = nullptr;
  std::array<double, 6> found_at_{};
  double cell_m_ = 0.0;
  std::vector<Probe> probes_;
  bool refound_ = false;
  bool searched_at_solution_ = false;  // found again after a solve (the roughness bound's search)
  bool trimmed_ = false;               // the last solve set points off their surface aside
  int trim_rounds_ = 0, solves_since_search_ = 0;
  std::vector<Patch> patches_;
  std::vector<std::vector<int>> blocks_;  // residual block of each point, per patch
  PlaneSection section_;
  std::unique_ptr<detail::LaserIntrinsicsBlock> laser_;  // per-laser intrinsics (null: not estimated)
};

}  // namespace mountcal
