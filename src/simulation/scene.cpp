#include "mountcal/simulation/scene.hpp"

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>

#include "mountcal/core/error.hpp"

namespace mountcal::simulation {

namespace {

struct MeshTraits : public OpenMesh::DefaultTraits {
  using Point = OpenMesh::Vec3d;
  FaceAttributes(OpenMesh::Attributes::Normal);
};
using TriMesh = OpenMesh::TriMesh_ArrayKernelT<MeshTraits>;

struct Triangle {
  Vec3 a, e1, e2, n;  // vertex, two edges, unit normal
  float intensity;
  SurfaceKind kind;
};

struct Box {
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 hi = -Vec3::Constant(std::numeric_limits<double>::infinity());
  void grow(const Vec3& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  void grow(const Box& b) {
    lo = lo.cwiseMin(b.lo);
    hi = hi.cwiseMax(b.hi);
  }
  /// Slab test; true when the ray enters the box before `tmax`.
  bool hit(const Vec3& o, const Vec3& inv, double tmax) const {
    double t0 = 0.0, t1 = tmax;
    for (int a = 0; a < 3; ++a) {
      double ta = (lo[a] - o[a]) * inv[a], tb = (hi[a] - o[a]) * inv[a];
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta);
      t1 = std::min(t1, tb);
      if (t0 > t1) return false;
    }
    return true;
  }
};

struct Node {
  Box box;
  int left = -1, right = -1;  // children, or -1 for a leaf
  int first = 0, count = 0;   // leaf triangle range in `order`
};

struct Marking {
  Vec3 centre;
  double half_len, half_wid, c, s;  // rectangle in its own frame
  float intensity;
  Box box;
};

struct Tree {
  double cx, cy, r, z0, z1, density;
};

/// SplitMix64: a well-mixed hash for deterministic per-pulse randomness.
std::uint64_t mix(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}
double unit(std::uint64_t h) { return static_cast<double>(h >> 11) * (1.0 / 9007199254740992.0); }

/// ⌊x⌋ as an int for grid indices (|x| < 2³¹). std::floor is a library call on baseline
/// x86-64 (no SSE4.1 round instruction), and a ray takes about ten of them.
inline int floorInt(double x) {
  const int i = static_cast<int>(x);
  return i - (x < static_cast<double>(i));
}

/// Unit vectors of a frame whose "along" axis is at `heading` clockwise from North (+y).
Vec3 along(double heading) { return {std::sin(heading), std::cos(heading), 0.0}; }
Vec3 across(double heading) { return {std::cos(heading), -std::sin(heading), 0.0}; }

/// The largest axis-aligned square centred at `c` inside the rectangle of half sizes (hu, hv)
/// along the unit plan directions u and v, less a margin [m].
PlanePatch insetBox(const std::string& id, const Vec3& c, const Vec3& u, double hu, const Vec3& v, double hv, double margin) {
  const double h = std::min(hu / (std::abs(u.x()) + std::abs(u.y())), hv / (std::abs(v.x()) + std::abs(v.y()))) - margin;
  return {id, c.x() - h, c.y() - h, c.x() + h, c.y() + h};
}

}  // namespace

struct Scene::Impl {
  double z0 = 0, gx = 0, gy = 0;
  Vec3 ground_normal = Vec3::UnitZ();  // (−gx, −gy, 1) normalised, once (not per pulse)
  float ground_intensity = 40.0f;
  TriMesh mesh;
  std::vector<std::pair<float, SurfaceKind>> face_props;  // by face index
  std::vector<Triangle> tris;
  std::vector<int> order;
  std::vector<Node> nodes;
  std::vector<Marking> markings;
  std::vector<Tree> trees;
  bool built = false;
  // Uniform plan grid over markings and tree crowns: each cell lists what overlaps it.
  double grid_x0 = 0, grid_y0 = 0;
  // A power of two: x · inv_cell is x / cell to the bit, without a division per lookup.
  static constexpr double cell = 8.0, inv_cell = 1.0 / cell;
  int grid_nx = 0, grid_ny = 0;
  std::vector<std::vector<int>> cell_markings, cell_trees;
  std::vector<char> cell_has_triangles;  // a triangle's plan box overlaps the cell
  double max_crown_top = -1e300;
  double max_triangle_z = -1e300;

