#pragma once
/// \file detail/vtp_strip.hpp
/// Internal to the VTPM method: a strip with its plan k-d tree, ready for building virtual tie
/// points. Not part of the API (it may change without notice).

#include <memory>
#include <string>
#include <vector>

#include "mountcal/methods/common/virtual_tie_point.hpp"

namespace mountcal {

/// A strip ready for VTPM construction: its points at the reference mounting in a FLANN k-d
/// tree over (x, y), and its poses.
class VtpStrip {
 public:
  /// Georeferences `strip` with `reference` through its per-point poses, or else `trajectory`
  /// (which may then be null), when `strip.x_m` is empty.
  /// Throws InvalidInput for inconsistent sizes, TimeOutOfRange for a point outside the
  /// trajectory.
  VtpStrip(StripData strip, std::shared_ptr<const Trajectory> trajectory, const MountingParameters& reference);
  ~VtpStrip();
  VtpStrip(VtpStrip&&) noexcept;
  VtpStrip& operator=(VtpStrip&&) noexcept;

  const StripData& data() const { return strip_; }
  /// Indices of the points within `radius_m` of (x, y) in plan (exact search).
  std::vector<std::size_t> radiusSearch(double x_m, double y_m, double radius_m) const;
  /// Mean plan spacing of points around (x, y) [m] (from the 8 nearest neighbours).
  double localSpacing(double x_m, double y_m) const;

  /// Builds the VTP of a pick; on failure returns false and sets `reason`.
  bool build(const TieObservation& pick, const VtpOptions& options, VirtualTiePoint* vtp, std::string* reason) const;

 private:
  struct Index;
  StripData strip_;
  std::shared_ptr<const Trajectory> trajectory_;
  MountingParameters reference_;
  std::unique_ptr<Index> index_;
  bool multi_laser_ = false;  // its points carry more than one laser id (VtpMotion::kAuto)
};

}  // namespace mountcal
