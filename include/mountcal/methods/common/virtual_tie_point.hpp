#pragma once
/// \file virtual_tie_point.hpp
/// The virtual tie point model (VTPM) of the first paper (seed 000 §2.3–2.4, SPEC §3).
///
/// Laser footprints are discrete, so no two strips share a real point. A virtual tie point
/// ties a picked plan position (X, Y) on one strip to the three real, coplanar laser points
/// whose triangle encloses it:
///  1. FLANN radius search around (X, Y); RANSAC keeps the coplanar points; a 2-D Delaunay
///     triangulation of them in the fitted plane (an OpenMesh TriMesh); the enclosing triangle.
///  2. Rule 1 (seed eq. 5): the tie's height is interpolated on the triangle's plane → P⁰.
///  3. Rule 2 (seed eq. 6): for any mounting M the three vertices are georeferenced again, the
///     rigid transform from the reference triangle to the new one is fitted (Kabsch), and
///     applied to P⁰ → P(M). A pure function of M.
///
/// On a multi-beam scanner's strip (VtpMotion) the pick moves instead with all the coplanar points
/// around it, an affine combination of them that reproduces it in plan: its lasers see a picked target at different times and
/// angles, and under a wrong mounting each places it elsewhere — the pick is the centre of that
/// smear, not a place of the one laser whose three pulses enclose it.

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "mountcal/data.hpp"
#include "mountcal/core/mounting.hpp"
#include "mountcal/observations.hpp"
#include "mountcal/core/trajectory.hpp"

namespace mountcal {

/// A real laser point with what Rule 2 needs to georeference it again.
struct LaserFootprint {
  Pose pose;                 ///< trajectory pose at the emission time
  Vec3 r_s = Vec3::Zero();   ///< raw laser vector [m]
  Vec3 x0_m = Vec3::Zero();  ///< position at the reference mounting [m]
  std::size_t index = 0;     ///< index in its strip
};

/// How a virtual tie point moves with the mounting (Rule 2).
enum class VtpMotion {
  /// kNeighbourhood on a strip whose points carry more than one laser id (a multi-beam scanner's,
  /// job key `sensor.laser_field`), kTriangle otherwise.
  kAuto,
  /// The seed's Rule 2: the rigid motion of the enclosing triangle (seed eq. 6).
  kTriangle,
  /// An affine combination of the coplanar points around the pick (the RANSAC plane's inliers
  /// within the search radius, the nearest kMaxMotionSupport): P(M) = Σ_i w_i x_i(M), Σ w_i = 1,
  /// each laser keeping the same share when the strip has laser ids (u_i = 1 / (lasers · its
  /// points)), each point otherwise, the weights changed from u as little as they can be so that
  /// P(M₀) is the pick in plan (setMotionSupport). On a plane surface the tie point lies on it
  /// wherever the points do — at the true mounting, noise-free (uav-vlp16, 8 seeds: heading RMS
  /// 0.0086°, against 0.022° with the plain mean displacement P⁰ + Σ u_i [x_i(M) − x_i(M₀)]).
  /// A multi-beam scanner's sixteen or thirty-two lasers each see a target at another time and
  /// angle; under a wrong mounting each places it elsewhere (a heading error of 1.2° moves the
  /// ground points of a laser 15° off the scan plane, 50 m below, by 0.28 m across the track
  /// against the scan plane's own), and a pick is made on the centre of that smear. The enclosing
  /// triangle's three pulses, of one laser or two, move as those lasers do: over 30 simulated
  /// uav-vlp16 surveys (a-priori boresight error 0.5°, −0.8°, 1.2°) VTPM's heading came out with
  /// RMS error/σ 1.13 (mean −0.89), and 0.75 (mean −0.22) with the mean displacement, upright
  /// triangles refused in both (scripts/experiments/uav-vtpm, 2026-12-05). A translation, not a rigid motion: the Kabsch
  /// rotation of a neighbourhood whose lasers move apart is their scatter, and a neighbourhood of
  /// one scan row leaves it undetermined (pitch errors of 9σ and 235σ in the same experiment).
  kNeighbourhood,
};

/// The most points a neighbourhood motion averages (the nearest to the pick) [-].
inline constexpr int kMaxMotionSupport = 256;

/// Settings of the VTPM construction.
struct VtpOptions {
  double radius_m = 1.0;  ///< search radius around the pick [m] (seed: 1 m)
  /// The radius grows to this multiple of the local point spacing when that is larger, so that
  /// sparse strips still give enough points [-].
  double radius_spacing_factor = 2.5;
  double max_radius_m = 5.0;         ///< the grown radius never exceeds this [m]
  double ransac_threshold_m = 0.05;  ///< max point-to-plane distance of an inlier [m]
  int ransac_iterations = 200;       ///< [-]
  int min_points = 5;                ///< fewer coplanar points than this → rejected
  /// The plane must hold at least this fraction of the pick's 6 nearest points, else "no plane".
  double min_inlier_fraction = 0.5;
  double min_triangle_angle_deg = 5.0;  ///< a sliver triangle is degenerate [deg]
  double max_plane_tilt_deg = 75.0;     ///< a plane steeper than this cannot hold a plan pick [deg]
  VtpMotion motion = VtpMotion::kAuto;  ///< how the tie point moves with the mounting (Rule 2)
};

/// One virtual tie point: a pick on one strip and its three laser footprints.
class VirtualTiePoint {
 public:
  VirtualTiePoint() = default;
  /// `reference` is the mounting the vertices' x0_m were georeferenced with.
  VirtualTiePoint(std::string tie_id, std::string strip_id, double pick_x_m, double pick_y_m, const std::array<LaserFootprint, 3>& vertices,
                  const MountingParameters& reference);