  int cellIndex(double x, double y) const {
    const int i = floorInt((x - grid_x0) * inv_cell), j = floorInt((y - grid_y0) * inv_cell);
    if (i < 0 || j < 0 || i >= grid_nx || j >= grid_ny) return -1;
    return j * grid_nx + i;
  }
  void buildGrid() {
    Box b;
    for (const Marking& m : markings) b.grow(m.box);
    for (const Triangle& t : tris) {
      b.grow(Vec3(t.a.x(), t.a.y(), 0));
      b.grow(Vec3((t.a + t.e1).x(), (t.a + t.e1).y(), 0));
      b.grow(Vec3((t.a + t.e2).x(), (t.a + t.e2).y(), 0));
      max_triangle_z = std::max({max_triangle_z, t.a.z(), (t.a + t.e1).z(), (t.a + t.e2).z()});
    }
    for (const Tree& t : trees) {
      b.grow(Vec3(t.cx - t.r, t.cy - t.r, 0));
      b.grow(Vec3(t.cx + t.r, t.cy + t.r, 0));
      max_crown_top = std::max(max_crown_top, t.z1);
    }
    cell_markings.clear();
    cell_trees.clear();
    cell_has_triangles.clear();
    if (markings.empty() && trees.empty() && tris.empty()) {
      grid_nx = grid_ny = 0;
      return;
    }
    grid_x0 = b.lo.x() - cell;
    grid_y0 = b.lo.y() - cell;
    grid_nx = static_cast<int>((b.hi.x() - grid_x0) * inv_cell) + 2;
    grid_ny = static_cast<int>((b.hi.y() - grid_y0) * inv_cell) + 2;
    cell_markings.assign(static_cast<std::size_t>(grid_nx) * grid_ny, {});
    cell_trees.assign(static_cast<std::size_t>(grid_nx) * grid_ny, {});
    cell_has_triangles.assign(static_cast<std::size_t>(grid_nx) * grid_ny, 0);
    auto fill = [&](std::vector<std::vector<int>>& cells, int id, double x0, double y0, double x1, double y1) {
      const int i0 = floorInt((x0 - grid_x0) * inv_cell), i1 = floorInt((x1 - grid_x0) * inv_cell);
      const int j0 = floorInt((y0 - grid_y0) * inv_cell), j1 = floorInt((y1 - grid_y0) * inv_cell);
      for (int j = j0; j <= j1; ++j)
        for (int i = i0; i <= i1; ++i) cells[static_cast<std::size_t>(j * grid_nx + i)].push_back(id);
    };
    for (std::size_t k = 0; k < markings.size(); ++k) {
      const Box& mb = markings[k].box;
      fill(cell_markings, static_cast<int>(k), mb.lo.x(), mb.lo.y(), mb.hi.x(), mb.hi.y());
    }
    for (std::size_t k = 0; k < trees.size(); ++k) {
      const Tree& t = trees[k];
      fill(cell_trees, static_cast<int>(k), t.cx - t.r, t.cy - t.r, t.cx + t.r, t.cy + t.r);
    }
    for (const Triangle& t : tris) {
      const Vec3 p1 = t.a + t.e1, p2 = t.a + t.e2;
      const int i0 = floorInt((std::min({t.a.x(), p1.x(), p2.x()}) - grid_x0) * inv_cell);
      const int i1 = floorInt((std::max({t.a.x(), p1.x(), p2.x()}) - grid_x0) * inv_cell);
      const int j0 = floorInt((std::min({t.a.y(), p1.y(), p2.y()}) - grid_y0) * inv_cell);
      const int j1 = floorInt((std::max({t.a.y(), p1.y(), p2.y()}) - grid_y0) * inv_cell);
      for (int j = j0; j <= j1; ++j)
        for (int i = i0; i <= i1; ++i) cell_has_triangles[static_cast<std::size_t>(j * grid_nx + i)] = 1;
    }
  }

