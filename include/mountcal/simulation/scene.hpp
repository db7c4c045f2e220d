#pragma once
/// \file simulation/scene.hpp
/// The world a simulated survey scans: a ground plane (flat or gently sloped) with
/// high-intensity markings, buildings (flat roofs, gable roofs, vertical walls), raised target
/// boards, and vegetation-like clutter. Ray casting is exact against the planar primitives:
/// buildings and boards are triangles held in an OpenMesh TriMesh with a bounding-volume
/// hierarchy; the ground is intersected analytically.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "mountcal/core/rotation.hpp"

namespace mountcal::simulation {

/// Kinds of surfaces a ray can hit.
enum class SurfaceKind : std::uint8_t { kGround, kMarking, kRoof, kWall, kBoard, kVegetation };

/// A ray hit.
struct Hit {
  double range_m = 0.0;           ///< distance from the ray origin [m]
  Vec3 point_m = Vec3::Zero();    ///< hit point, mapping frame [m]
  Vec3 normal_m = Vec3::UnitZ();  ///< unit surface normal (facing the ray) [-]
  float intensity = 0.0f;         ///< reflectance of the surface [0–255]
  SurfaceKind kind = SurfaceKind::kGround;
};

/// A world point a surveyor would pick as a tie: marking corners, target centres, roof points.
/// Each lies on a planar surface that extends at least `clearance_m` around it.
struct FeaturePoint {
  std::string id;
  Vec3 x_m = Vec3::Zero();  ///< true position [m]
  SurfaceKind kind = SurfaceKind::kGround;
  double clearance_m = 1.0;  ///< radius of the planar surface around the point [m]
};

/// A horizontal axis-aligned patch of bare ground, used as a check plane.
struct PlanePatch {
  std::string id;
  double xmin = 0, ymin = 0, xmax = 0, ymax = 0;  ///< [m]
};

class Scene {
 public:
  Scene();
  ~Scene();
  Scene(Scene&&) noexcept;
  Scene& operator=(Scene&&) noexcept;

  /// Ground z = z0 + gx·x + gy·y [m]; intensity of bare ground.
  void setGround(double z0_m, double gx, double gy, float intensity = 40.0f);
  double groundHeight(double x_m, double y_m) const;

  /// A painted rectangle on the ground (length along `heading`, clockwise from North).
  void addMarking(double cx, double cy, double length_m, double width_m, double heading_rad, float intensity = 220.0f);
  /// A zebra crossing: `stripes` stripes 0.5 m wide, 1 m apart, `length_m` long, across a road
  /// running along `heading`; its outer corners become feature points.
  void addZebraCrossing(const std::string& id, double cx, double cy, double heading_rad, int stripes = 6, double length_m = 4.0);
  /// A flat-roof building; roof corners inset by 2 m become feature points.
  void addFlatRoofBuilding(const std::string& id, double cx, double cy, double length_m, double width_m, double height_m,
                           double heading_rad);
  /// A gable-roof house (ridge along `heading`); one point in the middle of each roof plane
  /// becomes a feature point.
  void addGableHouse(const std::string& id, double cx, double cy, double length_m, double width_m, double eave_height_m,
                     double ridge_height_m, double heading_rad);
  /// A monopitch (lean-to) house: one roof plane from its low eave along the −across(heading)
  /// side up to its high eave along the +across side (it faces −across(heading), downslope);
  /// the middle of the roof plane becomes a feature point.
  void addMonopitchHouse(const std::string& id, double cx, double cy, double length_m, double width_m, double low_eave_height_m,
                         double high_eave_height_m, double heading_rad);
  /// A raised (and possibly tilted) square target board of side `size_m` whose centre is a
  /// feature point; `tilt_rad` rotates it about its own x axis.
  void addBoard(const std::string& id, const Vec3& centre_m, double size_m, double heading_rad, double tilt_rad, float intensity = 230.0f);
  /// A ground target (square marking) whose centre and corners are feature points.
  void addGroundTarget(const std::string& id, double cx, double cy, double size_m, double heading_rad, float intensity = 230.0f);
  /// A tree: a vertical cylinder of crown from `crown_base_m` to `top_m` above the ground that
  /// returns a scattered point with probability `density` per ray crossing it.
  void addTree(double cx, double cy, double radius_m, double crown_base_m, double top_m, double density = 0.5);
  /// A check plane: bare ground patch.
  void addCheckPlane(const std::string& id, double xmin, double ymin, double xmax, double ymax);
  void addFeature(const FeaturePoint& f) { features_.push_back(f); }
  /// A calibration patch for the plane method: an axis-aligned region holding one planar face.
  /// Flat roofs and each face of a gable roof add theirs (the largest box inside the face).
  void addPlaneRegion(const PlanePatch& region) { plane_regions_.push_back(region); }
  /// A region holding one high-intensity target for the feature method (SPEC §4 `"targets"`);
  /// boards and ground targets add theirs (their footprint with a margin of `target_margin_m`).
  void addTargetRegion(const PlanePatch& region) { target_regions_.push_back(region); }
  double target_margin_m = 2.0;

  const std::vector<FeaturePoint>& features() const { return features_; }
  const std::vector<PlanePatch>& checkPlanes() const { return check_planes_; }
  const std::vector<PlanePatch>& planeRegions() const { return plane_regions_; }
  const std::vector<PlanePatch>& targetRegions() const { return target_regions_; }
  std::size_t triangleCount() const;

  /// Builds the acceleration structure; call after adding geometry (cast() calls it if needed).
  void build();

  /// Casts the ray origin + s·dir (dir unit), s > 0. `pulse_id` seeds the clutter decision so
  /// the result is deterministic. Returns false when nothing is hit within `max_range_m`.
  bool cast(const Vec3& origin_m, const Vec3& dir_m, std::uint64_t pulse_id, Hit* hit, double max_range_m = 1e5) const;

  /// Writes the building and board triangles as a Wavefront OBJ (via OpenMesh) — for looking
  /// at the scene in any mesh viewer. Throws FileError.
  void writeMesh(const std::string& path) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::vector<FeaturePoint> features_;
  std::vector<PlanePatch> check_planes_;
  std::vector<PlanePatch> plane_regions_;
  std::vector<PlanePatch> target_regions_;
};

}  // namespace mountcal::simulation
