#include "mountcal/methods/features/feature_observations.hpp"

#include <ceres/ceres.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <numeric>
#include <unordered_map>

#include "geometry/kd_tree.hpp"
#include "geometry/plane_ransac.hpp"
#include "methods/common/laser_intrinsics.hpp"
#include "methods/features/feature_laser_terms.hpp"
#include "methods/common/strip_geometry.hpp"
#include "mountcal/core/error.hpp"

namespace mountcal {

bool FeatureOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  auto finiteNonNeg = [](double v) { return std::isfinite(v) && v >= 0; };
  if (!finiteNonNeg(intensity_threshold) || intensity_threshold > 1e6)
    return fail("intensity_threshold must be in [0, 1e6] (0: from each region's histogram)");
  if (!(min_contrast >= 1) || min_contrast > 1e3) return fail("min_contrast must be in [1, 1000]");
  if (!finiteNonNeg(growing_distance_m) || growing_distance_m > 100)
    return fail("growing_distance_m must be in [0, 100] (0: from the point spacing)");
  if (!(second_group_fraction > 0 && second_group_fraction <= 1)) return fail("second_group_fraction must be in (0, 1]");
  if (!(ransac_threshold_m > 0) || ransac_threshold_m > 10) return fail("ransac_threshold_m must be in (0, 10]");
  if (ransac_iterations < 1 || ransac_iterations > 100000) return fail("ransac_iterations must be in [1, 100000]");
  if (min_points < 3 || min_points > 1000000) return fail("min_points must be in [3, 1000000]");
  if (!(min_inlier_fraction > 0 && min_inlier_fraction <= 1)) return fail("min_inlier_fraction must be in (0, 1]");
  if (!finiteNonNeg(sigma_in_plane_m) || sigma_in_plane_m > 10) return fail("sigma_in_plane_m must be in [0, 10] (0: estimated)");
  if (edge_points < 0 || edge_points > 1000) return fail("edge_points must be in [0, 1000] (0: the mean of all points)");
  if (icp_max_iterations < 1 || icp_max_iterations > 10000) return fail("icp_max_iterations must be in [1, 10000]");
  if (!(icp_tolerance_m > 0) || icp_tolerance_m > 1) return fail("icp_tolerance_m must be in (0, 1]");
  if (!(direction_tolerance_deg > 0 && direction_tolerance_deg < 90)) return fail("direction_tolerance_deg must be in (0, 90)");
  if (!(min_height_spread > 0) || min_height_spread > 10) return fail("min_height_spread must be in (0, 10]");
  return laserPriorsValid(error);
}

namespace {

std::string fmt(const char* f, double a, double b = 0, double c = 0) {
  char buf[256];
  std::snprintf(buf, sizeof buf, f, a, b, c);
  return buf;
}

/// Otsu's threshold: the split of the histogram that maximises the between-class variance.
double otsuThreshold(const std::vector<float>& values) {
  const auto [lo_it, hi_it] = std::minmax_element(values.begin(), values.end());
  const double lo = *lo_it, hi = *hi_it;
  if (!(hi > lo)) return hi;
  constexpr int kBins = 256;
  std::vector<double> hist(kBins, 0.0);
  for (float v : values) hist[std::min(kBins - 1, static_cast<int>((v - lo) / (hi - lo) * kBins))] += 1;
  const double total = static_cast<double>(values.size());
  double sum_all = 0;
  for (int b = 0; b < kBins; ++b) sum_all += b * hist[b];
  double w0 = 0, sum0 = 0, best = -1;
  int best_b = 0;
  for (int b = 0; b < kBins - 1; ++b) {
    w0 += hist[b];
    sum0 += b * hist[b];
    const double w1 = total - w0;
    if (w0 == 0 || w1 == 0) continue;
    const double m0 = sum0 / w0, m1 = (sum_all - sum0) / w1;
    const double between = w0 * w1 * (m0 - m1) * (m0 - m1);
    if (between > best) best = between, best_b = b;
  }
  return lo + (best_b + 1.0) * (hi - lo) / kBins;  // the upper edge of the last low bin
}

/// Distance-based region growing (3-D, single linkage below `d`): groups, largest first.
std::vector<std::vector<std::uint32_t>> growRegions(const std::vector<Vec3>& X, const std::vector<std::uint32_t>& idx, double d) {
  std::unordered_map<std::int64_t, std::vector<std::size_t>> cells;
  auto cellOf = [&](const Vec3& p) {
    return Eigen::Vector3i(static_cast<int>(std::floor(p.x() / d)), static_cast<int>(std::floor(p.y() / d)),
                           static_cast<int>(std::floor(p.z() / d)));
  };
  auto key = [](const Eigen::Vector3i& c) {
    return (static_cast<std::int64_t>(c.x()) * 73856093) ^ (static_cast<std::int64_t>(c.y()) * 19349663) ^
           (static_cast<std::int64_t>(c.z()) * 83492791);
  };
  for (std::size_t k = 0; k < idx.size(); ++k) cells[key(cellOf(X[idx[k]]))].push_back(k);
  std::vector<int> label(idx.size(), -1);
  std::vector<std::vector<std::uint32_t>> groups;
  for (std::size_t seed = 0; seed < idx.size(); ++seed) {
    if (label[seed] >= 0) continue;
    const int g = static_cast<int>(groups.size());
    groups.emplace_back();
    std::vector<std::size_t> stack{seed};
    label[seed] = g;
    while (!stack.empty()) {
      const std::size_t k = stack.back();
      stack.pop_back();
      groups[g].push_back(idx[k]);
      const Eigen::Vector3i c = cellOf(X[idx[k]]);
      for (int dx = -1; dx <= 1; ++dx)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dz = -1; dz <= 1; ++dz) {
            auto it = cells.find(key(c + Eigen::Vector3i(dx, dy, dz)));
            if (it == cells.end()) continue;
            for (std::size_t j : it->second)
              if (label[j] < 0 && (X[idx[j]] - X[idx[k]]).norm() <= d) {
                label[j] = g;
                stack.push_back(j);
              }
          }
    }
  }
  std::sort(groups.begin(), groups.end(), [](const auto& a, const auto& b) { return a.size() > b.size(); });
  return groups;
}