  /// False only when the ray's part below the highest triangle crosses no cell that holds a
  /// triangle (exact culling: the BVH is then skipped). `t_end` is where the ray stops.
  bool mayHitTriangles(const Vec3& o, const Vec3& d, double t_end) const {
    if (tris.empty()) return false;
    if (!std::isfinite(t_end) || std::abs(d.z()) < 1e-6) return true;
    const double t_top = (max_triangle_z - o.z()) / d.z();
    const Vec3 a = (t_top > 0 && t_top < t_end) ? Vec3(o + t_top * d) : o;
    const Vec3 b = o + t_end * d;
    const int i0 = floorInt((std::min(a.x(), b.x()) - grid_x0) * inv_cell);
    const int i1 = floorInt((std::max(a.x(), b.x()) - grid_x0) * inv_cell);
    const int j0 = floorInt((std::min(a.y(), b.y()) - grid_y0) * inv_cell);
    const int j1 = floorInt((std::max(a.y(), b.y()) - grid_y0) * inv_cell);
    if (i1 - i0 > 4 || j1 - j0 > 4) return true;  // a long path: let the BVH decide
    for (int j = j0; j <= j1; ++j) {
      for (int i = i0; i <= i1; ++i) {
        if (i < 0 || j < 0 || i >= grid_nx || j >= grid_ny) continue;  // outside the grid: no triangle
        if (cell_has_triangles[static_cast<std::size_t>(j * grid_nx + i)]) return true;
      }
    }
    return false;
  }

  void addTriangle(const Vec3& a, const Vec3& b, const Vec3& c, float intensity, SurfaceKind kind) {
    auto va = mesh.add_vertex(TriMesh::Point(a.x(), a.y(), a.z()));
    auto vb = mesh.add_vertex(TriMesh::Point(b.x(), b.y(), b.z()));
    auto vc = mesh.add_vertex(TriMesh::Point(c.x(), c.y(), c.z()));
    mesh.add_face(va, vb, vc);
    face_props.emplace_back(intensity, kind);
    built = false;
  }
  void addQuad(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d, float intensity, SurfaceKind kind) {
    addTriangle(a, b, c, intensity, kind);
    addTriangle(a, c, d, intensity, kind);
  }

  int buildNode(int first, int count) {
    Node node;
    node.first = first;
    node.count = count;
    Box centroids;
    for (int i = first; i < first + count; ++i) {
      const Triangle& t = tris[order[i]];
      node.box.grow(t.a);
      node.box.grow(t.a + t.e1);
      node.box.grow(t.a + t.e2);
      centroids.grow(t.a + (t.e1 + t.e2) / 3.0);
    }
    const int index = static_cast<int>(nodes.size());
    nodes.push_back(node);
    if (count <= 4) return index;
    int axis = 0;
    const Vec3 ext = centroids.hi - centroids.lo;
    if (ext.y() > ext[axis]) axis = 1;
    if (ext.z() > ext[axis]) axis = 2;
    const int mid = first + count / 2;
    std::nth_element(order.begin() + first, order.begin() + mid, order.begin() + first + count, [&](int a, int b) {
      const Triangle &ta = tris[a], &tb = tris[b];
      return (3 * ta.a + ta.e1 + ta.e2)[axis] < (3 * tb.a + tb.e1 + tb.e2)[axis];
    });
    const int l = buildNode(first, mid - first);
    const int r = buildNode(mid, first + count - mid);
    nodes[index].left = l;
    nodes[index].right = r;
    nodes[index].count = 0;
    return index;
  }

