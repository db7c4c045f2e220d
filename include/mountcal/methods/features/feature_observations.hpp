#pragma once
/// \file methods/features/feature_observations.hpp
/// The second paper's method (seed 002: multi-beam UAV calibration by feature matching), made
/// rigorous. Inside user-given regions (job key `"targets"`), each holding one high-intensity
/// target board or marking seen by several strips:
///
///  1. **Extraction** per strip: the region's points above an intensity threshold (Otsu's split
///     of the region's intensity histogram unless set), grouped by distance-based region
///     growing, the largest group fitted by a RANSAC plane (the "feature plane").
///  2. **Matching**: between every pair of strips that see a target, a translation-only ICP
///     (FLANN nearest neighbours, point-to-plane along the feature plane's normal and
///     point-to-point across it) gives the 3-D offset Δ = x_A − x_B with its covariance.
///  3. **Closed form** (SPEC §2, seed 002 eqs. 8–10): pairs flown in opposite directions give
///     roll and pitch, pairs flown in the same direction and offset sideways give heading; a
///     first-order estimate, used as the starting value.
///  4. **Rigorous**: each target is a nuisance point X_k; each strip i that sees it observes it
///     through the centroid of its feature points, re-georeferenced at the mounting M:
///
///       r = W^½ ( c_i(M) + o_i − X_k ),   c_i(M) = (1/n) Σ_j x_j(M),
///       x_j(M) = x_j(M_used) + R_mb,j [ (R_bs(M) − R_bs(M_used)) r_s,j + (a_b − a_b,used) ]
///
///     (SPEC §2 eq. 1 differenced, exact), W from σ_n along the feature plane's normal (the plane
///     fit's σ/√n: the point-to-plane information of the target's points) and σ_t across it (the
///     sampling of the target's outline). The mean is linear in R_bs(M): c_i(M) needs one 3×9
///     product per evaluation however many points the target holds.

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "mountcal/adjustment/mounting_adjustment.hpp"
#include "mountcal/data.hpp"
#include "mountcal/methods/common/laser_priors.hpp"
#include "mountcal/methods/method.hpp"