/// RANSAC plane through a group (deterministic sampling), then a least-squares refit of the
/// inliers. Returns the inliers.
std::vector<std::uint32_t> ransacPlane(const std::vector<Vec3>& X, const std::vector<std::uint32_t>& group, double threshold,
                                       int iterations, detail::PlaneFit* fit) {
  std::uint64_t state = 0x9E3779B97F4A7C15ULL ^ group.size();
  auto next = [&] {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<std::size_t>(state >> 33) % group.size();
  };
  const detail::PlaneHypothesis plane = detail::ransacPlane(X, group, threshold, iterations, next);
  std::vector<std::uint32_t> in = detail::planeInliers(X, group, plane.normal, plane.found ? plane.point : X[group[0]], threshold);
  if (in.size() >= 3) {
    *fit = detail::fitPlane(in.size(), [&](std::size_t k) { return X[in[k]]; });
    // One refinement against the least-squares plane.
    std::vector<std::uint32_t> again;
    for (std::uint32_t i : group)
      if (std::abs(fit->normal.dot(X[i] - fit->centroid)) <= threshold) again.push_back(i);
    if (again.size() >= 3) {
      in.swap(again);
      *fit = detail::fitPlane(in.size(), [&](std::size_t k) { return X[in[k]]; });
    }
  }
  return in;
}

Mat3 planeCovariance(const Vec3& n, double sigma_normal, double sigma_plane) {
  return sigma_normal * sigma_normal * n * n.transpose() + sigma_plane * sigma_plane * (Mat3::Identity() - n * n.transpose());
}

/// The in-plane axis along a strip's track: its forward direction projected into the target's
/// plane (a target plane facing along the track: the plane's horizontal axis, by convention).
Vec3 alongTrackInPlane(const Vec3& normal, const Vec3& forward) {
  const Vec3 n = normal.normalized();
  Vec3 a = forward - n * n.dot(forward);
  if (a.norm() < 1e-3) a = Vec3::UnitZ().cross(n);
  if (a.norm() < 1e-3) a = Vec3::UnitX() - n * n.x();
  return a.normalized();
}

/// σ_n² n nᵀ + σ_a² a aᵀ + σ_c² c cᵀ: a centre's covariance with the in-plane σ along the track
/// (a, alongTrackInPlane) and across it (c = n × a).
Mat3 viewCovariance(const Vec3& normal, const Vec3& forward, double sigma_normal, double sigma_along, double sigma_across) {
  const Vec3 n = normal.normalized(), a = alongTrackInPlane(n, forward), c = n.cross(a);
  return sigma_normal * sigma_normal * n * n.transpose() + sigma_along * sigma_along * a * a.transpose() +
         sigma_across * sigma_across * c * c.transpose();
}

/// The strips' points at the mounting used and their plan grids, built once.
struct Clouds {
  std::vector<std::vector<Vec3>> x0;
  std::vector<std::unique_ptr<detail::PlanGrid>> grid;
};

Clouds makeClouds(const CalibrationData& data) {
  data.requirePoses();
  Clouds c;
  for (const StripData& s : data.strips) {
    if (s.r_s.size() != s.time_s.size() || (!s.x_m.empty() && s.x_m.size() != s.time_s.size())) {
      throw InvalidInput("strip '" + s.id + "': time, r_s and x_m must have the same length");
    }
    if (s.intensity.size() != s.time_s.size()) {
      throw InvalidInput("strip '" + s.id + "': method \"features\" needs the points' intensity (" + std::to_string(s.intensity.size()) +
                         " intensities for " + std::to_string(s.time_s.size()) + " points)");
    }
    c.x0.push_back(detail::referencePoints(data, s, data.mounting_used));
    c.grid.push_back(std::make_unique<detail::PlanGrid>(c.x0.back(), 2.0));
  }
  return c;
}

/// The platform that saw a view: its mean position, mean time and horizontal forward direction
/// over the view's points.
void setPlatform(const CalibrationData& data, const StripData& strip, const std::vector<std::uint32_t>& group, FeatureView* v) {
  std::size_t cursor = 0;
  Vec3 fwd = Vec3::Zero(), pos = Vec3::Zero();
  double t = 0;
  for (std::uint32_t i : group) {
    const Pose P = data.pose(strip, i, strip.poses.empty() ? &cursor : nullptr);
    fwd += P.R_mb.col(0);
    pos += P.p_m;
    t += strip.time_s[i];
  }
  fwd.z() = 0;
  const double n = static_cast<double>(group.size());
  v->forward = fwd.norm() > 0 ? Vec3(fwd.normalized()) : Vec3::UnitY();
  v->platform_m = pos / n;
  v->time_s = t / n;
}