  void build() {
    tris.clear();
    mesh.request_face_normals();
    mesh.update_face_normals();
    for (auto fh : mesh.faces()) {
      std::array<Vec3, 3> v;
      int k = 0;
      for (auto vh : mesh.fv_range(fh)) {
        const auto& p = mesh.point(vh);
        v[k++] = Vec3(p[0], p[1], p[2]);
      }
      Triangle t;
      t.a = v[0];
      t.e1 = v[1] - v[0];
      t.e2 = v[2] - v[0];
      t.n = t.e1.cross(t.e2).normalized();
      t.intensity = face_props[static_cast<std::size_t>(fh.idx())].first;
      t.kind = face_props[static_cast<std::size_t>(fh.idx())].second;
      tris.push_back(t);
    }
    order.resize(tris.size());
    std::iota(order.begin(), order.end(), 0);
    nodes.clear();
    if (!tris.empty()) buildNode(0, static_cast<int>(tris.size()));
    buildGrid();
    built = true;
  }

  /// Möller–Trumbore; updates *best when closer.
  bool castTriangles(const Vec3& o, const Vec3& d, double* best, int* which) const {
    if (nodes.empty()) return false;
    const Vec3 inv(1.0 / d.x(), 1.0 / d.y(), 1.0 / d.z());
    int stack[64];
    int sp = 0;
    stack[sp++] = 0;
    bool any = false;
    while (sp > 0) {
      const Node& node = nodes[stack[--sp]];
      if (!node.box.hit(o, inv, *best)) continue;
      if (node.left < 0) {
        for (int i = node.first; i < node.first + node.count; ++i) {
          const Triangle& t = tris[order[i]];
          const Vec3 p = d.cross(t.e2);
          const double det = t.e1.dot(p);
          if (std::abs(det) < 1e-14) continue;
          const double inv_det = 1.0 / det;
          const Vec3 s = o - t.a;
          const double u = s.dot(p) * inv_det;
          if (u < 0.0 || u > 1.0) continue;
          const Vec3 q = s.cross(t.e1);
          const double v = d.dot(q) * inv_det;
          if (v < 0.0 || u + v > 1.0) continue;
          const double dist = t.e2.dot(q) * inv_det;
          if (dist > 1e-9 && dist < *best) {
            *best = dist;
            *which = order[i];
            any = true;
          }
        }
      } else if (sp + 2 <= 64) {
        stack[sp++] = node.left;
        stack[sp++] = node.right;
      }
    }
    return any;
  }
};

Scene::Scene() : impl_(std::make_unique<Impl>()) {}
Scene::~Scene() = default;
Scene::Scene(Scene&&) noexcept = default;
Scene& Scene::operator=(Scene&&) noexcept = default;

void Scene::setGround(double z0_m, double gx, double gy, float intensity) {
  impl_->z0 = z0_m;
  impl_->gx = gx;
  impl_->gy = gy;
  impl_->ground_normal = Vec3(-gx, -gy, 1.0).normalized();
  impl_->ground_intensity = intensity;
}

double Scene::groundHeight(double x, double y) const { return impl_->z0 + impl_->gx * x + impl_->gy * y; }

std::size_t Scene::triangleCount() const { return impl_->mesh.n_faces(); }

void Scene::addMarking(double cx, double cy, double length_m, double width_m, double heading_rad, float intensity) {
  Marking m;
  m.centre = Vec3(cx, cy, groundHeight(cx, cy));
  m.half_len = 0.5 * length_m;
  m.half_wid = 0.5 * width_m;
  m.c = std::cos(heading_rad);
  m.s = std::sin(heading_rad);
  m.intensity = intensity;
  const double r = std::hypot(m.half_len, m.half_wid);
  m.box.grow(Vec3(cx - r, cy - r, 0));
  m.box.grow(Vec3(cx + r, cy + r, 0));
  impl_->markings.push_back(m);
  impl_->built = false;
}

void Scene::addZebraCrossing(const std::string& id, double cx, double cy, double heading_rad, int stripes, double length_m) {
  // Stripes are 0.5 m wide along the road, `length_m` long across it, 1 m apart.
  const Vec3 u = along(heading_rad), v = across(heading_rad);
  const double first = -0.5 * (stripes - 1);
  for (int k = 0; k < stripes; ++k) {
    const Vec3 c = Vec3(cx, cy, 0) + (first + k) * u;
    addMarking(c.x(), c.y(), 0.5, length_m, heading_rad, 220.0f);
  }
  // Outer corners of the first and last stripe.
  const double du = -first + 0.25, dv = 0.5 * length_m;
  const double sgn[4][2] = {{-1, -1}, {-1, 1}, {1, -1}, {1, 1}};
  for (int k = 0; k < 4; ++k) {
    const Vec3 p = Vec3(cx, cy, 0) + sgn[k][0] * du * u + sgn[k][1] * dv * v;
    addFeature({id + "_c" + std::to_string(k), Vec3(p.x(), p.y(), groundHeight(p.x(), p.y())), SurfaceKind::kMarking, 3.0});
  }
}

namespace {

/// The plan point p at height z.
Vec3 atHeight(const Vec3& p, double z) { return Vec3(p.x(), p.y(), z); }

/// A building's plan: its centre, half axes (u along the heading, v across), its corners a = c − u − v,
/// b = c + u − v, cc = c + u + v, d = c − u + v, and its walls' foot a metre below the ground.
struct HouseCorners {
  Vec3 c, u, v, a, b, cc, d;
  double zb = 0;  ///< [m]
};

HouseCorners houseCorners(double cx, double cy, double length_m, double width_m, double heading_rad, double ground_z_m) {
  HouseCorners h;
  h.zb = ground_z_m - 1.0;
  h.c = Vec3(cx, cy, 0);
  h.u = along(heading_rad) * (0.5 * length_m);
  h.v = across(heading_rad) * (0.5 * width_m);
  h.a = h.c - h.u - h.v, h.b = h.c + h.u - h.v, h.cc = h.c + h.u + h.v, h.d = h.c - h.u + h.v;
  return h;
}

/// The walls of a pitched house from its foot: the long side a–b up to z_ab, the long side cc–d up
/// to z_cd, and each end (b–cc, d–a) a rectangle up to the lower of the two with a triangle above
/// it to the roof's end point there (`apex_bc`, `apex_da`: a gable's ridge end, a monopitch's high
/// eave corner).
template <typename Impl>
void addHouseWalls(Impl& impl, const HouseCorners& h, double z_ab, double z_cd, const Vec3& apex_bc, const Vec3& apex_da) {
  const double zl = std::min(z_ab, z_cd);
  impl.addQuad(atHeight(h.a, h.zb), atHeight(h.b, h.zb), atHeight(h.b, z_ab), atHeight(h.a, z_ab), 50.0f, SurfaceKind::kWall);
  impl.addQuad(atHeight(h.cc, h.zb), atHeight(h.d, h.zb), atHeight(h.d, z_cd), atHeight(h.cc, z_cd), 50.0f, SurfaceKind::kWall);
  impl.addQuad(atHeight(h.b, h.zb), atHeight(h.cc, h.zb), atHeight(h.cc, zl), atHeight(h.b, zl), 50.0f, SurfaceKind::kWall);
  impl.addTriangle(atHeight(h.b, zl), atHeight(h.cc, zl), apex_bc, 50.0f, SurfaceKind::kWall);
  impl.addQuad(atHeight(h.d, h.zb), atHeight(h.a, h.zb), atHeight(h.a, zl), atHeight(h.d, zl), 50.0f, SurfaceKind::kWall);
  impl.addTriangle(atHeight(h.d, zl), atHeight(h.a, zl), apex_da, 50.0f, SurfaceKind::kWall);
}

}  // namespace

void Scene::addFlatRoofBuilding(const std::string& id, double cx, double cy, double length_m, double width_m, double height_m,
                                double heading_rad) {
  const double g = groundHeight(cx, cy), zr = g + height_m;
  const HouseCorners h = houseCorners(cx, cy, length_m, width_m, heading_rad, g);
  const Vec3 &u = h.u, &v = h.v, &c = h.c;
  const Vec3 corners[4] = {h.a, h.b, h.cc, h.d};
  const double zb = h.zb;  // walls start below the (sloped) ground
  const auto at = atHeight;
  impl_->addQuad(at(corners[0], zr), at(corners[1], zr), at(corners[2], zr), at(corners[3], zr), 70.0f, SurfaceKind::kRoof);
  for (int k = 0; k < 4; ++k) {
    const Vec3& a = corners[k];
    const Vec3& b = corners[(k + 1) % 4];
    impl_->addQuad(at(a, zb), at(b, zb), at(b, zr), at(a, zr), 50.0f, SurfaceKind::kWall);
  }
  const Vec3 ui = u.normalized(), vi = v.normalized();
  const double iu = 0.5 * length_m - 2.0, iv = 0.5 * width_m - 2.0;
  const double sgn[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
  for (int k = 0; k < 4; ++k) {
    const Vec3 p = c + sgn[k][0] * iu * ui + sgn[k][1] * iv * vi;
    addFeature({id + "_r" + std::to_string(k), at(p, zr), SurfaceKind::kRoof, 2.0});
  }
  plane_regions_.push_back(insetBox(id + "_roof", c, ui, 0.5 * length_m, vi, 0.5 * width_m, 1.0));
}

void Scene::addGableHouse(const std::string& id, double cx, double cy, double length_m, double width_m, double eave_height_m,
                          double ridge_height_m, double heading_rad) {
  const double g = groundHeight(cx, cy), ze = g + eave_height_m, zr = g + ridge_height_m;
  const HouseCorners h = houseCorners(cx, cy, length_m, width_m, heading_rad, g);
  const Vec3 &u = h.u, &v = h.v, &c = h.c, &a = h.a, &b = h.b, &cc = h.cc, &d = h.d;
  const Vec3 r0 = c - u, r1 = c + u;  // the ridge's ends
  const auto at = atHeight;
  // Two roof planes.
  impl_->addQuad(at(a, ze), at(b, ze), at(r1, zr), at(r0, zr), 80.0f, SurfaceKind::kRoof);
  impl_->addQuad(at(cc, ze), at(d, ze), at(r0, zr), at(r1, zr), 80.0f, SurfaceKind::kRoof);
  // Long walls and gable ends.
  addHouseWalls(*impl_, h, ze, ze, at(r1, zr), at(r0, zr));
  // Mid-points of the two roof planes.
  const double zm = 0.5 * (ze + zr);
  const Vec3 m0 = c - 0.5 * v, m1 = c + 0.5 * v;
  const double clearance = std::min(0.25 * length_m, 0.25 * std::hypot(0.5 * width_m, zr - ze));
  addFeature({id + "_s0", at(m0, zm), SurfaceKind::kRoof, clearance});
  addFeature({id + "_s1", at(m1, zm), SurfaceKind::kRoof, clearance});
  const Vec3 un = u.normalized(), vn = v.normalized();
  plane_regions_.push_back(insetBox(id + "_face0", m0, un, 0.5 * length_m, vn, 0.25 * width_m, 0.3));
  plane_regions_.push_back(insetBox(id + "_face1", m1, un, 0.5 * length_m, vn, 0.25 * width_m, 0.3));
}

void Scene::addMonopitchHouse(const std::string& id, double cx, double cy, double length_m, double width_m, double low_eave_height_m,
                              double high_eave_height_m, double heading_rad) {
  const double g = groundHeight(cx, cy), zl = g + low_eave_height_m, zh = g + high_eave_height_m;
  const HouseCorners h = houseCorners(cx, cy, length_m, width_m, heading_rad, g);
  const auto at = atHeight;
  // The roof plane, low along a–b, high along cc–d.
  impl_->addQuad(at(h.a, zl), at(h.b, zl), at(h.cc, zh), at(h.d, zh), 80.0f, SurfaceKind::kRoof);
  // The low and high long walls, and the two ends (a rectangle to the low eave, a triangle above).
  addHouseWalls(*impl_, h, zl, zh, at(h.cc, zh), at(h.d, zh));
  const double zm = 0.5 * (zl + zh);
  const double clearance = std::min(0.25 * length_m, 0.25 * std::hypot(width_m, zh - zl));
  addFeature({id + "_s0", at(h.c, zm), SurfaceKind::kRoof, clearance});
  plane_regions_.push_back(insetBox(id + "_face0", h.c, h.u.normalized(), 0.5 * length_m, h.v.normalized(), 0.5 * width_m, 0.3));
}

void Scene::addBoard(const std::string& id, const Vec3& centre_m, double size_m, double heading_rad, double tilt_rad, float intensity) {
  const Vec3 u = along(heading_rad), v0 = across(heading_rad);
  const Vec3 v = std::cos(tilt_rad) * v0 + std::sin(tilt_rad) * Vec3::UnitZ();
  const double h = 0.5 * size_m;
  const Vec3& c = centre_m;
  impl_->addQuad(c - h * u - h * v, c + h * u - h * v, c + h * u + h * v, c - h * u + h * v, intensity, SurfaceKind::kBoard);
  addFeature({id, c, SurfaceKind::kBoard, 0.45 * size_m});
  const double r = h * (std::abs(u.x()) + std::abs(v.x())) + target_margin_m, s = h * (std::abs(u.y()) + std::abs(v.y())) + target_margin_m;
  addTargetRegion({id, c.x() - r, c.y() - s, c.x() + r, c.y() + s});
}

void Scene::addGroundTarget(const std::string& id, double cx, double cy, double size_m, double heading_rad, float intensity) {
  addMarking(cx, cy, size_m, size_m, heading_rad, intensity);
  addFeature({id, Vec3(cx, cy, groundHeight(cx, cy)), SurfaceKind::kMarking, 3.0});
  const double r = 0.5 * size_m * (std::abs(std::cos(heading_rad)) + std::abs(std::sin(heading_rad))) + target_margin_m;
  addTargetRegion({id, cx - r, cy - r, cx + r, cy + r});
}

void Scene::addTree(double cx, double cy, double radius_m, double crown_base_m, double top_m, double density) {
  const double g = groundHeight(cx, cy);
  impl_->trees.push_back({cx, cy, radius_m, g + crown_base_m, g + top_m, density});
  impl_->built = false;
}

void Scene::addCheckPlane(const std::string& id, double xmin, double ymin, double xmax, double ymax) {
  check_planes_.push_back({id, xmin, ymin, xmax, ymax});
}

void Scene::build() { impl_->build(); }

bool Scene::cast(const Vec3& o, const Vec3& d, std::uint64_t pulse_id, Hit* hit, double max_range_m) const {
  if (!impl_->built) const_cast<Impl&>(*impl_).build();
  const Impl& s = *impl_;
  double best = max_range_m;
  bool found = false;
  // Ground: n·x = z0 with n = (−gx, −gy, 1).
  const Vec3 n(-s.gx, -s.gy, 1.0);
  const double denom = n.dot(d);
  if (std::abs(denom) > 1e-12) {
    const double t = (s.z0 - n.dot(o)) / denom;
    if (t > 1e-9 && t < best) {
      best = t;
      found = true;
      hit->kind = SurfaceKind::kGround;
      hit->intensity = s.ground_intensity;
      hit->normal_m = s.ground_normal;
    }
  }
  int tri = -1;
  if (s.mayHitTriangles(o, d, best) && s.castTriangles(o, d, &best, &tri)) {
    found = true;
    const auto& t = s.tris[static_cast<std::size_t>(tri)];
    hit->kind = t.kind;
    hit->intensity = t.intensity;
    hit->normal_m = t.n;
  }
  // Vegetation: a return somewhere inside a crown cylinder, before the surface behind it. Only
  // the trees in the grid cells under the ray's part below the highest crown are tested.
  if (!s.trees.empty() && found && std::abs(d.z()) > 1e-6) {
    const Vec3 hit_point = o + best * d;
    const double t_top = (s.max_crown_top - o.z()) / d.z();
    const Vec3 top_point = (t_top > 0 && t_top < best) ? Vec3(o + t_top * d) : o;
    const int i0 = floorInt((std::min(hit_point.x(), top_point.x()) - s.grid_x0) * s.inv_cell);
    const int i1 = floorInt((std::max(hit_point.x(), top_point.x()) - s.grid_x0) * s.inv_cell);
    const int j0 = floorInt((std::min(hit_point.y(), top_point.y()) - s.grid_y0) * s.inv_cell);
    const int j1 = floorInt((std::max(hit_point.y(), top_point.y()) - s.grid_y0) * s.inv_cell);
    const bool narrow = (i1 - i0) <= 2 && (j1 - j0) <= 2;
    int candidates[16];
    int n_cand = 0;
    if (narrow) {
      for (int j = std::max(j0, 0); j <= std::min(j1, s.grid_ny - 1); ++j)
        for (int i = std::max(i0, 0); i <= std::min(i1, s.grid_nx - 1); ++i)
          for (int id : s.cell_trees[static_cast<std::size_t>(j * s.grid_nx + i)])
            if (n_cand < 16 && std::find(candidates, candidates + n_cand, id) == candidates + n_cand) candidates[n_cand++] = id;
    }
    const int n_test = narrow ? n_cand : static_cast<int>(s.trees.size());
    for (int q = 0; q < n_test; ++q) {
      const Tree& tree = s.trees[static_cast<std::size_t>(narrow ? candidates[q] : q)];
      const double ox = o.x() - tree.cx, oy = o.y() - tree.cy;
      const double a = d.x() * d.x() + d.y() * d.y();
      if (a < 1e-12) continue;
      const double b = ox * d.x() + oy * d.y();
      const double c = ox * ox + oy * oy - tree.r * tree.r;
      const double disc = b * b - a * c;
      if (disc <= 0) continue;
      double t0 = (-b - std::sqrt(disc)) / a, t1 = (-b + std::sqrt(disc)) / a;
      double za = (tree.z0 - o.z()) / d.z(), zb = (tree.z1 - o.z()) / d.z();
      if (za > zb) std::swap(za, zb);
      t0 = std::max(std::max(t0, za), 1e-9);
      t1 = std::min(std::min(t1, zb), best);
      if (t0 >= t1) continue;
      const std::uint64_t h = mix(pulse_id * 0x2545F4914F6CDD1Dull + 17);
      if (unit(h) < tree.density) {
        best = t0 + unit(mix(h)) * (t1 - t0);
        hit->kind = SurfaceKind::kVegetation;
        hit->intensity = 25.0f;
        hit->normal_m = -d;
      }
    }
  }
  if (!found) return false;
  hit->range_m = best;
  hit->point_m = o + best * d;
  if (hit->kind == SurfaceKind::kGround) {
    const int cell = s.cellIndex(hit->point_m.x(), hit->point_m.y());
    if (cell >= 0) {
      for (int id : s.cell_markings[static_cast<std::size_t>(cell)]) {
        const Marking& m = s.markings[static_cast<std::size_t>(id)];
        const double dx = hit->point_m.x() - m.centre.x(), dy = hit->point_m.y() - m.centre.y();
        // Rectangle frame: along = (sin h, cos h), across = (cos h, −sin h).
        const double a_len = dx * m.s + dy * m.c, a_wid = dx * m.c - dy * m.s;
        if (std::abs(a_len) <= m.half_len && std::abs(a_wid) <= m.half_wid) {
          hit->kind = SurfaceKind::kMarking;
          hit->intensity = m.intensity;
          break;
        }
      }
    }
  }
  if (hit->normal_m.dot(d) > 0) hit->normal_m = -hit->normal_m;
  return true;
}

void Scene::writeMesh(const std::string& path) const {
  if (!OpenMesh::IO::write_mesh(impl_->mesh, path)) {
    throw FileError(path, "", "OpenMesh could not write the scene mesh");
  }
}

}  // namespace mountcal::simulation