namespace mountcal {

namespace detail {
class LaserIntrinsicsBlock;
}

/// Settings of the feature method (job: the `"features"` object). Lengths [m], angles [deg].
/// Multi-beam strips with laser ids (StripData::laser): the per-laser intrinsics of
/// LaserIntrinsicsPriors (elevation, azimuth, range, vertical and horizontal origin offsets) in
/// the rigorous adjustment, each group with its prior σ (0: not estimated).
struct FeatureOptions : LaserIntrinsicsPriors {
  static constexpr const char* kMethod = "features";
  /// Points at or above this intensity are target points; 0: Otsu's threshold of each region's
  /// intensity histogram (all strips' points in the region) [intensity units].
  double intensity_threshold = 0.0;
  /// A region whose brightest points are not at least this many times its median intensity
  /// holds no high-intensity target [-].
  double min_contrast = 2.0;
  /// Region growing joins target points closer than this [m]; 0: 2.5 × the strip's point
  /// spacing in the region, at least 1 m (a multi-beam scanner samples a target in rows that
  /// are the platform's advance per revolution apart, 0.5 m at 5 m/s and 10 Hz).
  double growing_distance_m = 0.0;
  /// A second group of at least this fraction of the largest one's points means the region
  /// holds two targets: the region is rejected [-].
  double second_group_fraction = 0.3;
  /// Inlier distance of the feature plane [m]. Generous on purpose: at the mounting used, a
  /// boresight error of 1° puts the rows of different lasers (seen 10 m apart along the track)
  /// 0.2 m apart in height; the rigorous step re-georeferences every point anyway.
  double ransac_threshold_m = 0.3;
  int ransac_iterations = 200;
  int min_points = 12;               ///< a strip's feature with fewer inliers is not seen [-]
  double min_inlier_fraction = 0.8;  ///< fewer of the group's points on its plane: not planar [-]
  /// σ of a target's centre across its plane (the outline's sampling) [m]; 0: estimated from
  /// the residuals by variance components (starting from 2 cm), as is σ along the normal.
  double sigma_in_plane_m = 0.0;
  /// The outline's centre along each of the target's axes is the mean of this many extreme
  /// points on either side (midrange: its error falls as 1/n with the sampling, the mean's as 1/√n) [-].
  int edge_points = 4;
  int icp_max_iterations = 50;
  double icp_tolerance_m = 1e-6;  ///< ICP stops when the translation changes less [m]
  /// Pairs whose headings differ by less than this are the same direction; by more than
  /// 180° minus this, opposite; others are crossing and not used by the closed form [deg].
  double direction_tolerance_deg = 20.0;
  /// The closed form separates pitch from the along-track lever arm only when the opposite
  /// pairs' heights above the targets differ by at least this fraction of their mean [-].
  double min_height_spread = 0.2;
  bool IsValid(std::string* error) const;
};

/// One strip's view of a target.
struct FeatureView {
  std::string strip_id;
  int points = 0;                  ///< inliers of the feature plane
  Vec3 centroid_m = Vec3::Zero();  ///< at the mounting used [m]
  Vec3 normal = Vec3::UnitZ();     ///< feature plane normal (upwards) [-]
  double plane_sigma_m = 0.0;      ///< σ of the inliers about the plane [m]
  double sigma_normal_m = 0.0;     ///< σ of the centroid along the normal [m]
  double sigma_in_plane_m = 0.0;   ///< σ of the centroid across the plane [m]
  double time_s = 0.0;             ///< mean time of the feature's points [s]
  Vec3 platform_m = Vec3::Zero();  ///< mean IMU position while the strip saw it [m]
  Vec3 forward = Vec3::UnitY();    ///< the body's forward axis, horizontal, unit (mean over the points) [-]
  double threshold = 0.0;          ///< intensity threshold used [-]
};

/// A target rejected (strip_id empty: the whole region), or one strip's view of it, and why.
struct RejectedFeature {
  std::string target_id, strip_id;
  std::string reason;
};

/// The offset of one target between two strips, and how the closed form reads it.
struct FeaturePairOffset {
  std::string target_id, strip_a, strip_b;
  /// "opposite", "same" (same direction, B offset sideways) or "crossing".
  std::string relation;
  Vec3 offset_m = Vec3::Zero();        ///< Δ = x_A − x_B in the mapping frame, by ICP [m]
  Vec3 offset_afd_m = Vec3::Zero();    ///< Δ in A's along-track / cross-track (right) / down axes [m]
  Mat3 covariance = Mat3::Zero();      ///< of offset_m [m²]
  Mat3 covariance_afd = Mat3::Zero();  ///< of offset_afd_m [m²]
  double height_m = 0.0;               ///< H_A: A above the target [m]
  double height_b_m = 0.0;             ///< H_B: B above the target [m]
  double lateral_a_m = 0.0;            ///< y_A: the target right of A's line [m]
  double lateral_b_m = 0.0;            ///< y_B: the target right of B's line (B's own right) [m]
  double line_offset_m = 0.0;          ///< D = y_A − y_B: B's line right of A's (same-direction pairs) [m]
  int icp_iterations = 0;
  double icp_rms_m = 0.0;  ///< RMS distance of the matched points [m]
};

/// The paper's first-order answer (SPEC §2 "Closed-form boresight from strip offsets").
struct FeatureClosedForm {
  bool valid = false;
  std::string message;                                       ///< why not, or what was held
  Vec3 boresight_correction_rad = Vec3::Zero();              ///< ε = δ_used − δ (roll, pitch, heading) [rad]
  Vec3 boresight_sigma_rad = Vec3::Constant(std::nan(""));   ///< NaN: not determined [rad]
  Vec3 boresight_spread_rad = Vec3::Constant(std::nan(""));  ///< std. dev. of the single-pair estimates [rad]
  std::array<int, 3> pairs_used{};                           ///< pairs contributing to each angle
  bool lever_arm_estimated = false;                          ///< two heights: η_x, η_y estimated beside the angles
  Vec3 lever_arm_correction_m = Vec3::Zero();                ///< η = a_used − a (x, y; z never) [m]
  Vec3 lever_arm_sigma_m = Vec3::Constant(std::nan(""));
  /// Named when one flight height leaves pitch and the along-track lever arm coupled.
  bool pitch_lever_arm_coupled = false;
  MountingParameters mounting;  ///< mounting_used corrected by ε (and η) [m, rad]
};

/// The section of the result file (SPEC §4 `"features"`).
struct FeatureSection : MethodSection {
  std::string method() const override { return "features"; }
  std::string brief() const override;
  std::string text(const AdjustmentSummary& summary) const override;
  std::string resultJson(const AdjustmentSummary& summary) const override;
  std::string html(const AdjustmentSummary& summary) const override;
  std::vector<std::string> warnings() const override;
  int targets_used = 0;
  int views_used = 0;  ///< (target, strip) observations in the adjustment
  std::vector<std::string> target_ids;
  std::vector<std::vector<FeatureView>> views;  ///< per used target
  std::vector<RejectedFeature> rejected;
  std::vector<FeaturePairOffset> pairs;
  FeatureClosedForm closed_form;
  /// Per used target and view: the centroid's residual to the target before (at the mounting
  /// used, about the mean of the views) and after (at the estimate) [m].
  struct Residual {
    std::string target_id, strip_id;
    Vec3 before_m = Vec3::Zero(), after_m = Vec3::Zero();
  };
  std::vector<Residual> residuals;
  Vec3 rms_before_m = Vec3::Zero(), rms_after_m = Vec3::Zero();  ///< per mapping axis [m]
  /// σ of a target centre along its normal and across its plane used in the last solve (stated,
  /// or estimated from the residuals) [m]. Estimated, the in-plane σ is two components — along the
  /// viewing strip's track and across it, both in the target's plane (a scanner samples a target
  /// in rows and along its scan lines at different spacings) — and sigma_in_plane_m their RMS.
  double sigma_normal_m = 0.0, sigma_in_plane_m = 0.0;
  double sigma_along_track_m = 0.0, sigma_across_track_m = 0.0;
  bool sigma_estimated = false;
  double extraction_time_s = 0.0, matching_time_s = 0.0;  ///< [s]
  /// With laser_elevation_sigma_deg > 0: the estimated per-laser elevation offsets.
  LaserIntrinsicEstimates laser_intrinsics;
  LaserCorrections laserCorrections() const override { return laser_intrinsics.lasers; }
  /// Elevation offsets estimated beyond kLaserPriorDoubt times their prior σ (one sentence naming them).
  std::vector<std::string> doubts() const override;
};

/// Step 1 for one region: every strip's feature (the rest rejected with reasons, appended to
/// `rejected`). Pulse indices into each strip are returned in `indices` (same order as the views).
std::vector<FeatureView> extractFeature(const CalibrationData& data, const PlaneRegion& region, const FeatureOptions& options,
                                        std::vector<RejectedFeature>* rejected, std::vector<std::vector<std::uint32_t>>* indices = nullptr);

/// The centre of a target's outline from one strip's points of it: along the target's two axes in
/// its plane (the minimum-area bounding rectangle) the midpoint of the `edge_points` most extreme
/// points on either side, along the normal the mean. As weights: centre = Σ_j W_j x_j (Σ W_j = I).
struct OutlineCentre {
  Vec3 centre_m = Vec3::Zero();
  Vec3 u = Vec3::UnitX(), v = Vec3::UnitY(), n = Vec3::UnitZ();  ///< target axes and normal [-]
  std::vector<std::pair<std::size_t, Mat3>> weights;             ///< (index into the points, W_j)
};
OutlineCentre outlineCentre(const std::vector<Vec3>& points, const Vec3& normal, int edge_points = 4);

/// Step 2: the translation t (= x_A − x_B) that moves `b` onto `a`, by ICP with the normal of
/// `a`'s feature plane. Starts from the centroid difference (or `initial` when given).
struct IcpResult {
  Vec3 translation_m = Vec3::Zero();
  Mat3 covariance = Mat3::Zero();  ///< [m²]
  int iterations = 0;
  double rms_m = 0.0;
  bool converged = false;
};
IcpResult matchTranslation(const std::vector<Vec3>& a, const std::vector<Vec3>& b, const Vec3& normal, double sigma_normal_m,
                           double sigma_in_plane_m, int max_iterations = 50, double tolerance_m = 1e-6, const Vec3* initial = nullptr);

class FeatureObservations final : public ObservationSource {
 public:
  /// Extracts, matches and computes the closed form at `data.mounting_used`
  /// (data.target_regions). Throws InvalidInput for invalid options or strips without intensity.
  FeatureObservations(const CalibrationData& data, const FeatureOptions& options);
  ~FeatureObservations() override;