std::vector<FeatureView> extractWith(const CalibrationData& data, const Clouds& clouds, const PlaneRegion& region,
                                     const FeatureOptions& options, std::vector<RejectedFeature>* rejected,
                                     std::vector<std::vector<std::uint32_t>>* indices) {
  auto reject = [&](const std::string& strip, const std::string& why) {
    if (rejected) rejected->push_back({region.id, strip, why});
  };
  std::vector<std::vector<std::uint32_t>> in_box(data.strips.size());
  std::vector<float> values;
  for (std::size_t s = 0; s < data.strips.size(); ++s) {
    in_box[s] = clouds.grid[s]->box(clouds.x0[s], region.xmin, region.ymin, region.xmax, region.ymax);
    for (std::uint32_t i : in_box[s]) values.push_back(data.strips[s].intensity[i]);
  }
  if (values.empty()) {
    reject("", "no strip has points in the region");
    return {};
  }
  double threshold = options.intensity_threshold;
  if (threshold <= 0) {
    std::vector<float> sorted = values;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2), sorted.end());
    const double median = sorted[sorted.size() / 2];
    const double brightest = *std::max_element(values.begin(), values.end());
    if (!(brightest >= options.min_contrast * std::max(median, 1e-9)) || brightest <= 0) {
      reject("", fmt("no high-intensity points: the brightest is %.0f, the median %.0f (a target needs %.1f times the median)", brightest,
                     median, options.min_contrast));
      return {};
    }
    threshold = otsuThreshold(values);
  }
  std::vector<FeatureView> views;
  std::vector<std::vector<std::uint32_t>> view_indices;
  for (std::size_t s = 0; s < data.strips.size(); ++s) {
    const StripData& strip = data.strips[s];
    const std::vector<Vec3>& X = clouds.x0[s];
    if (in_box[s].empty()) continue;  // the strip does not cover the region
    std::vector<std::uint32_t> bright;
    for (std::uint32_t i : in_box[s])
      if (strip.intensity[i] >= threshold) bright.push_back(i);
    if (static_cast<int>(bright.size()) < options.min_points) {
      reject(strip.id, fmt("%.0f high-intensity points (at least %.0f needed): the strip does not see the target",
                           static_cast<double>(bright.size()), options.min_points));
      continue;
    }
    const double area = std::max((region.xmax - region.xmin) * (region.ymax - region.ymin), 1e-6);
    const double spacing = std::sqrt(area / static_cast<double>(in_box[s].size()));
    const double d = options.growing_distance_m > 0 ? options.growing_distance_m : std::max(1.0, 2.5 * spacing);
    const auto groups = growRegions(X, bright, d);
    if (groups.size() > 1 && static_cast<int>(groups[1].size()) >= options.min_points &&
        static_cast<double>(groups[1].size()) >= options.second_group_fraction * static_cast<double>(groups[0].size())) {
      // Two targets in one region: which one the others' strips matched is unknowable.
      if (rejected) {
        // Drop whatever this region already produced: the whole region goes.
        rejected->push_back({region.id, "",
                             "the region holds more than one target: strip '" + strip.id + "' shows groups of " +
                                 std::to_string(groups[0].size()) + " and " + std::to_string(groups[1].size()) + " high-intensity points " +
                                 fmt("more than %.2f m apart", d)});
      }
      if (indices) indices->clear();
      return {};
    }
    const auto& group = groups[0];
    if (static_cast<int>(group.size()) < options.min_points) {
      reject(strip.id, "its largest group of high-intensity points has " + std::to_string(group.size()) + " points (at least " +
                           std::to_string(options.min_points) + " needed)");
      continue;
    }
    // A target lies inside its region; a bright surface that runs to the region's edge is a road
    // marking or a roof, whose clipped outline would move with the region, not with the strip.
    double edge = 1e300;
    for (std::uint32_t i : group) {
      edge = std::min({edge, X[i].x() - region.xmin, region.xmax - X[i].x(), X[i].y() - region.ymin, region.ymax - X[i].y()});
    }
    if (edge < 0.25) {
      reject(strip.id,
             fmt("its high-intensity points run to the region's edge (%.2f m from it): a marking or surface larger than the region, "
                 "not a target inside it",
                 edge));
      continue;
    }
    detail::PlaneFit fit;
    const std::vector<std::uint32_t> inl = ransacPlane(X, group, options.ransac_threshold_m, options.ransac_iterations, &fit);
    const double fraction = static_cast<double>(inl.size()) / static_cast<double>(group.size());
    if (static_cast<int>(inl.size()) < options.min_points || fraction < options.min_inlier_fraction) {
      reject(strip.id, fmt("not planar: %.0f %% of its %.0f points lie within %.3f m of one plane", 100 * fraction,
                           static_cast<double>(group.size()), options.ransac_threshold_m));
      continue;
    }
    // The feature is the whole group: the intensity (a property of the surface hit) chose its
    // points, so their centroid samples the target evenly. The plane only checks flatness and
    // orients the weights — its inliers at the mounting used would drop the rows that the
    // mounting error displaced most, and bias the centroid.
    const detail::PlaneFit all = detail::fitPlane(group.size(), [&](std::size_t k) { return X[group[k]]; });
    FeatureView v;
    v.strip_id = strip.id;
    v.points = static_cast<int>(group.size());
    v.centroid_m = all.centroid;
    v.normal = fit.normal;
    v.plane_sigma_m = fit.sigma_m;
    const double n = static_cast<double>(group.size());
    v.sigma_normal_m = std::max(fit.sigma_m, 0.002) / std::sqrt(n);
    v.sigma_in_plane_m = options.sigma_in_plane_m > 0 ? options.sigma_in_plane_m : 1.5 * spacing / std::sqrt(n);
    v.threshold = threshold;
    setPlatform(data, strip, group, &v);
    views.push_back(v);
    view_indices.push_back(group);
  }
  if (views.size() < 2) {
    reject("", "seen by " + std::to_string(views.size()) + " strip" + (views.size() == 1 ? "" : "s") + " (at least two needed)");
    return {};
  }
  if (indices) *indices = std::move(view_indices);
  return views;
}

}  // namespace

std::vector<FeatureView> extractFeature(const CalibrationData& data, const PlaneRegion& region, const FeatureOptions& options,
                                        std::vector<RejectedFeature>* rejected, std::vector<std::vector<std::uint32_t>>* indices) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidInput("features options: " + why);
  const Clouds clouds = makeClouds(data);
  return extractWith(data, clouds, region, options, rejected, indices);
}

OutlineCentre outlineCentre(const std::vector<Vec3>& x, const Vec3& normal, int k) {
  OutlineCentre C;
  const std::size_t N = x.size();
  if (N == 0) return C;
  const Vec3 n = normal.normalized();
  Vec3 e1 = n.cross(std::abs(n.z()) < 0.9 ? Vec3::UnitZ() : Vec3::UnitX()).normalized();
  const Vec3 e2 = n.cross(e1);
  Vec3 mean = Vec3::Zero();
  for (const Vec3& p : x) mean += p;
  mean /= static_cast<double>(N);
  std::vector<Eigen::Vector2d> q(N);
  for (std::size_t j = 0; j < N; ++j) q[j] = Eigen::Vector2d(e1.dot(x[j] - mean), e2.dot(x[j] - mean));
  // The minimum-area bounding rectangle: a coarse search over 90°, then refined.
  auto area = [&](double a) {
    const Eigen::Vector2d du(std::cos(a), std::sin(a)), dv(-std::sin(a), std::cos(a));
    double u0 = 1e300, u1 = -1e300, v0 = 1e300, v1 = -1e300;
    for (const auto& p : q) {
      u0 = std::min(u0, p.dot(du)), u1 = std::max(u1, p.dot(du));
      v0 = std::min(v0, p.dot(dv)), v1 = std::max(v1, p.dot(dv));
    }
    return (u1 - u0) * (v1 - v0);
  };
  double best = 0, best_area = 1e300;
  for (int s = 0; s < 90; ++s) {
    const double a = deg2rad(s), A = area(a);
    if (A < best_area) best_area = A, best = a;
  }
  for (double step = deg2rad(0.5); step > deg2rad(0.01); step *= 0.5) {
    for (double a : {best - step, best + step}) {
      const double A = area(a);
      if (A < best_area) best_area = A, best = a;
    }
  }
  C.u = std::cos(best) * e1 + std::sin(best) * e2;
  C.v = n.cross(C.u);
  C.n = n;
  if (k <= 0) {  // the mean of all points
    for (std::size_t j = 0; j < N; ++j) C.weights.emplace_back(j, Mat3::Identity() / static_cast<double>(N));
    C.centre_m = mean;
    return C;
  }
  std::vector<Mat3> W(N, (n * n.transpose()) / static_cast<double>(N));
  const std::size_t kk = std::min<std::size_t>(static_cast<std::size_t>(k), std::max<std::size_t>(1, N / 2));
  for (const Vec3& axis : {C.u, C.v}) {
    std::vector<std::size_t> order(N);
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return axis.dot(x[a]) < axis.dot(x[b]); });
    const Mat3 P = axis * axis.transpose() / (2.0 * static_cast<double>(kk));
    for (std::size_t i = 0; i < kk; ++i) {
      W[order[i]] += P;
      W[order[N - 1 - i]] += P;
    }
  }
  for (std::size_t j = 0; j < N; ++j) {
    if (W[j].isZero(0)) continue;
    C.weights.emplace_back(j, W[j]);
    C.centre_m += W[j] * (x[j] - mean);
  }
  C.centre_m += mean;
  return C;
}

