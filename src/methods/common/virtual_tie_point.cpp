#include "methods/common/vtp_strip.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <algorithm>
#include <cmath>
#include <map>
#include <random>

#include "mountcal/core/error.hpp"
#include "geometry/kd_tree.hpp"
#include "geometry/plane_ransac.hpp"
#include "mountcal/core/georeference_model.hpp"

namespace mountcal {

// ------------------------------------------------------------------------------------------
double interpolateHeight(const Vec3& p1, const Vec3& p2, const Vec3& p3, double x, double y) {
  // seed eq. (5)
  const double dX21 = p2.x() - p1.x(), dY21 = p2.y() - p1.y(), dZ21 = p2.z() - p1.z();
  const double dX31 = p3.x() - p1.x(), dY31 = p3.y() - p1.y(), dZ31 = p3.z() - p1.z();
  const double num = (p1.x() - x) * (dY21 * dZ31 - dY31 * dZ21) - (p1.y() - y) * (dX21 * dZ31 - dX31 * dZ21);
  return p1.z() + num / (dX21 * dY31 - dX31 * dY21);
}

void fitRigidTransform(const Vec3* p, const Vec3* q, int n, Mat3* R, Vec3* t) {
  Vec3 cp = Vec3::Zero(), cq = Vec3::Zero();
  for (int i = 0; i < n; ++i) {
    cp += p[i];
    cq += q[i];
  }
  cp /= n;
  cq /= n;
  Mat3 H = Mat3::Zero();
  for (int i = 0; i < n; ++i) H += (p[i] - cp) * (q[i] - cq).transpose();
  const Eigen::JacobiSVD<Mat3> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 D = Mat3::Identity();
  D(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1.0 : 1.0;
  *R = svd.matrixV() * D * svd.matrixU().transpose();
  *t = cq - *R * cp;
}

// ------------------------------------------------------------------------------------------
VirtualTiePoint::VirtualTiePoint(std::string tie_id, std::string strip_id, double pick_x_m, double pick_y_m,
                                 const std::array<LaserFootprint, 3>& vertices, const MountingParameters& reference)
    : tie_id_(std::move(tie_id)),
      strip_id_(std::move(strip_id)),
      vertices_(vertices),
      R_nom_(reference.R_nom),
      R_bs0_(reference.R_bs()),
      a0_b_(reference.a_b) {
  // Rule 1 (seed eq. 5): height of the pick on the triangle's plane.
  const double z = interpolateHeight(vertices_[0].x0_m, vertices_[1].x0_m, vertices_[2].x0_m, pick_x_m, pick_y_m);
  P0_m_ = Vec3(pick_x_m, pick_y_m, z);
  centroid0_m_ = (vertices_[0].x0_m + vertices_[1].x0_m + vertices_[2].x0_m) / 3.0;
  for (int i = 0; i < 3; ++i) d0_m_[i] = vertices_[i].x0_m - centroid0_m_;
  P0_rel_m_ = P0_m_ - centroid0_m_;
}

void VirtualTiePoint::setMotionSupport(std::vector<LaserFootprint> points, std::vector<double> weights, std::vector<int> groups) {
  const std::string self = "virtual tie point '" + tie_id_ + "' on strip '" + strip_id_ + "': ";
  if (points.empty()) throw InvalidInput(self + "empty motion support");
  if (weights.empty()) weights.assign(points.size(), 1.0);
  if (weights.size() != points.size()) throw InvalidInput(self + "motion weights and points differ in number");
  if (!groups.empty() && groups.size() != points.size()) throw InvalidInput(self + "motion groups and points differ in number");
  double sum = 0;
  for (double w : weights) {
    if (!(w > 0) || !std::isfinite(w)) throw InvalidInput(self + "a motion weight is not positive and finite");
    sum += w;
  }
  for (double& w : weights) w /= sum;
  // The weights changed as little as they can, Σ (w_i − u_i)² / u_i, so that the points' weighted
  // plan centroid is the pick and each group keeps its share: δ_i = u_i λᵀ d_i, d_i = x_i − x̄_g(i),
  // with S λ = pick − Σ u_i x_i, S = Σ u_i d_i d_iᵀ in plan (Lagrange; x̄_g each group's weighted
  // centroid). A direction the groups spread along by less than a centimetre is left as it was:
  // a neighbourhood of one scan row would give weights of thousands.
  const std::size_t n = points.size();
  auto groupOf = [&](std::size_t i) { return groups.empty() ? 0 : groups[i]; };
  std::map<int, std::pair<double, Eigen::Vector2d>> group_mean;  // share, weighted plan centroid
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    auto& g = group_mean.try_emplace(groupOf(i), 0.0, Eigen::Vector2d::Zero()).first->second;
    g.first += weights[i];
    g.second += weights[i] * points[i].x0_m.head<2>();
    centroid += weights[i] * points[i].x0_m.head<2>();
  }
  for (auto& g : group_mean) g.second.second /= g.second.first;
  std::vector<Eigen::Vector2d> d(n);
  Eigen::Matrix2d S = Eigen::Matrix2d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    d[i] = points[i].x0_m.head<2>() - group_mean.at(groupOf(i)).second;
    S += weights[i] * d[i] * d[i].transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(S);
  const Eigen::Vector2d r = P0_m_.head<2>() - centroid;
  Eigen::Vector2d lambda = Eigen::Vector2d::Zero();
  for (int k = 0; k < 2; ++k) {
    const double e = eig.eigenvalues()[k];
    if (e > 1e-6 * std::max(eig.eigenvalues()[1], 1e-300) && e > 1e-4)
      lambda += eig.eigenvectors().col(k) * (eig.eigenvectors().col(k).dot(r) / e);
  }
  for (std::size_t i = 0; i < n; ++i) weights[i] += weights[i] * lambda.dot(d[i]);
  support_ = std::move(points);
  weights_ = std::move(weights);
  // P⁰ = Σ w_i x_i(M₀): the pick with the neighbourhood's height there (Rule 1 on the points around
  // it, not on one triangle); centroid() the points' plain mean.
  Vec3 c = Vec3::Zero(), P = Vec3::Zero();
  for (std::size_t i = 0; i < n; ++i) P += weights_[i] * support_[i].x0_m;
  for (const LaserFootprint& f : support_) c += f.x0_m;
  centroid0_m_ = c / static_cast<double>(n);
  for (LaserFootprint& f : support_) f.x0_m -= centroid0_m_;
  P0_m_ = P;
  P0_rel_m_ = P0_m_ - centroid0_m_;
}

Vec3 VirtualTiePoint::relativePosition(const double* m) const {
  // Rule 2: georeference the vertices with M (seed eq. 1) — as displacements from their
  // reference positions — fit the rigid motion of the triangle (seed eq. 6), carry P⁰ along.
  const Mat3 dR_bs = R_zyx(Vec3(m[3], m[4], m[5])) * R_nom_ - R_bs0_;
  const Vec3 da_b = Vec3(m[0], m[1], m[2]) - a0_b_;
  if (!support_.empty()) {
    // VtpMotion::kNeighbourhood: P(M) − c = Σ_i w_i (x_i(M) − c), x_i(M) − x_i(M₀) = R_mb,i [(R_bs(M) − R_bs(M₀)) r_s,i + (a − a₀)].
    Vec3 mean = Vec3::Zero();
    for (std::size_t i = 0; i < support_.size(); ++i) mean += weights_[i] * (support_[i].pose.R_mb * (dR_bs * support_[i].r_s + da_b));
    return P0_rel_m_ + mean;
  }
  Vec3 q[3];
  for (int i = 0; i < 3; ++i) q[i] = d0_m_[i] + vertices_[i].pose.R_mb * (dR_bs * vertices_[i].r_s + da_b);
  Mat3 R;
  Vec3 t;
  fitRigidTransform(d0_m_.data(), q, 3, &R, &t);
  return R * P0_rel_m_ + t;
}

Vec3 VirtualTiePoint::position(const double* m) const { return centroid0_m_ + relativePosition(m); }

Vec3 VirtualTiePoint::position(const MountingParameters& m) const {
  const auto a = m.toArray();
  return position(a.data());
}

// ------------------------------------------------------------------------------------------
struct VtpStrip::Index {
  detail::KdTree<double, 2> plan;  // the points' (x, y)
};

VtpStrip::VtpStrip(StripData strip, std::shared_ptr<const Trajectory> trajectory, const MountingParameters& reference)
    : strip_(std::move(strip)), trajectory_(std::move(trajectory)), reference_(reference), index_(std::make_unique<Index>()) {
  const std::size_t n = strip_.time_s.size();
  if (strip_.r_s.size() != n || (!strip_.x_m.empty() && strip_.x_m.size() != n)) {
    throw InvalidInput("strip '" + strip_.id + "': time, r_s and x_m must have the same length");
  }
  if (n < 3) throw InvalidInput("strip '" + strip_.id + "': fewer than 3 points");
  if (!strip_.poses.empty() && strip_.poses.size() != n) {
    throw InvalidInput("strip '" + strip_.id + "': per-point poses and points differ in number");
  }
  if (!strip_.laser.empty() && strip_.laser.size() != n)
    throw InvalidInput("strip '" + strip_.id + "': laser ids and points differ in number");
  if (strip_.poses.empty() && !trajectory_) throw InvalidInput("strip '" + strip_.id + "': no per-point poses and no trajectory");
  if (strip_.x_m.empty() && !strip_.poses.empty()) {
    const Mat3 R_bs = reference_.R_bs();
    strip_.x_m.resize(n);
    for (std::size_t i = 0; i < n; ++i) strip_.x_m[i] = georeference(strip_.poses[i], R_bs, reference_.a_b, strip_.r_s[i]);
  } else if (strip_.x_m.empty()) {
    const GeoreferenceModel model(trajectory_, reference_);
    strip_.x_m.resize(n);
    std::vector<double> r(3 * n), x(3 * n);
    for (std::size_t i = 0; i < n; ++i) Eigen::Map<Vec3>{&r[3 * i]} = strip_.r_s[i];
    model.forward(strip_.time_s.data(), r.data(), x.data(), n);
    for (std::size_t i = 0; i < n; ++i) strip_.x_m[i] = Eigen::Map<const Vec3>(&x[3 * i]);
  }
  std::vector<double> xy(2 * n);
  for (std::size_t i = 0; i < n; ++i) {
    xy[2 * i] = strip_.x_m[i].x();
    xy[2 * i + 1] = strip_.x_m[i].y();
  }
  index_->plan = detail::KdTree<double, 2>(std::move(xy));
  multi_laser_ = std::any_of(strip_.laser.begin(), strip_.laser.end(), [&](std::uint16_t l) { return l != strip_.laser.front(); });
}

VtpStrip::~VtpStrip() = default;
VtpStrip::VtpStrip(VtpStrip&&) noexcept = default;
VtpStrip& VtpStrip::operator=(VtpStrip&&) noexcept = default;

std::vector<std::size_t> VtpStrip::radiusSearch(double x, double y, double radius_m) const {
  const double q[2] = {x, y};
  return index_->plan.within(q, radius_m, /*sorted=*/true);
}

double VtpStrip::localSpacing(double x, double y) const {
  const double q[2] = {x, y};
  std::size_t found[9];
  double squared[9];
  const std::size_t k = index_->plan.nearest(q, 9, found, squared);
  if (k == 0) return 0.0;
  // k points within radius r ⇒ density k / (π r²) ⇒ spacing √(π r² / k).
  return std::sqrt(kPi * squared[k - 1] / static_cast<double>(k));
}

namespace {

/// Bowyer–Watson Delaunay triangulation of 2-D points; returns index triples.
std::vector<std::array<int, 3>> delaunay(const std::vector<Eigen::Vector2d>& pts) {
  const int n = static_cast<int>(pts.size());
  Eigen::Vector2d lo = pts[0], hi = pts[0];
  for (const auto& p : pts) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const double span = std::max((hi - lo).maxCoeff(), 1e-9) * 20.0;
  const Eigen::Vector2d mid = 0.5 * (lo + hi);
  std::vector<Eigen::Vector2d> v = pts;
  v.push_back(mid + Eigen::Vector2d(-span, -span));
  v.push_back(mid + Eigen::Vector2d(span, -span));
  v.push_back(mid + Eigen::Vector2d(0, span));
  struct Tri {
    std::array<int, 3> v;
    Eigen::Vector2d c;
    double r2;
  };
  auto make = [&](int a, int b, int c) {
    const Eigen::Vector2d &A = v[a], &B = v[b], &C = v[c];
    const double d = 2 * (A.x() * (B.y() - C.y()) + B.x() * (C.y() - A.y()) + C.x() * (A.y() - B.y()));
    Tri t{{a, b, c}, Eigen::Vector2d::Zero(), 0};
    if (std::abs(d) < 1e-300) {
      t.r2 = std::numeric_limits<double>::infinity();
      return t;
    }
    const double a2 = A.squaredNorm(), b2 = B.squaredNorm(), c2 = C.squaredNorm();
    t.c = Eigen::Vector2d((a2 * (B.y() - C.y()) + b2 * (C.y() - A.y()) + c2 * (A.y() - B.y())) / d,
                          (a2 * (C.x() - B.x()) + b2 * (A.x() - C.x()) + c2 * (B.x() - A.x())) / d);
    t.r2 = (A - t.c).squaredNorm();
    return t;
  };
  std::vector<Tri> tris{make(n, n + 1, n + 2)};
  for (int i = 0; i < n; ++i) {
    std::vector<std::array<int, 2>> edges;
    std::vector<Tri> keep;
    for (const Tri& t : tris) {
      if ((v[i] - t.c).squaredNorm() < t.r2 * (1 + 1e-12)) {
        edges.push_back({t.v[0], t.v[1]});
        edges.push_back({t.v[1], t.v[2]});
        edges.push_back({t.v[2], t.v[0]});
      } else {
        keep.push_back(t);
      }
    }
    // Boundary of the cavity: edges that appear once.
    for (std::size_t a = 0; a < edges.size(); ++a) {
      bool shared = false;
      for (std::size_t b = 0; b < edges.size() && !shared; ++b) {
        shared = a != b && edges[a][0] == edges[b][1] && edges[a][1] == edges[b][0];
      }
      if (!shared) keep.push_back(make(edges[a][0], edges[a][1], i));
    }
    tris.swap(keep);
  }
  std::vector<std::array<int, 3>> out;
  for (const Tri& t : tris) {
    if (t.v[0] < n && t.v[1] < n && t.v[2] < n) out.push_back(t.v);
  }
  return out;
}

using TinMesh = OpenMesh::TriMesh_ArrayKernelT<>;

/// The Delaunay triangle of the coplanar points `inliers` (plane coordinates `uv`, centred at `c`)
/// that holds the pick `puv`, held in an OpenMesh TriMesh: its three indices into `inliers`, or
/// {-1, -1, -1} when the pick lies outside the hull.
std::array<int, 3> enclosingTriangle(const std::vector<Vec3>& X, const std::vector<std::size_t>& inliers, const Vec3& c,
                                     const std::vector<Eigen::Vector2d>& uv, const Eigen::Vector2d& puv) {
  TinMesh tin;
  std::vector<TinMesh::VertexHandle> vh;
  for (std::size_t i : inliers)
    vh.push_back(tin.add_vertex(
        TinMesh::Point(static_cast<float>(X[i].x() - c.x()), static_cast<float>(X[i].y() - c.y()), static_cast<float>(X[i].z() - c.z()))));
  for (const auto& t : delaunay(uv)) {
    // Orient counter-clockwise in (u, v) so that OpenMesh sees a consistent manifold.
    const Eigen::Vector2d e1 = uv[t[1]] - uv[t[0]], e2 = uv[t[2]] - uv[t[0]];
    if (e1.x() * e2.y() - e1.y() * e2.x() > 0)
      tin.add_face(vh[t[0]], vh[t[1]], vh[t[2]]);
    else
      tin.add_face(vh[t[0]], vh[t[2]], vh[t[1]]);
  }
  for (auto fh : tin.faces()) {
    int k = 0;
    std::array<int, 3> tri{};
    for (auto fv : tin.fv_range(fh)) tri[static_cast<std::size_t>(k++)] = fv.idx();
    const Eigen::Vector2d a = uv[static_cast<std::size_t>(tri[0])], b = uv[static_cast<std::size_t>(tri[1])],
                          cc = uv[static_cast<std::size_t>(tri[2])];
    const double d = (b - a).x() * (cc - a).y() - (b - a).y() * (cc - a).x();
    if (std::abs(d) < 1e-14) continue;
    const double l1 = ((b - puv).x() * (cc - puv).y() - (b - puv).y() * (cc - puv).x()) / d;
    const double l2 = ((cc - puv).x() * (a - puv).y() - (cc - puv).y() * (a - puv).x()) / d;
    const double l3 = 1.0 - l1 - l2;
    if (l1 >= -1e-12 && l2 >= -1e-12 && l3 >= -1e-12) return tri;
  }
  return {-1, -1, -1};
}

/// Why the triangle (a, b, cc) cannot carry a pick, or "" when it can: a sliver (its smallest
/// angle), or a triangle standing upright in plan.
std::string triangleShapeProblem(const Vec3& a, const Vec3& b, const Vec3& cc, const VtpOptions& options) {
  const std::array<Vec3, 3> v{a, b, cc};
  double min_angle = kPi;
  for (std::size_t k = 0; k < 3; ++k) {
    const Vec3 e1 = v[(k + 1) % 3] - v[k], e2 = v[(k + 2) % 3] - v[k];
    min_angle = std::min(min_angle, std::acos(std::clamp(e1.normalized().dot(e2.normalized()), -1.0, 1.0)));
  }
  if (min_angle < deg2rad(options.min_triangle_angle_deg))
    return "degenerate triangle: smallest angle " + std::to_string(rad2deg(min_angle)).substr(0, 4) + "°";
  // Rule 1 interpolates the height in plan (seed eq. 5), but the triangle was found in the local
  // plane's own coordinates: three noisy pulses on a sloped plane can stand nearly upright — a
  // sliver in plan — and the height at the pick is then extrapolated from it (a uav-vlp16 survey,
  // a roof at 48°: three pulses within 4 cm of one line in plan, the pick's height 24.5 m above
  // the roof, read from the LAS file's millimetres; 0.4 m above from the simulator's doubles).
  const Vec3 nt = (b - a).cross(cc - a).normalized();
  if (!(std::abs(nt.z()) >= std::cos(deg2rad(options.max_plane_tilt_deg))))
    return "degenerate triangle: its plane is " + std::to_string(rad2deg(std::acos(std::min(1.0, std::abs(nt.z()))))).substr(0, 4) +
           "° steep (a sliver in plan), the pick's height would be extrapolated";
  return "";
}

}  // namespace

bool VtpStrip::build(const TieObservation& pick, const VtpOptions& options, VirtualTiePoint* vtp, std::string* reason) const {
  const double spacing = localSpacing(pick.x_m, pick.y_m);
  const double radius = std::max(options.radius_m, std::min(options.max_radius_m, options.radius_spacing_factor * spacing));
  std::vector<std::size_t> idx = radiusSearch(pick.x_m, pick.y_m, radius);
  if (static_cast<int>(idx.size()) < std::max(options.min_points, 3)) {
    *reason = "too few points: " + std::to_string(idx.size()) + " within " + std::to_string(radius).substr(0, 4) + " m of the pick (need " +
              std::to_string(std::max(options.min_points, 3)) + "); is the pick on this strip?";
    return false;
  }
  // RANSAC plane (deterministic: seeded by the pick).
  std::mt19937 rng(static_cast<unsigned>(std::hash<std::string>{}(pick.tie_id + "/" + pick.strip_id)));
  std::uniform_int_distribution<std::size_t> pickone(0, idx.size() - 1);
  const auto& X = strip_.x_m;
  // Several surfaces may fall within the radius (a board over the ground, a roof edge): the
  // plane wanted is the one the pick lies on, so a candidate scores first by how many of the
  // pick's nearest neighbours it holds (idx is sorted by distance), then by its inliers.
  const std::size_t n_near = std::min<std::size_t>(6, idx.size());
  const detail::PlaneHypothesis plane = detail::ransacPlane(
      X, idx, options.ransac_threshold_m, options.ransac_iterations, [&] { return pickone(rng); }, n_near);
  const std::vector<std::size_t> best =
      plane.found ? detail::planeInliers(X, idx, plane.normal, plane.point, options.ransac_threshold_m) : std::vector<std::size_t>{};
  const std::size_t best_near = plane.priority;
  if (static_cast<int>(best.size()) < std::max(options.min_points, 3) ||
      static_cast<double>(best_near) < options.min_inlier_fraction * static_cast<double>(n_near)) {
    *reason = "no plane: " + std::to_string(best_near) + " of the " + std::to_string(n_near) + " points nearest the pick (" +
              std::to_string(best.size()) + " of " + std::to_string(idx.size()) + " in all) within " +
              std::to_string(options.ransac_threshold_m).substr(0, 5) + " m of one plane";
    return false;
  }
  // Least-squares plane of the inliers, then re-select inliers against it.
  Vec3 c = Vec3::Zero();
  for (std::size_t i : best) c += X[i];
  c /= static_cast<double>(best.size());
  Mat3 C = Mat3::Zero();
  for (std::size_t i : best) C += (X[i] - c) * (X[i] - c).transpose();
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(C);
  Vec3 n = eig.eigenvectors().col(0);
  if (n.z() < 0) n = -n;
  if (n.z() < std::cos(deg2rad(options.max_plane_tilt_deg))) {
    *reason =
        "no plane: the local surface is too steep (" + std::to_string(rad2deg(std::acos(n.z()))).substr(0, 4) + "°) to hold a plan pick";
    return false;
  }
  std::vector<std::size_t> inliers;
  for (std::size_t i : idx)
    if (std::abs(n.dot(X[i] - c)) <= options.ransac_threshold_m) inliers.push_back(i);
  if (static_cast<int>(inliers.size()) < std::max(options.min_points, 3)) {
    *reason = "no plane: too few coplanar points after refinement";
    return false;
  }
  // Plane coordinates (u, v) and the pick projected vertically onto the plane.
  const Vec3 u = (std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY()).cross(n).normalized();
  const Vec3 v = n.cross(u);
  std::vector<Eigen::Vector2d> uv;
  for (std::size_t i : inliers) uv.emplace_back((X[i] - c).dot(u), (X[i] - c).dot(v));
  const double zp = c.z() - (n.x() * (pick.x_m - c.x()) + n.y() * (pick.y_m - c.y())) / n.z();
  const Vec3 P(pick.x_m, pick.y_m, zp);
  const Eigen::Vector2d puv((P - c).dot(u), (P - c).dot(v));

  const std::array<int, 3> found = enclosingTriangle(X, inliers, c, uv, puv);
  if (found[0] < 0) {
    *reason = "outside the hull: the pick is not inside the triangulation of the " + std::to_string(inliers.size()) +
              " coplanar points around it";
    return false;
  }
  const std::string shape = triangleShapeProblem(X[inliers[found[0]]], X[inliers[found[1]]], X[inliers[found[2]]], options);
  if (!shape.empty()) {
    *reason = shape;
    return false;
  }
  // Point i of the strip with what Rule 2 needs to georeference it again.
  auto footprint = [&](std::size_t i) {
    LaserFootprint f;
    f.index = i;
    f.r_s = strip_.r_s[i];
    f.x0_m = X[i];
    f.pose = strip_.poses.empty() ? trajectory_->pose(strip_.time_s[i]) : strip_.poses[i];
    return f;
  };
  std::array<LaserFootprint, 3> verts;
  for (int k = 0; k < 3; ++k) verts[k] = footprint(inliers[found[k]]);
  *vtp = VirtualTiePoint(pick.tie_id, pick.strip_id, pick.x_m, pick.y_m, verts, reference_);
  if (options.motion == VtpMotion::kNeighbourhood || (options.motion == VtpMotion::kAuto && multi_laser_)) {
    // The coplanar points nearest the pick (inliers keep idx's order, by distance).
    std::vector<LaserFootprint> support;
    for (std::size_t k = 0; k < inliers.size() && k < static_cast<std::size_t>(kMaxMotionSupport); ++k)
      support.push_back(footprint(inliers[k]));
    // Each laser weighs the same (its points share it): a pick is the centre of the lasers' images
    // of the target, and the displacements of lasers tilted ±e from the scan plane cancel to first
    // order only in equal shares (over 6 noise-free uav-vlp16 surveys the heading's error fell
    // from 0.011-0.025° to 0.005-0.020° with them).
    std::vector<double> w;
    std::vector<int> lasers;
    if (!strip_.laser.empty()) {
      std::map<int, int> count;
      for (const LaserFootprint& f : support) ++count[strip_.laser[f.index]];
      for (const LaserFootprint& f : support) {
        w.push_back(1.0 / count[strip_.laser[f.index]]);
        lasers.push_back(strip_.laser[f.index]);
      }
    }
    vtp->setMotionSupport(std::move(support), std::move(w), std::move(lasers));
  }
  vtp->setSurfaceNormal(n);  // the local plane's, for the pick's error along the surface (TieObservations)
  // The reference vertices were georeferenced with the reference mounting; Rule 2 uses the
  // same nominal rotation, so P(reference) = P⁰ exactly.
  return true;
}

}  // namespace mountcal