  const std::string& tieId() const { return tie_id_; }
  const std::string& stripId() const { return strip_id_; }
  const std::array<LaserFootprint, 3>& vertices() const { return vertices_; }
  /// P⁰: the pick with its Rule 1 height (with a motion support, the neighbourhood's), at the
  /// reference mounting [m].
  const Vec3& referencePosition() const { return P0_m_; }

  /// Rule 2: the tie position at mounting (lever arm, boresight) given as the 6-vector
  /// `mounting6` in MountingIndex order [m, rad]; the nominal rotation is the reference one.
  Vec3 position(const double* mounting6) const;
  Vec3 position(const MountingParameters& m) const;
  /// P(M) − centroid(): the same, free of the round-off of large map coordinates. Each vertex
  /// moves by R_mb·[(R_bs(M) − R_bs(M₀))·r_s + (a − a₀)] from its reference position, so the
  /// central differences of the calibrator see no cancellation of ~1 km terms.
  Vec3 relativePosition(const double* mounting6) const;
  /// Centroid of the reference triangle (of the motion support, when set) [m].
  const Vec3& centroid() const { return centroid0_m_; }
  /// Unit normal (upward) of the surface the pick lies on: the least-squares plane of the
  /// coplanar points around it that VtpStrip::build fitted (the triangle's own normal carries its
  /// three pulses' noise as well: on dense UAV points, decimetres apart, 2 cm of range noise tilts
  /// a triangle by degrees). Zero when not set.
  const Vec3& surfaceNormal() const { return surface_normal_; }
  void setSurfaceNormal(const Vec3& n) { surface_normal_ = n; }
  /// Rule 2 as an affine combination of these points (VtpMotion::kNeighbourhood; their x0_m at
  /// the reference mounting) instead of the triangle's rigid motion: P(M) = Σ_i w_i x_i(M), Σ w_i = 1.
  /// `weights` (all equal when empty) are normalised and then changed as little as they can be
  /// (Σ (w_i − u_i)² / u_i) so that the points' weighted plan centroid is the pick while each of
  /// `groups` (a laser id per point; one group when empty) keeps its share. P⁰ becomes Σ w_i x_i(M₀):
  /// the pick with the neighbourhood's height. On a plane surface the tie point then lies on it at
  /// every mounting that puts the points on it — the true one, noise-free — and a displacement that
  /// is affine in plan over the neighbourhood moves it as it moves the pick (the plain weighted mean
  /// moved it as it moves the neighbourhood's centroid, up to a metre away at a target's corner).
  /// centroid() becomes the points' mean. Throws InvalidInput when empty or when the weights or
  /// groups are not as many, or a weight is not positive and finite.
  void setMotionSupport(std::vector<LaserFootprint> points, std::vector<double> weights = {}, std::vector<int> groups = {});
  /// The weights of motionSupport(), summing to 1 (some may be negative).
  const std::vector<double>& motionWeights() const { return weights_; }
  /// The points of a neighbourhood motion; empty for the triangle's.
  const std::vector<LaserFootprint>& motionSupport() const { return support_; }

 private:
  std::string tie_id_, strip_id_;
  std::array<LaserFootprint, 3> vertices_{};
  Vec3 P0_m_ = Vec3::Zero();
  Vec3 centroid0_m_ = Vec3::Zero();
  std::array<Vec3, 3> d0_m_{};    // reference vertices relative to centroid0
  Vec3 P0_rel_m_ = Vec3::Zero();  // P⁰ − centroid0
  Mat3 R_nom_ = Mat3::Identity();
  Mat3 R_bs0_ = Mat3::Identity();  // reference R_bore·R_nom
  Vec3 a0_b_ = Vec3::Zero();       // reference lever arm
  Vec3 surface_normal_ = Vec3::Zero();
  std::vector<LaserFootprint> support_;  // VtpMotion::kNeighbourhood; x0_m relative to centroid0
  std::vector<double> weights_;          // of support_, summing to 1
};

/// seed eq. (5): height at (x, y) on the plane through three points.
double interpolateHeight(const Vec3& p1, const Vec3& p2, const Vec3& p3, double x, double y);

/// Least-squares rigid transform (Kabsch) with q ≈ R p + t for three or more point pairs.
void fitRigidTransform(const Vec3* p, const Vec3* q, int n, Mat3* R, Vec3* t);

}  // namespace mountcal