IcpResult matchTranslation(const std::vector<Vec3>& a, const std::vector<Vec3>& b, const Vec3& normal, double sigma_normal_m,
                           double sigma_in_plane_m, int max_iterations, double tolerance_m, const Vec3* initial) {
  IcpResult R;
  if (a.empty() || b.empty()) return R;
  Vec3 ca = Vec3::Zero(), cb = Vec3::Zero();
  for (const Vec3& p : a) ca += p;
  for (const Vec3& q : b) cb += q;
  ca /= static_cast<double>(a.size());
  cb /= static_cast<double>(b.size());
  // Coordinates relative to A's centroid: kilometre-size coordinates never enter the tree.
  std::vector<double> ref(3 * a.size());
  for (std::size_t i = 0; i < a.size(); ++i)
    for (int k = 0; k < 3; ++k) ref[3 * i + k] = a[i](k) - ca(k);
  const detail::KdTree<double, 3> tree(std::move(ref));
  const Vec3 n = normal.normalized();
  const Mat3 W = planeCovariance(n, sigma_normal_m, sigma_in_plane_m).inverse();
  Vec3 t = initial ? *initial : Vec3(ca - cb);
  std::vector<double> q(3 * b.size());
  std::vector<std::size_t> I(b.size());
  std::vector<double> D(b.size());
  for (int it = 0; it < max_iterations; ++it) {
    for (std::size_t j = 0; j < b.size(); ++j)
      for (int k = 0; k < 3; ++k) q[3 * j + k] = b[j](k) + t(k) - ca(k);
    tree.nearestMany(q.data(), b.size(), 1, I.data(), D.data());
    // Trim matches beyond 3 × the median distance (a target edge seen by one strip only).
    std::vector<double> d_sorted(D.begin(), D.end());
    std::nth_element(d_sorted.begin(), d_sorted.begin() + static_cast<long>(d_sorted.size() / 2), d_sorted.end());
    const double limit = 9.0 * std::max(d_sorted[d_sorted.size() / 2], 1e-12);  // squared distances
    Mat3 H = Mat3::Zero();
    Vec3 g = Vec3::Zero();
    double ss = 0;
    int used = 0;
    for (std::size_t j = 0; j < b.size(); ++j) {
      if (D[j] > limit) continue;
      const Vec3 e = (a[I[j]] - ca) - Vec3(q[3 * j], q[3 * j + 1], q[3 * j + 2]);
      H += W;
      g += W * e;
      ss += e.squaredNorm();
      ++used;
    }
    if (used == 0) break;
    const Vec3 dt = H.ldlt().solve(g);
    t += dt;
    R.iterations = it + 1;
    R.rms_m = std::sqrt(ss / used);
    if (dt.norm() < tolerance_m) {
      R.converged = true;
      break;
    }
  }
  R.translation_m = t;
  R.covariance = W.inverse();
  return R;
}

namespace {

/// The sample standard deviation of at least two values.
double sampleStandardDeviation(const std::vector<double>& x) {
  const double mean = std::accumulate(x.begin(), x.end(), 0.0) / static_cast<double>(x.size());
  double v = 0;
  for (double e : x) v += (e - mean) * (e - mean);
  return std::sqrt(v / static_cast<double>(x.size() - 1));
}

/// What the closed form could not determine, and the one-height coupling, in words.
std::string closedFormMessage(const std::array<bool, 5>& use, bool pitch_lever_arm_coupled) {
  std::string held;
  const char* names[3] = {"roll", "pitch", "heading"};
  for (int j = 0; j < 3; ++j)
    if (!use[j]) held += std::string(held.empty() ? "" : ", ") + names[j];
  if (!held.empty()) held += " not determined (roll and pitch need opposite pairs, heading same-direction lines offset sideways)";
  if (pitch_lever_arm_coupled) {
    held += std::string(held.empty() ? "" : "; ") +
            "one flight height: pitch and the along-track lever arm are coupled (Δ_along = 2(ε_φ H + η_x)); the lever arm is "
            "taken as measured — fly a second height to separate them";
  }
  return held;
}

}  // namespace