  std::string kind() const override { return "features"; }
  /// The outline (which points are extreme) is found again at each new mounting, and the
  /// σ of the centres re-estimated from the residuals (variance components).
  bool rematches() const override { return true; }
  bool settled() const override { return settled_; }
  void addBlocks(const std::array<double, 6>& mounting, AdjustmentProblem* problem) override;
  void solved(const AdjustmentProblem& problem) override;
  void finish(const std::array<double, 6>& mounting_used, const std::array<double, 6>& mounting, const AdjustmentProblem& problem,
              const AnalysisOptions& analysis) override;

  int observationCount() const { return section_.views_used; }
  const FeatureSection& section() const { return section_; }

  /// One strip's feature as the adjustment needs it: c(M) = c0 + K vec(R_bs(M) − R_bs,used) + R̄ (a − a_used).
  struct View {
    std::string strip_id;
    Vec3 c0_rel = Vec3::Zero();  ///< centroid at M_used minus the target's reference point [m]
    Eigen::Matrix<double, 3, 9> K = Eigen::Matrix<double, 3, 9>::Zero();
    Mat3 R_bar = Mat3::Zero();          ///< mean R_mb of the points [-]
    Mat3 sqrt_info = Mat3::Identity();  ///< W^½ [1/m]
    double time_s = 0.0;                ///< mean time of the view's points [s]
    Vec3 u_m = Vec3::Zero();            ///< mean IMU → point vector, mapping frame [m]
    /// Per laser l of the outline's points: c gains [(cos δ_l − 1) K_r + sin δ_l K_u] vec(R_bs(M))
    /// (r(ω + δ) = cos δ r + sin δ u, exactly), K_r, K_u as K with r and u = ∂r/∂ω. With groups
    /// beyond the elevation (LaserCorrector: r' = R_z(δα) [(1 + δρ/ρ)(cos δω r + sin δω u) +
    /// δH p] + δV e_z, exactly), `K_all`: K of each vector f ∈ {r, u, r/ρ, u/ρ, p} turned by each
    /// part of R_z(δα) = I + (cos δα − 1) P + sin δα Z (P = diag(1, 1, 0), Z the rotation's
    /// generator) at 3 f + {0, 1, 2}, and K of e_z at 15.
    struct LaserTerm {
      int laser = 0;
      Eigen::Matrix<double, 3, 9> K_r = Eigen::Matrix<double, 3, 9>::Zero(), K_u = Eigen::Matrix<double, 3, 9>::Zero();
      std::vector<Eigen::Matrix<double, 3, 9>> K_all;  ///< empty: elevation offsets alone (detail::addFeatureLaserTerms)
    };
    std::vector<LaserTerm> lasers;
  };
  struct Target {
    std::string id;
    Vec3 reference_m = Vec3::Zero();  ///< mean of the views' centroids at M_used [m]
    std::vector<View> views;
    double* block = nullptr;
  };
  const std::vector<Target>& targets() const { return targets_; }