FeatureClosedForm closedFormBoresight(const std::vector<FeaturePairOffset>& pairs, const MountingParameters& used,
                                      const FeatureOptions& options) {
  FeatureClosedForm C;
  C.mounting = used;
  // Unknowns u = (ε_ω, ε_φ, ε_κ, η_x, η_y). SPEC §2 "Closed-form boresight" (seed 002 eqs. 8–10)
  // for targets abeam, each strip's error in its own along / right / down axes being
  //   e = (ε_φ H − ε_κ y + η_x,  η_y − ε_ω H,  ε_ω y),
  // differenced between A and B (B's along and right axes reversed when it flies the other way).
  // With H_A = H_B and y_B = −y_A (opposite, one line) or y_B = y_A − D (same direction) these are
  // the SPEC's forms; unequal heights (a second height) add the terms in H_A ∓ H_B.
  struct Row {
    Eigen::Matrix<double, 5, 1> a;
    double y, w;
  };
  std::vector<Row> rows;
  std::vector<double> heights;
  std::vector<double> single[3];
  for (const FeaturePairOffset& p : pairs) {
    const double HA = p.height_m, HB = p.height_b_m, yA = p.lateral_a_m, yB = p.lateral_b_m;
    const Vec3& d = p.offset_afd_m;
    const Vec3 sig = p.covariance_afd.diagonal().cwiseMax(1e-12).cwiseSqrt();
    Row along{}, cross{}, down{};
    if (p.relation == "opposite") {
      along.a << 0, HA + HB, -(yA + yB), 2, 0;
      cross.a << -(HA + HB), 0, 0, 0, 2;
      heights.push_back(HA), heights.push_back(HB);
      single[1].push_back(d(0) / (HA + HB));   // η_x taken as 0
      single[0].push_back(-d(1) / (HA + HB));  // η_y taken as 0
      ++C.pairs_used[0], ++C.pairs_used[1];
    } else if (p.relation == "same") {
      along.a << 0, HA - HB, -(yA - yB), 0, 0;
      cross.a << -(HA - HB), 0, 0, 0, 0;
      if (std::abs(yA - yB) > 1.0) {
        single[2].push_back(-d(0) / (yA - yB));  // same height assumed
        ++C.pairs_used[2];
      }
      if (std::abs(HA - HB) > 1.0) ++C.pairs_used[1];
    } else {
      continue;  // crossing lines: not the paper's geometry
    }
    down.a << yA - yB, 0, 0, 0, 0;
    along.y = d(0), along.w = 1 / sig(0);
    cross.y = d(1), cross.w = 1 / sig(1);
    down.y = d(2), down.w = 1 / sig(2);
    rows.push_back(along), rows.push_back(cross), rows.push_back(down);
  }
  if (rows.empty()) {
    C.message = "no pair of strips flown in opposite or in the same direction sees a common target";
    return C;
  }
  // Which unknowns the pairs reach: an angle needs a coefficient of a metre somewhere; the lever
  // arm needs opposite pairs at two heights (otherwise it is coupled with pitch and roll).
  std::array<bool, 5> use{};
  for (const Row& r : rows)
    for (int j = 0; j < 3; ++j) use[j] = use[j] || std::abs(r.a(j)) > 1.0;
  if (!heights.empty()) {
    const auto [lo, hi] = std::minmax_element(heights.begin(), heights.end());
    const double mean = std::accumulate(heights.begin(), heights.end(), 0.0) / static_cast<double>(heights.size());
    if (*hi - *lo >= options.min_height_spread * mean) {
      use[3] = use[4] = true;
      C.lever_arm_estimated = true;
    } else {
      C.pitch_lever_arm_coupled = true;
    }
  }
  std::vector<int> cols;
  for (int j = 0; j < 5; ++j)
    if (use[j]) cols.push_back(j);
  if (cols.empty()) {
    C.message = "the pairs determine no angle (no opposite pairs, no same-direction lines offset sideways)";
    return C;
  }
  const int m = static_cast<int>(rows.size()), k = static_cast<int>(cols.size());
  Eigen::MatrixXd A(m, k);
  Eigen::VectorXd y(m);
  for (int i = 0; i < m; ++i) {
    for (int c = 0; c < k; ++c) A(i, c) = rows[i].a(cols[c]) * rows[i].w;
    y(i) = rows[i].y * rows[i].w;
  }
  const Eigen::MatrixXd N = A.transpose() * A;
  const Eigen::VectorXd s = N.diagonal().cwiseMax(1e-300).cwiseSqrt().cwiseInverse();
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(s.asDiagonal() * N * s.asDiagonal());
  const double cond = svd.singularValues()(0) / std::max(svd.singularValues()(k - 1), 1e-300);
  if (!(cond < 1e10)) {
    C.message = "the pairs do not determine the angles (normal matrix singular)";
    return C;
  }
  const Eigen::VectorXd u = N.ldlt().solve(A.transpose() * y);
  const Eigen::MatrixXd Q = N.inverse();
  const int dof = m - k;
  const double s0 = dof > 0 ? (A * u - y).squaredNorm() / dof : 1.0;
  // The first-order model's own error dominates the residuals: σ from the a-posteriori variance.
  const double scale = std::max(s0, 1.0);
  for (int c = 0; c < k; ++c) {
    const int j = cols[c];
    const double sd = std::sqrt(Q(c, c) * scale);
    if (j < 3) {
      C.boresight_correction_rad(j) = u(c);
      C.boresight_sigma_rad(j) = sd;
    } else {
      C.lever_arm_correction_m(j - 3) = u(c);
      C.lever_arm_sigma_m(j - 3) = sd;
    }
  }
  for (int j = 0; j < 3; ++j)
    if (single[j].size() >= 2) C.boresight_spread_rad(j) = sampleStandardDeviation(single[j]);
  C.valid = true;
  C.message = closedFormMessage(use, C.pitch_lever_arm_coupled);
  C.mounting.boresight = used.boresight - C.boresight_correction_rad;
  C.mounting.a_b = used.a_b - C.lever_arm_correction_m;
  return C;
}

// ---- the observation source ------------------------------------------------------------------

namespace {

/// One strip's view of a target: r = W^½ (c0 + K vec(ΔR_bs) + R̄ Δa + o − X), with per-laser
/// elevation offsets δ (a fourth block) + Σ_l [(cos δ_l − 1) K_r,l + sin δ_l K_u,l] vec(R_bs(M)),
/// or with more groups Σ_l featureLaserTermMatrix(K_all,l, δ_l) vec(R_bs(M)).
struct FeatureViewResidual {
  const FeatureObservations::View* v;
  const MountingParameters* used;
  Mat3 R_bs_used;
  const detail::LaserLayout* layout = nullptr;  // the laser block's (null: no block)
  bool operator()(double const* const* p, double* r) const {
    const double *m = p[0], *X = p[1], *o = p[2];
    const Mat3 dR = detail::cachedMountingMotion(used->R_nom, R_bs_used, used->a_b, m).dR_bs;
    const Eigen::Map<const Eigen::Matrix<double, 9, 1>> vecR(dR.data());
    Vec3 c = v->c0_rel + v->K * vecR + v->R_bar * (Vec3(m[0], m[1], m[2]) - used->a_b);
    if (!v->lasers.empty()) {
      const Mat3 R_bs = R_bs_used + dR;
      const Eigen::Map<const Eigen::Matrix<double, 9, 1>> vecRbs(R_bs.data());
      for (const auto& t : v->lasers) {
        if (!t.K_all.empty()) {
          c += detail::featureLaserTermMatrix(t.K_all, layout->correction(p[3], t.laser)) * vecRbs;
          continue;
        }
        const double d = p[3][t.laser];
        c += ((std::cos(d) - 1.0) * t.K_r + std::sin(d) * t.K_u) * vecRbs;
      }
    }
    const Vec3 e = c + Vec3(o[0], o[1], o[2]) - Vec3(X[0], X[1], X[2]);
    Eigen::Map<Vec3> out(r);
    out = v->sqrt_info * e;
    return true;
  }
};

Mat3 sqrtInformation(const Mat3& cov) {
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(cov);
  return eig.eigenvalues().cwiseMax(1e-18).cwiseInverse().cwiseSqrt().asDiagonal() * eig.eigenvectors().transpose();
}

}  // namespace

FeatureObservations::~FeatureObservations() = default;