 private:
  struct ViewPoints {
    std::string strip_id;
    std::vector<Vec3> x0, r_s;
    std::vector<Mat3> R_mb;
    std::vector<int> laser;  ///< each point's laser id (per-laser intrinsics only)
    Vec3 normal = Vec3::UnitZ();
    Vec3 forward = Vec3::UnitY();  ///< the strip's horizontal forward direction (FeatureView::forward) [-]
    double time_s = 0.0;           ///< mean time of the points [s]
  };
  void select(const std::array<double, 6>& m);
  std::vector<std::vector<ViewPoints>> points_;
  std::array<double, 6> selected_at_{};
  bool selected_ = false, settled_ = false;
  /// σ of a centre along the normal, and in the plane along and across the viewing strip's track [m].
  double sigma_n_ = 0.002, sigma_a_ = 0.02, sigma_c_ = 0.02;
  /// The in-plane σ as one figure: the RMS of the two components [m].
  double sigmaInPlane() const { return std::sqrt(0.5 * (sigma_a_ * sigma_a_ + sigma_c_ * sigma_c_)); }
  FeatureOptions options_;
  MountingParameters used_;
  std::vector<Target> targets_;
  std::vector<std::vector<int>> blocks_;
  std::vector<int> viewRecords() const;  // every target's view records, in blocks_' order
  FeatureSection section_;
  std::unique_ptr<detail::LaserIntrinsicsBlock> laser_;  // per-laser intrinsics (null: not estimated)
};

/// Step 3 alone, from matched pairs: the closed form (SPEC §2) at `mounting_used`.
FeatureClosedForm closedFormBoresight(const std::vector<FeaturePairOffset>& pairs, const MountingParameters& mounting_used,
                                      const FeatureOptions& options);

}  // namespace mountcal