FeatureObservations::FeatureObservations(const CalibrationData& data, const FeatureOptions& options)
    : options_(options), used_(data.mounting_used) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidInput("features options: " + why);
  if (options.estimatesLaserIntrinsics()) {
    laser_ = std::make_unique<detail::LaserIntrinsicsBlock>();
    laser_->setUp(data, "features", options.laserPrior());
  }
  auto clock = [] { return std::chrono::steady_clock::now(); };
  const auto t0 = clock();
  const Clouds clouds = makeClouds(data);
  std::unordered_map<std::string, std::size_t> strip_index;
  for (std::size_t s = 0; s < data.strips.size(); ++s) strip_index[data.strips[s].id] = s;
  std::vector<std::vector<std::vector<Vec3>>> target_points;  // per target, per view
  std::vector<std::vector<Vec3>> target_means;                // per target, per view: the points' mean
  for (const PlaneRegion& region : data.target_regions) {
    std::vector<std::vector<std::uint32_t>> idx;
    std::vector<FeatureView> views = extractWith(data, clouds, region, options_, &section_.rejected, &idx);
    if (views.empty()) continue;
    Target T;
    T.id = region.id;
    std::vector<std::vector<Vec3>> pts;
    std::vector<ViewPoints> vps;
    std::vector<Vec3> means;
    for (std::size_t k = 0; k < views.size(); ++k) {
      const std::size_t s = strip_index.at(views[k].strip_id);
      const StripData& strip = data.strips[s];
      ViewPoints vp;
      vp.strip_id = strip.id;
      vp.normal = views[k].normal;
      vp.forward = views[k].forward;
      std::size_t cursor = 0;
      for (std::uint32_t i : idx[k]) {
        vp.R_mb.push_back(data.pose(strip, i, strip.poses.empty() ? &cursor : nullptr).R_mb);
        vp.r_s.push_back(strip.r_s[i]);
        if (options_.estimatesLaserIntrinsics()) vp.laser.push_back(strip.laser[i]);
        vp.x0.push_back(clouds.x0[s][i]);
        vp.time_s += strip.time_s[i] / static_cast<double>(idx[k].size());
      }
      Vec3 mean = Vec3::Zero();
      for (const Vec3& x : vp.x0) mean += x / static_cast<double>(vp.x0.size());
      means.push_back(mean);
      // The view's position of the target: its outline's centre at the mounting used.
      views[k].centroid_m = outlineCentre(vp.x0, vp.normal, options_.edge_points).centre_m;
      T.reference_m += views[k].centroid_m / static_cast<double>(views.size());
      pts.push_back(vp.x0);
      vps.push_back(std::move(vp));
    }
    section_.target_ids.push_back(T.id);
    section_.views.push_back(views);
    targets_.push_back(std::move(T));
    points_.push_back(std::move(vps));
    target_points.push_back(std::move(pts));
    target_means.push_back(std::move(means));
  }
  if (options_.sigma_in_plane_m > 0) sigma_a_ = sigma_c_ = options_.sigma_in_plane_m;
  const auto t1 = clock();
  section_.extraction_time_s = std::chrono::duration<double>(t1 - t0).count();

  // ---- matching: every pair of strips that see a target, and the closed form ------------------
  for (std::size_t k = 0; k < targets_.size(); ++k) {
    const std::vector<FeatureView>& views = section_.views[k];
    for (std::size_t i = 0; i < views.size(); ++i)
      for (std::size_t j = i + 1; j < views.size(); ++j) {
        const FeatureView &A = views[i], &B = views[j];
        FeaturePairOffset P;
        P.target_id = targets_[k].id;
        P.strip_a = A.strip_id;
        P.strip_b = B.strip_id;
        const double sn = std::hypot(A.sigma_normal_m, B.sigma_normal_m), st = std::hypot(A.sigma_in_plane_m, B.sigma_in_plane_m);
        // At the mounting used the rows of different lasers are displaced against each other by
        // the mounting error itself (a 1° heading error moves rows seen 13 m ahead and behind by
        // ±0.2 m): the outline's extremes follow that smear, the mean of all points averages it.
        const Vec3 start = target_means[k][i] - target_means[k][j];
        const IcpResult icp = matchTranslation(target_points[k][i], target_points[k][j], A.normal, sn, st, options_.icp_max_iterations,
                                               options_.icp_tolerance_m, &start);
        // Across the target's plane a matching of two differently sampled outlines is ill-posed
        // (point-to-point pairs drift along the board); the points' means give it. Along the
        // normal, the point-to-plane ICP.
        const Vec3 nA = A.normal.normalized();
        P.offset_m = start - nA * nA.dot(start) + nA * nA.dot(icp.translation_m);
        P.icp_iterations = icp.iterations;
        P.icp_rms_m = icp.rms_m;
        const Vec3 down(0, 0, -1);
        const Vec3 along = A.forward, right = down.cross(along);
        Mat3 R_afd;  // rows: A's along, right, down axes
        R_afd.row(0) = along.transpose();
        R_afd.row(1) = right.transpose();
        R_afd.row(2) = down.transpose();
        P.offset_afd_m = R_afd * P.offset_m;
        P.covariance = icp.covariance;
        P.covariance_afd = R_afd * icp.covariance * R_afd.transpose();
        const Vec3 target = 0.5 * (A.centroid_m + B.centroid_m);
        P.height_m = A.platform_m.z() - target.z();
        P.height_b_m = B.platform_m.z() - target.z();
        P.lateral_a_m = right.dot(target - A.platform_m);
        P.lateral_b_m = down.cross(B.forward).dot(target - B.platform_m);
        const double cosang = A.forward.dot(B.forward);
        const double tol = std::cos(deg2rad(options_.direction_tolerance_deg));
        if (cosang >= tol) {
          P.relation = "same";
          P.line_offset_m = P.lateral_a_m - P.lateral_b_m;
        } else if (cosang <= -tol) {
          P.relation = "opposite";
        } else {
          P.relation = "crossing";
        }
        section_.pairs.push_back(P);
      }
  }
  section_.closed_form = closedFormBoresight(section_.pairs, used_, options_);
  section_.matching_time_s = std::chrono::duration<double>(clock() - t1).count();
  section_.targets_used = static_cast<int>(targets_.size());
  section_.views_used = 0;
  for (const auto& vps : points_) section_.views_used += static_cast<int>(vps.size());
}

void FeatureObservations::select(const std::array<double, 6>& m) {
  const Mat3 R_bs_used = used_.R_bs();
  const detail::MountingMotion motion(used_.R_nom, R_bs_used, used_.a_b, m.data());
  for (std::size_t k = 0; k < targets_.size(); ++k) {
    Target& T = targets_[k];
    T.views.clear();
    for (const ViewPoints& vp : points_[k]) {
      std::vector<Vec3> x(vp.x0.size());
      for (std::size_t j = 0; j < x.size(); ++j) x[j] = vp.x0[j] + motion.displacement(vp.R_mb[j], vp.r_s[j]);
      // Which points are extreme is decided at m; the centre stays the same fixed combination
      // of fixed pulses while the adjustment moves the mounting (exact re-georeferencing).
      const OutlineCentre oc = outlineCentre(x, vp.normal, options_.edge_points);
      View V;
      V.strip_id = vp.strip_id;
      V.time_s = vp.time_s;
      for (std::size_t j = 0; j < vp.r_s.size(); ++j)
        V.u_m += vp.R_mb[j] * (R_bs_used * vp.r_s[j] + used_.a_b) / static_cast<double>(vp.r_s.size());
      Vec3 c0 = Vec3::Zero();
      for (const auto& [j, W] : oc.weights) {
        c0 += W * (vp.x0[j] - T.reference_m);
        const Mat3 WR = W * vp.R_mb[j];
        // K vec(ΔR) = Σ_j W_j R_mb,j ΔR r_j: column (a, b) of vec (column-major) is Σ W_j R_mb,j e_a r_j(b).
        for (int b = 0; b < 3; ++b)
          for (int a = 0; a < 3; ++a) V.K.col(3 * b + a) += WR.col(a) * vp.r_s[j](b);
        V.R_bar += WR;
        if (vp.laser.empty()) continue;
        const int id = vp.laser[j];  // (a structured binding cannot be captured in C++17)
        auto t = std::find_if(V.lasers.begin(), V.lasers.end(), [id](const View::LaserTerm& x) { return x.laser == id; });
        if (t == V.lasers.end()) {
          View::LaserTerm fresh;  // K_r, K_u zero
          fresh.laser = id;
          t = V.lasers.insert(V.lasers.end(), fresh);
        }
        if (!laser_->layout().elevationOnly()) {  // every group: K_all (K_r, K_u unused)
          detail::addFeatureLaserTerms(WR, LaserRay(vp.r_s[j]), &t->K_all);
          continue;
        }
        const Vec3 u = elevationTangent(vp.r_s[j]);
        for (int b = 0; b < 3; ++b)
          for (int a = 0; a < 3; ++a) {
            t->K_r.col(3 * b + a) += WR.col(a) * vp.r_s[j](b);
            t->K_u.col(3 * b + a) += WR.col(a) * u(b);
          }
      }
      V.c0_rel = c0;
      V.sqrt_info = sqrtInformation(viewCovariance(oc.n, vp.forward, sigma_n_, sigma_a_, sigma_c_));
      T.views.push_back(V);
    }
  }
  selected_at_ = m;
  selected_ = true;
}

void FeatureObservations::addBlocks(const std::array<double, 6>& mounting, AdjustmentProblem* problem) {
  if (!selected_ || mounting != selected_at_) select(mounting);
  const Mat3 R_bs_used = used_.R_bs();
  ceres::NumericDiffOptions nd;
  nd.relative_step_size = problem->numericDiffRelativeStep();
  blocks_.assign(targets_.size(), {});
  double* lasers = nullptr;
  if (laser_) {
    // Priors: each offset N(0, σ); their mean over the lasers the outlines use held at 0 (the
    // boresight pitch's direction, as in the dense correspondences).
    std::vector<bool> seen(static_cast<std::size_t>(laser_->lasers()), false);
    for (const Target& T : targets_)
      for (const View& v : T.views)
        for (const View::LaserTerm& t : v.lasers) seen[static_cast<std::size_t>(t.laser)] = true;
    lasers = laser_->add(problem, seen);
  }
  for (std::size_t k = 0; k < targets_.size(); ++k) {
    Target& T = targets_[k];
    const double zero[3] = {0, 0, 0};
    T.block = problem->addNuisanceBlock(3, zero);
    for (const View& v : T.views) {
      auto* cost = new ceres::DynamicNumericDiffCostFunction<FeatureViewResidual, ceres::CENTRAL>(
          new FeatureViewResidual{&v, &used_, R_bs_used, laser_ ? &laser_->layout() : nullptr}, ceres::TAKE_OWNERSHIP, nd);
      for (int size : {6, 3, 3}) cost->AddParameterBlock(size);
      std::vector<double*> blocks = {problem->mounting(), T.block, problem->stripOffset(v.strip_id)};
      if (lasers) cost->AddParameterBlock(laser_->layout().size), blocks.push_back(lasers);
      cost->SetNumResiduals(3);
      blocks_[k].push_back(problem->addResidualBlock(cost, sigmaInPlane(), blocks));
      problem->setEpoch(blocks_[k].back(), v.strip_id, v.time_s, v.u_m, options_.sigma_in_plane_m <= 0);
    }
  }
}

std::vector<int> FeatureObservations::viewRecords() const {
  std::vector<int> out;
  for (const auto& target_blocks : blocks_) out.insert(out.end(), target_blocks.begin(), target_blocks.end());
  return out;
}

void FeatureObservations::solved(const AdjustmentProblem& problem) {
  if (laser_) laser_->solved();
  settled_ = true;
  if (options_.sigma_in_plane_m > 0) return;
  // Variance components (after Förstner): σ² = Σ e² / Σ r per component, r each residual's
  // redundancy number (1 − its leverage in the whole adjustment, AdjustmentProblem::leverage):
  // the target points take one view's worth per target, and the mounting, the strip offsets
  // and the per-laser offsets what they fit — sixteen elevation offsets take up much of the
  // along-track scatter, and counting only the targets' (V − 1) per axis stated their σ about
  // half what their errors show (RMS of error/σ 1.7–2.0 over 20 seeds). In the plane two
  // components, along the viewing strip's track and across it: a scanner samples a target in
  // rows and along scan lines at different spacings, so one isotropic σ would state the finer
  // axis too large and the coarser too small (the UAV preset's VLP-16: roll and lever y σ about
  // 1.2× large, pitch and lever x small, over 100 seeds with one in-plane σ).
  const std::vector<Eigen::MatrixXd> H = problem.leverage(viewRecords());
  double ss_n = 0, ss_a = 0, ss_c = 0, red_n = 0, red_a = 0, red_c = 0;
  std::size_t at = 0;
  for (std::size_t k = 0; k < targets_.size(); ++k) {
    const Target& T = targets_[k];
    for (std::size_t j = 0; j < T.views.size(); ++j, ++at) {
      const Vec3 e = T.views[j].sqrt_info.inverse() * problem.residual(blocks_[k][j]);
      const ViewPoints& vp = points_[k][j];
      const Vec3 n = vp.normal.normalized(), a = alongTrackInPlane(n, vp.forward), c = n.cross(a);
      ss_n += std::pow(n.dot(e), 2);
      ss_a += std::pow(a.dot(e), 2);
      ss_c += std::pow(c.dot(e), 2);
      // An axis x in the whitened residual's space: the unit vector along sqrt_info x.
      auto redundancy = [&](const Vec3& x) {
        const Vec3 q = (T.views[j].sqrt_info * x).normalized();
        return 1.0 - q.dot(H[at] * q);
      };
      red_n += redundancy(n);
      red_a += redundancy(a);
      red_c += redundancy(c);
    }
  }
  if (!(std::min({red_n, red_a, red_c}) >= 1.0)) return;
  const double sn = std::max(std::sqrt(ss_n / red_n), 0.001), sa = std::max(std::sqrt(ss_a / red_a), 0.002),
               sc = std::max(std::sqrt(ss_c / red_c), 0.002);
  auto near = [](double x, double y) { return std::abs(x / y - 1) < 0.05; };
  settled_ = near(sa, sigma_a_) && near(sc, sigma_c_) && near(sn, sigma_n_);
  sigma_n_ = sn;
  sigma_a_ = sa;
  sigma_c_ = sc;
  selected_ = false;  // rebuild the weights with the new σ
}

void FeatureObservations::finish(const std::array<double, 6>& /*m0*/, const std::array<double, 6>& /*m*/, const AdjustmentProblem& problem,
                                 const AnalysisOptions& /*analysis*/) {
  section_.residuals.clear();
  section_.sigma_normal_m = sigma_n_;
  section_.sigma_in_plane_m = sigmaInPlane();
  section_.sigma_along_track_m = sigma_a_;
  section_.sigma_across_track_m = sigma_c_;
  section_.sigma_estimated = options_.sigma_in_plane_m <= 0;
  Vec3 ss_before = Vec3::Zero(), ss_after = Vec3::Zero();
  int n = 0;
  for (std::size_t k = 0; k < targets_.size(); ++k) {
    const Target& T = targets_[k];
    Vec3 mean0 = Vec3::Zero();
    for (const View& v : T.views) mean0 += v.c0_rel;
    mean0 /= static_cast<double>(T.views.size());
    for (std::size_t j = 0; j < T.views.size(); ++j) {
      const View& v = T.views[j];
      FeatureSection::Residual r;
      r.target_id = T.id;
      r.strip_id = v.strip_id;
      r.before_m = v.c0_rel - mean0;
      r.after_m = v.sqrt_info.inverse() * problem.residual(blocks_[k][j]);
      ss_before += r.before_m.cwiseAbs2();
      ss_after += r.after_m.cwiseAbs2();
      ++n;
      section_.residuals.push_back(r);
    }
  }
  if (n > 0) {
    section_.rms_before_m = (ss_before / n).cwiseSqrt();
    section_.rms_after_m = (ss_after / n).cwiseSqrt();
  }
  if (laser_) {
    std::vector<int> points(static_cast<std::size_t>(laser_->lasers()), 0);
    for (const auto& vps : points_)
      for (const ViewPoints& vp : vps)
        for (int l : vp.laser) ++points[static_cast<std::size_t>(l)];
    // The offsets' own covariance with the views' share from their leave-one-out residuals
    // (AdjustmentProblem::leaveOneOutCovariance, in place of its formal part; the trajectory
    // errors' term stays): an offset is fitted to the few views whose outline its rows bound,
    // and the fit hides their sampling error in small residuals — over 60 seeds the formal σ
    // were 1.5–1.6 times small (RMS of error/σ), these 1.11–1.18 (seeds 61–120). The boresight
    // keeps the formal part: many views determine it, and its σ are honest (its sandwich would
    // state them 1.2–1.7 times large, RMS 0.49–0.98).
    Eigen::MatrixXd formal, loo;
    if (laser_->block()) loo = problem.leaveOneOutCovariance(laser_->block(), viewRecords(), &formal);
    section_.laser_intrinsics = laser_->finish(problem, points, loo.size() > 0 ? Eigen::MatrixXd(loo - formal) : Eigen::MatrixXd());
  }
}

namespace detail {

void addFeatureLaserTerms(const Mat3& WR, const LaserRay& ray, FeatureLaserTerms* K) {
  if (K->empty()) K->assign(16, Eigen::Matrix<double, 3, 9>::Zero());
  const double inv_rho = ray.rho > 0 ? 1.0 / ray.rho : 0.0;
  const std::array<Vec3, 5> f{ray.r, ray.u, inv_rho * ray.r, inv_rho * ray.u, ray.p};
  for (std::size_t i = 0; i < 5; ++i) {
    // R_z(δα) v = v + (cos δα − 1) (v_x, v_y, 0) + sin δα (v_y, −v_x, 0) (LaserCorrector's R_z).
    const std::array<Vec3, 3> variants{f[i], Vec3(f[i].x(), f[i].y(), 0.0), Vec3(f[i].y(), -f[i].x(), 0.0)};
    for (std::size_t w = 0; w < 3; ++w)
      for (int b = 0; b < 3; ++b)
        for (int a = 0; a < 3; ++a) (*K)[3 * i + w].col(3 * b + a) += WR.col(a) * variants[w](b);
  }
  for (int a = 0; a < 3; ++a) (*K)[15].col(3 * 2 + a) += WR.col(a);  // e_z: its only entry b = 2
}

Eigen::Matrix<double, 3, 9> featureLaserTermMatrix(const FeatureLaserTerms& K, const LaserCorrection& c) {
  const double cw = std::cos(c.elevation_rad), sw = std::sin(c.elevation_rad);
  const double ca1 = std::cos(c.azimuth_rad) - 1.0, sa = std::sin(c.azimuth_rad);
  // r' = R_z Σ s_f f + δV e_z with f ∈ {r, u, r/ρ, u/ρ, p}; less the table's own r.
  const std::array<double, 5> s{cw, sw, c.range_m * cw, c.range_m * sw, c.horizontal_m};
  Eigen::Matrix<double, 3, 9> M = c.vertical_m * K[15] - K[0];
  for (std::size_t i = 0; i < 5; ++i) M += s[i] * (K[3 * i] + ca1 * K[3 * i + 1] + sa * K[3 * i + 2]);
  return M;
}

}  // namespace detail

}  // namespace mountcal
