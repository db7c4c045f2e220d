// The shared kernels of issue 27 against independent references: the k-d tree against brute
// force, the RANSAC plane against a plane the test draws its points from, the byte reader
// against byte patterns written out by hand (IEEE 754 and two's complement).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <numeric>
#include <random>
#include <stdexcept>
#include <utility>
#include <vector>

#include <ceres/sized_cost_function.h>

#include "adjustment/corrected_cost.hpp"
#include "geometry/column_grid.hpp"
#include "geometry/kd_tree.hpp"
#include "geometry/plane_ransac.hpp"
#include "geometry/point_geometry.hpp"
#include "io/bytes.hpp"
#include "mountcal/io/las.hpp"
#include "mountcal/report/evaluation.hpp"

namespace mountcal {
namespace {

template <typename Scalar, int Dim>
std::vector<Scalar> randomCloud(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-50.0, 50.0);
  std::vector<Scalar> c(Dim * n);
  for (Scalar& v : c) v = static_cast<Scalar>(u(rng));
  // A few exact duplicates and a tight cluster: ties and degenerate cells.
  for (int d = 0; d < Dim; ++d) c[Dim * 1 + d] = c[d];
  for (std::size_t i = 2; i < std::min<std::size_t>(n, 40); ++i)
    for (int d = 0; d < Dim; ++d) c[Dim * i + d] = static_cast<Scalar>(3.0 + 1e-3 * static_cast<double>(i % 7) * (d + 1));
  return c;
}

template <typename Scalar, int Dim>
double squaredDistance(const std::vector<Scalar>& c, std::size_t i, const Scalar* q) {
  double d2 = 0;
  for (int d = 0; d < Dim; ++d) {
    const double e = static_cast<double>(c[Dim * i + d]) - static_cast<double>(q[d]);
    d2 += e * e;
  }
  return d2;
}

template <typename Scalar, int Dim>
void checkAgainstBruteForce(std::uint32_t seed) {
  const std::size_t n = 3000;
  const std::vector<Scalar> cloud = randomCloud<Scalar, Dim>(n, seed);
  const detail::KdTree<Scalar, Dim> tree(cloud);
  ASSERT_EQ(tree.size(), n);
  std::mt19937 rng(seed + 1);
  std::uniform_real_distribution<double> u(-55.0, 55.0);
  for (int query = 0; query < 200; ++query) {
    Scalar q[Dim];
    for (int d = 0; d < Dim; ++d) q[d] = static_cast<Scalar>(query < 20 ? cloud[Dim * (query + 1) + d] : u(rng));
    std::vector<double> all(n);
    for (std::size_t i = 0; i < n; ++i) all[i] = squaredDistance<Scalar, Dim>(cloud, i, q);
    std::vector<double> sorted = all;
    std::sort(sorted.begin(), sorted.end());
    // k nearest: the same distances as brute force, nearest first.
    const std::size_t k = 1 + static_cast<std::size_t>(query % 12);
    std::vector<std::size_t> idx(k);
    std::vector<Scalar> d2(k);
    ASSERT_EQ(tree.nearest(q, k, idx.data(), d2.data()), k);
    for (std::size_t j = 0; j < k; ++j) {
      EXPECT_NEAR(all[idx[j]], sorted[j], 1e-9 * (1 + sorted[j]) + (sizeof(Scalar) == 4 ? 1e-3 : 0)) << "query " << query << " rank " << j;
      if (j > 0) {
        EXPECT_LE(d2[j - 1], d2[j]);
      }
    }
    // Radius: exactly the brute-force set (the boundary in double precision), sorted on demand.
    const double radius = 0.5 + 0.05 * query;
    std::vector<std::size_t> expected;
    for (std::size_t i = 0; i < n; ++i)
      if (all[i] <= radius * radius) expected.push_back(i);
    std::vector<std::size_t> got = tree.within(q, radius, /*sorted=*/true);
    const double order_tolerance = sizeof(Scalar) == 4 ? 1e-5 : 1e-12;
    for (std::size_t j = 1; j < got.size(); ++j) EXPECT_LE(all[got[j - 1]], all[got[j]] * (1 + order_tolerance) + order_tolerance);
    std::sort(got.begin(), got.end());
    EXPECT_EQ(got, expected) << "query " << query;
    std::vector<std::size_t> unsorted = tree.within(q, radius, /*sorted=*/false);
    std::sort(unsorted.begin(), unsorted.end());
    EXPECT_EQ(unsorted, expected);
  }
}

TEST(KdTree, MatchesBruteForce2dDouble) { checkAgainstBruteForce<double, 2>(11); }
TEST(KdTree, MatchesBruteForce3dDouble) { checkAgainstBruteForce<double, 3>(12); }
TEST(KdTree, MatchesBruteForce3dFloat) { checkAgainstBruteForce<float, 3>(13); }

TEST(KdTree, ManyQueriesAtOnceEqualOneByOne) {
  const std::vector<double> cloud = randomCloud<double, 3>(500, 5);
  const detail::KdTree<double, 3> tree(cloud);
  const std::vector<double> queries = randomCloud<double, 3>(64, 6);
  std::vector<std::size_t> many(64 * 2);
  std::vector<double> many_d2(64 * 2);
  ASSERT_EQ(tree.nearestMany(queries.data(), 64, 2, many.data(), many_d2.data()), 2u);
  for (std::size_t q = 0; q < 64; ++q) {
    std::size_t one[2];
    double one_d2[2];
    tree.nearest(&queries[3 * q], 2, one, one_d2);
    EXPECT_DOUBLE_EQ(many_d2[2 * q], one_d2[0]);
    EXPECT_DOUBLE_EQ(many_d2[2 * q + 1], one_d2[1]);
  }
}

TEST(KdTree, EmptyAndSmallTreesAnswerWhatTheyHold) {
  const detail::KdTree<double, 2> empty;
  const double q[2] = {0, 0};
  std::size_t idx[4];
  double d2[4];
  EXPECT_TRUE(empty.empty());
  EXPECT_EQ(empty.nearest(q, 4, idx, d2), 0u);
  EXPECT_TRUE(empty.within(q, 10.0, true).empty());
  const detail::KdTree<double, 2> two(std::vector<double>{1, 0, 0, 2});
  ASSERT_EQ(two.nearest(q, 4, idx, d2), 2u);  // k larger than the tree: all of it
  EXPECT_EQ(idx[0], 0u);
  EXPECT_DOUBLE_EQ(d2[0], 1.0);
  EXPECT_DOUBLE_EQ(d2[1], 4.0);
  EXPECT_EQ(two.within(q, 1.0, true), std::vector<std::size_t>{0});  // on the boundary: inside
  EXPECT_TRUE(two.within(q, 0.999999, true).empty());
}

/// A strip-like cloud: a sloped ground, a wall (a tall column of points), a dense cluster with
/// exact duplicates and a few far outliers.
std::vector<float> stripCloud(std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<float> c;
  auto add = [&](double x, double y, double z) {
    c.push_back(static_cast<float>(x));
    c.push_back(static_cast<float>(y));
    c.push_back(static_cast<float>(z));
  };
  for (int i = 0; i < 4000; ++i) {
    const double x = 60 * u(rng) - 30, y = 8 * u(rng) + 0.3 * x;  // a diagonal band
    add(x, y, 0.1 * x + 0.01 * u(rng));
  }
  for (int i = 0; i < 600; ++i) add(5 + 0.01 * u(rng), 3 + 2 * u(rng), 6 * u(rng));  // a wall
  for (int i = 0; i < 300; ++i) add(-4 + 1e-3 * (i % 5), 1 + 1e-3 * (i % 3), 0.5);   // a cluster with duplicates
  add(900, -700, 40);
  add(-1200, 50, -3);
  return c;
}

/// Brute force in the grid's own arithmetic: float squared distances, sorted with ties by index.
std::vector<std::pair<float, std::size_t>> bruteForce(const std::vector<float>& c, const float* q) {
  std::vector<std::pair<float, std::size_t>> all;
  for (std::size_t i = 0; i < c.size() / 3; ++i) {
    float d2 = 0;
    for (int d = 0; d < 3; ++d) {
      const float e = c[3 * i + static_cast<std::size_t>(d)] - q[d];
      d2 += e * e;
    }
    all.emplace_back(d2, i);
  }
  std::sort(all.begin(), all.end());
  return all;
}

TEST(ColumnGrid, AnswersWhatBruteForceAndTheFloatKdTreeAnswer) {
  for (std::uint32_t seed : {21u, 22u}) {
    const std::vector<float> cloud = stripCloud(seed);
    const detail::KdTree<float, 3> tree(cloud);
    for (double per_column : {1.0, 5.0, 30.0}) {
      const detail::ColumnGrid grid(cloud, per_column);
      ASSERT_EQ(grid.size(), cloud.size() / 3);
      std::mt19937 rng(seed + 7);
      std::uniform_real_distribution<double> u(-40.0, 40.0);
      for (int query = 0; query < 300; ++query) {
        float q[3];
        for (int d = 0; d < 3; ++d)  // on points, between them, and far outside the cloud
          q[d] = query < 60 ? cloud[3 * static_cast<std::size_t>(query * 71) + static_cast<std::size_t>(d)]
                            : static_cast<float>(query < 280 ? u(rng) / (d == 2 ? 8 : 1) : 3 * u(rng) * (d + 1));
        const auto expected = bruteForce(cloud, q);
        const std::size_t k = 1 + static_cast<std::size_t>(query % 31);
        std::vector<std::size_t> idx(k), tree_idx(k);
        std::vector<float> d2(k), tree_d2(k);
        ASSERT_EQ(grid.nearest(q, k, std::numeric_limits<double>::infinity(), idx.data(), d2.data()), k);
        tree.nearest(q, k, tree_idx.data(), tree_d2.data());
        for (std::size_t j = 0; j < k; ++j) {
          EXPECT_EQ(idx[j], expected[j].second) << "query " << query << " rank " << j;
          EXPECT_EQ(d2[j], expected[j].first);
          EXPECT_EQ(d2[j], tree_d2[j]);  // the same float distances as FLANN's
        }
        // A bound on the nearest: nothing when it lies beyond, the same answer when within.
        for (double gate : {0.05, 0.5, 3.0}) {
          const bool beyond = static_cast<double>(expected[0].first) > gate * gate;
          std::vector<std::size_t> gi(k);
          std::vector<float> gd(k);
          const std::size_t got = grid.nearest(q, k, gate, gi.data(), gd.data());
          EXPECT_EQ(got, beyond ? 0u : k) << "query " << query << " gate " << gate;
          if (got == k) {
            EXPECT_EQ(gi, idx);
          }
        }
      }
    }
  }
}

TEST(ColumnGrid, EmptySmallAndFlatGridsAnswerWhatTheyHold) {
  const detail::ColumnGrid empty;
  const float q[3] = {0, 0, 0};
  std::size_t idx[4];
  float d2[4];
  EXPECT_TRUE(empty.empty());
  EXPECT_EQ(empty.nearest(q, 4, 1e9, idx, d2), 0u);
  // Two points on one vertical line (a grid of one column), k larger than the grid: all of it.
  const detail::ColumnGrid line(std::vector<float>{0, 0, 2, 0, 0, -1}, 10.0);
  ASSERT_EQ(line.nearest(q, 4, 1e9, idx, d2), 2u);
  EXPECT_EQ(idx[0], 1u);
  EXPECT_EQ(d2[0], 1.0f);
  EXPECT_EQ(d2[1], 4.0f);
  EXPECT_EQ(line.nearest(q, 1, 0.999, idx, d2), 0u);  // nearest at 1 m: beyond 0.999 m
  EXPECT_EQ(line.nearest(q, 1, 1.0, idx, d2), 1u);    // on the bound: within
}

TEST(PlaneRansac, FindsThePlaneThePointsWereDrawnFromAmongOutliers) {
  // z = 0.2 x − 0.1 y + 5 with ±1 mm noise, and 30 % of points scattered in a 10 m cube.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-5, 5), e(-0.001, 0.001);
  std::vector<Vec3> points;
  std::vector<std::uint32_t> candidates;
  for (std::uint32_t i = 0; i < 1000; ++i) {
    const double x = u(rng), y = u(rng);
    points.emplace_back(x, y, i % 10 < 3 ? 5 + u(rng) : 0.2 * x - 0.1 * y + 5 + e(rng));
    candidates.push_back(i);
  }
  std::uniform_int_distribution<std::size_t> pick(0, candidates.size() - 1);
  const detail::PlaneHypothesis plane = detail::ransacPlane(points, candidates, 0.005, 200, [&] { return pick(rng); });
  ASSERT_TRUE(plane.found);
  const Vec3 truth = Vec3(-0.2, 0.1, 1).normalized();
  EXPECT_GT(std::abs(plane.normal.dot(truth)), std::cos(0.01));
  const std::vector<std::uint32_t> in = detail::planeInliers(points, candidates, plane.normal, plane.point, 0.005);
  EXPECT_EQ(in.size(), plane.inliers);
  EXPECT_GE(in.size(), 700u);
  EXPECT_LE(in.size(), 720u);  // the plane's 700 and the few outliers that happen to lie on it
}

TEST(PlaneRansac, PriorityPointsChooseTheSurfaceOfThePick) {
  // A ground plane z = 0 and a smaller board at z = 1: ranked by the board's first points first
  // (the pick's nearest neighbours), the board wins although the ground has more points.
  std::vector<Vec3> points;
  std::vector<std::size_t> candidates;
  for (int i = 0; i < 60; ++i) points.emplace_back(0.1 * (i % 3), 0.1 * (i / 3), 1.0);  // the first 6: a 3 × 2 block
  for (int i = 0; i < 120; ++i) points.emplace_back(-5 + 0.5 * (i % 20), -5 + 0.5 * (i / 20), 0.0);
  candidates.resize(points.size());
  std::iota(candidates.begin(), candidates.end(), std::size_t{0});
  std::mt19937 rng(1);
  std::uniform_int_distribution<std::size_t> pick(0, candidates.size() - 1);
  const auto ground = detail::ransacPlane(points, candidates, 0.01, 300, [&] { return pick(rng); });
  EXPECT_NEAR(ground.point.z(), 0.0, 1e-12);
  const auto board = detail::ransacPlane(
      points, candidates, 0.01, 300, [&] { return pick(rng); }, 6);
  EXPECT_NEAR(board.point.z(), 1.0, 1e-12);
  EXPECT_EQ(board.priority, 6u);
  EXPECT_EQ(board.inliers, 60u);
}

TEST(PlaneRansac, DegenerateSamplesFindNothing) {
  std::vector<Vec3> line;
  for (int i = 0; i < 10; ++i) line.emplace_back(i, 2 * i, 0);
  std::vector<std::uint32_t> all(10);
  std::iota(all.begin(), all.end(), 0u);
  std::size_t next = 0;
  EXPECT_FALSE(detail::ransacPlane(line, all, 0.1, 50, [&] { return next++ % 10; }).found);
}

TEST(Bytes, ReadAndWriteLittleEndianAsWrittenByHand) {
  // 1.5 = 0x3FF8000000000000; −2 as int16 = 0xFFFE; 0x01020304 stored 04 03 02 01.
  const std::uint8_t raw[] = {0xAA, 0, 0, 0, 0, 0, 0, 0xF8, 0x3F, 0xFE, 0xFF, 0x04, 0x03, 0x02, 0x01};
  EXPECT_EQ(io::bytes::get<double>(raw, 1), 1.5);
  EXPECT_EQ(io::bytes::get<std::int16_t>(raw, 9), -2);
  EXPECT_EQ(io::bytes::get<std::uint32_t>(raw, 11), 0x01020304u);
  std::uint8_t out[15] = {0xAA};
  io::bytes::put<double>(out, 1, 1.5);
  io::bytes::put<std::int16_t>(out, 9, -2);
  io::bytes::put<std::uint32_t>(out, 11, 0x01020304u);
  EXPECT_TRUE(std::equal(raw, raw + 15, out));
  std::vector<std::uint8_t> appended;
  io::bytes::put<std::uint16_t>(appended, 0x0102);
  EXPECT_EQ(appended, (std::vector<std::uint8_t>{0x02, 0x01}));
}

TEST(LasRecordLayout, TimeAndIntegersWhereTheSpecificationPutsThem) {
  // LAS 1.4 R15 tables 7–16: GPS time at byte 20 in formats 1, 3–5, at 22 in 6–10.
  EXPECT_FALSE(io::LasRecordLayout(0).has_gps_time);
  EXPECT_FALSE(io::LasRecordLayout(2).has_gps_time);
  for (int f : {1, 3, 4, 5}) EXPECT_EQ(io::LasRecordLayout(f).gps_time_offset, 20u) << f;
  for (int f : {6, 7, 8, 9, 10}) EXPECT_EQ(io::LasRecordLayout(f).gps_time_offset, 22u) << f;
  std::uint8_t record[30] = {};
  const std::int32_t xyz[3] = {-7, 123456, 2147483647};
  io::LasRecordLayout::setIntegers(record, xyz);
  EXPECT_EQ(record[0], 0xF9);  // −7
  EXPECT_EQ(record[11], 0x7F);
  io::bytes::put<double>(record, 22, 4321.25);
  EXPECT_EQ(io::LasRecordLayout(6).gpsTime(record), 4321.25);
  std::int32_t back[3];
  io::LasRecordLayout::integers(record, back);
  EXPECT_TRUE(std::equal(xyz, xyz + 3, back));
}

// The pass-to-pass discrepancy on two planar grids of spacing s, the second 5 cm above the first
// and shifted by half a cell: every used point is 0.05 m from the plane of its neighbours (a
// plane fitted to coplanar points is exact). The size gates' defaults fit centimetre spacing; at
// 0.5 m (an airborne strip) k = 10 neighbours span √λ_max ≈ 0.45 m, so without the spacing rule
// no point passes, and with it, every one.
std::vector<Vec3> grid(double spacing_m, double z_m, double shift_m) {
  std::vector<Vec3> x;
  for (int i = 0; i < 60; ++i)
    for (int j = 0; j < 60; ++j) x.emplace_back(shift_m + i * spacing_m, shift_m + j * spacing_m, z_m);
  return x;
}

TEST(Discrepancy, GatesWidenWithThePointSpacingOfSparseStrips) {
  const DiscrepancyOptions d;
  // r = s √(k/π): 0.5 · √(10/π) = 0.892 m; extent 1.5 r = 1.338 m, nearest 3 s = 1.5 m.
  const DiscrepancyOptions sparse = d.forSpacing(0.5);
  EXPECT_NEAR(sparse.max_extent_m, 1.5 * 0.5 * std::sqrt(10.0 / 3.14159265358979), 1e-12);
  EXPECT_DOUBLE_EQ(sparse.max_neighbour_distance_m, 1.5);
  const DiscrepancyOptions dense = d.forSpacing(0.05);  // a UAV pass keeps the defaults
  EXPECT_DOUBLE_EQ(dense.max_extent_m, 0.3);
  EXPECT_DOUBLE_EQ(dense.max_neighbour_distance_m, 1.0);
  for (double s : {0.05, 0.5}) {
    const DiscrepancyStats widened = pointToPlaneDiscrepancy(grid(s, 0.05, s / 2), grid(s, 0.0, 0.0));
    EXPECT_GT(widened.used, widened.queries / 2) << s;
    EXPECT_NEAR(widened.median_m, 0.05, 1e-9) << s;
    EXPECT_NEAR(widened.p90_m, 0.05, 1e-9) << s;
  }
  DiscrepancyOptions fixed;
  fixed.from_spacing = false;
  EXPECT_EQ(pointToPlaneDiscrepancy(grid(0.5, 0.05, 0.25), grid(0.5, 0.0, 0.0), fixed).used, 0u);
  EXPECT_GT(pointToPlaneDiscrepancy(grid(0.05, 0.05, 0.025), grid(0.05, 0.0, 0.0), fixed).used, 1000u);
}

// ---- the trajectory corrections' cost (adjustment/corrected_cost.hpp) -----------------------------

/// Two residuals, nonlinear in the strip offset o (block 1): r₀ = m₀ + 2 o_x − 3 o_z,
/// r₁ = o_y² + m₄ o_x.
class NonlinearInOffset final : public ceres::SizedCostFunction<2, 6, 3> {
 public:
  bool Evaluate(double const* const* p, double* r, double** J) const override {
    const double* m = p[0];
    const double* o = p[1];
    r[0] = m[0] + 2 * o[0] - 3 * o[2];
    r[1] = o[1] * o[1] + m[4] * o[0];
    if (J && J[0]) {
      std::fill(J[0], J[0] + 12, 0.0);
      J[0][0] = 1;
      J[0][6 + 4] = o[0];
    }
    if (J && J[1]) {
      const double j1[6] = {2, 0, -3, m[4], 2 * o[1], 0};
      std::copy(j1, j1 + 6, J[1]);
    }
    return true;
  }
};

TEST(CorrectedCost, JacobiansEqualCentralDifferencesOfTheCorrectedResidual) {
  // Position degree 2, attitude degree 1, the time offset: the shift is
  // δ = c₁ τ + c₂ (3τ² − 1)/2 + (e₁ τ) × u + δt w, checked by hand at one point, and every
  // Jacobian against central differences of the wrapped cost itself.
  detail::CorrectionTerm term;
  term.offset_block = 1;
  term.correction_block = 2;
  term.tau = 0.3;
  term.u_m = Vec3(10, -20, -100);
  term.motion_m_s = Vec3(60, 1, 0.5);
  detail::CorrectedCost cost(new NonlinearInOffset, {term}, 2, 1, 1, true);
  ASSERT_EQ(cost.parameter_block_sizes(), (std::vector<int32_t>{6, 3, 9, 1}));
  double m[6] = {0.1, 0.2, 0.3, 0.01, 0.02, 0.03}, o[3] = {0.01, -0.02, 0.03}, dt[1] = {0.004};
  double c[9] = {0.01, 0.02, -0.03, 0.002, -0.001, 0.003, -1e-4, 5e-5, 2e-4};
  double* blocks[4] = {m, o, c, dt};
  // By hand: the shifted offset and r.
  const double tau = 0.3, p2 = 0.5 * (3 * tau * tau - 1);
  const Vec3 e(c[6] * tau, c[7] * tau, c[8] * tau);
  const Vec3 shift = Vec3(c[0], c[1], c[2]) * tau + Vec3(c[3], c[4], c[5]) * p2 + e.cross(term.u_m) + dt[0] * term.motion_m_s;
  const Vec3 oc = Vec3(o[0], o[1], o[2]) + shift;
  double r[2];
  ASSERT_TRUE(cost.Evaluate(blocks, r, nullptr));
  EXPECT_NEAR(r[0], m[0] + 2 * oc.x() - 3 * oc.z(), 1e-12);
  EXPECT_NEAR(r[1], oc.y() * oc.y() + m[4] * oc.x(), 1e-12);
  std::vector<std::vector<double>> J = {std::vector<double>(12), std::vector<double>(6), std::vector<double>(18), std::vector<double>(2)};
  double* jac[4] = {J[0].data(), J[1].data(), J[2].data(), J[3].data()};
  ASSERT_TRUE(cost.Evaluate(blocks, r, jac));
  const int sizes[4] = {6, 3, 9, 1};
  for (int b = 0; b < 4; ++b)
    for (int k = 0; k < sizes[b]; ++k) {
      const double h = 1e-6, keep = blocks[b][k];
      double rp[2], rm[2];
      blocks[b][k] = keep + h;
      cost.Evaluate(blocks, rp, nullptr);
      blocks[b][k] = keep - h;
      cost.Evaluate(blocks, rm, nullptr);
      blocks[b][k] = keep;
      for (int i = 0; i < 2; ++i)
        EXPECT_NEAR(J[b][i * sizes[b] + k], (rp[i] - rm[i]) / (2 * h), 1e-6 * (1 + std::abs(J[b][i * sizes[b] + k])))
            << "block " << b << " column " << k << " residual " << i;
    }
  // Ceres leaves out the Jacobian of a constant block (a held strip offset): the others stay right.
  double* partial[4] = {nullptr, nullptr, J[2].data(), nullptr};
  std::vector<double> J2 = J[2];
  ASSERT_TRUE(cost.Evaluate(blocks, r, partial));
  EXPECT_EQ(J[2], J2);
}

/// r = o (the strip offset block as the source sees it: with corrections, o + δ).
class OffsetEcho final : public ceres::SizedCostFunction<3, 6, 3> {
 public:
  bool Evaluate(double const* const* p, double* r, double** J) const override {
    std::copy(p[1], p[1] + 3, r);
    if (J && J[0]) std::fill(J[0], J[0] + 18, 0.0);
    if (J && J[1]) {
      std::fill(J[1], J[1] + 9, 0.0);
      J[1][0] = J[1][4] = J[1][8] = 1.0;
    }
    return true;
  }
};

/// ∫∫ P_k(x) P_l(y) exp(−a |x − y|) dx dy over [−1, 1]², by hand: the square split at its diagonal,
/// each triangle integrated in y, then in x (done symbolically with sympy, not by mountcal; a = 1.5 gives 0.27213069538799,
/// 0.08039649917719 and −0.03606994458276).
double legendreKernelIntegral(int k, int l, double a) {
  const double e = std::exp(-2 * a);
  if (k == 1 && l == 1) return 2 * (2 * std::pow(a, 3) + 3 * (1 - a * a) - (3 * a * a + 6 * a + 3) * e) / (3 * std::pow(a, 4));
  if (k == 2 && l == 2)
    return 2 *
           (2 * std::pow(a, 5) + 5 * (-std::pow(a, 4) + 3 * a * a - 9) +
            (5 * std::pow(a, 4) + 30 * std::pow(a, 3) + 75 * a * a + 90 * a + 45) * e) /
           (5 * std::pow(a, 6));
  // (1, 3)
  return 2 *
         (-std::pow(a, 4) + 5 * std::pow(a, 3) - 9 * a * a + 15 + (-std::pow(a, 4) - 7 * std::pow(a, 3) - 21 * a * a - 30 * a - 15) * e) /
         std::pow(a, 6);
}

TEST(TrajectoryCorrections, PriorsFromTheAccuracyAreTheLegendreCoefficientsCovarianceOfTheGaussMarkovError) {
  // A 45 s strip under a Gauss–Markov error of σ = 2 cm and τ = 15 s: in τ ∈ [−1, 1] the kernel is
  // exp(−a |τ − τ'|) with a = 45 / (2 · 15) = 1.5, and cov(c_k, c_l) = σ² (2k+1)(2l+1)/4 I_kl(a).
  const double sigma = 0.02, t0 = 100.0, t1 = 145.0, tau = 15.0, a = (t1 - t0) / (2 * tau);
  EXPECT_NEAR(legendreKernelIntegral(1, 1, 1.5), 0.27213069538799, 1e-12);
  EXPECT_NEAR(legendreKernelIntegral(2, 2, 1.5), 0.08039649917719, 1e-12);
  EXPECT_NEAR(legendreKernelIntegral(1, 3, 1.5), -0.03606994458276, 1e-12);
  const Eigen::MatrixXd C = detail::legendreCoefficientCovariance(3, t0, t1, tau, [&](double) { return sigma; });
  const double s2 = sigma * sigma;
  EXPECT_NEAR(C(0, 0), s2 * 9.0 / 4 * legendreKernelIntegral(1, 1, a), 1e-6 * C(0, 0));
  EXPECT_NEAR(C(1, 1), s2 * 25.0 / 4 * legendreKernelIntegral(2, 2, a), 1e-6 * C(1, 1));
  EXPECT_NEAR(C(0, 2), s2 * 21.0 / 4 * legendreKernelIntegral(1, 3, a), 1e-6 * C(0, 0));
  EXPECT_NEAR(C(2, 0), C(0, 2), 1e-15);
  EXPECT_NEAR(C(0, 1), 0.0, 1e-9 * C(0, 0));  // odd against even
  // A σ twice as large on the strip's second half only: between 1× and 4× the variance.
  const Eigen::MatrixXd C2 = detail::legendreCoefficientCovariance(1, t0, t1, tau, [&](double t) { return t > 122.5 ? 2 * sigma : sigma; });
  EXPECT_GT(C2(0, 0), 1.5 * C(0, 0));
  EXPECT_LT(C2(0, 0), 4.0 * C(0, 0));
  // A much longer correlation time leaves little drift within the strip; a span of one instant none.
  EXPECT_LT(detail::legendreCoefficientCovariance(1, t0, t1, 1e4, [&](double) { return sigma; })(0, 0), 0.01 * C(0, 0));
  EXPECT_EQ(detail::legendreCoefficientCovariance(2, t0, t0, tau, [&](double) { return sigma; }).norm(), 0.0);

  // The adjustment takes them as each strip's prior: its σ at the strip's end is √(Σ_kl C_kl),
  // the stated σ (TrajectoryAccuracy: position 2 cm, τ 15 s; attitude 0.002° / 0.004°, τ 5 s).
  TrajectoryAccuracy acc;
  acc.position_sigma_m = sigma;
  acc.position_correlation_s = tau;
  TrajectoryCorrections tc;
  tc.position_degree = 2;
  tc.attitude_degree = 1;
  tc.priors_from_accuracy = true;
  AdjustmentProblem P({0, 0, 0, 0, 0, 0}, 0.02, LossType::kTrivial, 0.5, 1e-6);
  P.setCorrections(tc, 0.0, acc);
  for (double t : {t0, t1, 120.0})
    P.setEpoch(P.addResidualBlock(new OffsetEcho, 0.0, {P.mounting(), P.stripOffset("a")}), "a", t, {0, 0, -100});
  P.commit();
  ASSERT_EQ(P.stripCorrections().size(), 1u);
  const auto& sc = P.stripCorrections()[0];
  const Eigen::MatrixXd Cp = detail::legendreCoefficientCovariance(2, t0, t1, tau, [&](double) { return sigma; });
  for (int axis = 0; axis < 3; ++axis) EXPECT_NEAR(sc.prior_end_position_m[axis], std::sqrt(Cp.sum()), 1e-12) << axis;
  const double heading = deg2rad(acc.heading_sigma_deg);
  const Eigen::MatrixXd Ch = detail::legendreCoefficientCovariance(1, t0, t1, acc.attitude_correlation_s, [&](double) { return heading; });
  EXPECT_NEAR(sc.prior_end_attitude_rad.z(), std::sqrt(Ch(0, 0)), 1e-15);
  // Without the accuracy the option is refused, naming what to do.
  StochasticOptions st;
  st.corrections = tc;
  st.trajectory = TrajectoryAccuracy::none();
  std::string why;
  EXPECT_FALSE(st.IsValid(&why));
  EXPECT_NE(why.find("priors_from_accuracy"), std::string::npos) << why;
}

TEST(PointShifts, AreTheShiftsTheCorrectedCostAppliesAndTheHandFormula) {
  // A matching source matches where the adjustment puts its points (PointShifts): the strip
  // offset, the corrections and the time offset at a point's time and u must be exactly what
  // the wrapped cost passes to the source. Three epochs of strip "a" (span 100–140 s, so the
  // one at 130 s has τ = 0.5), position degree 2, attitude degree 1, the time offset estimated.
  AdjustmentProblem P({0, 0, 0, 0, 0, 0}, 0.02, LossType::kTrivial, 0.5, 1e-6);
  const Vec3 v(60, 1, 0.5), w(0.001, -0.002, 0.01);
  P.setMotion([&](const std::string&, double, Vec3* vel, Vec3* rate) {
    *vel = v, *rate = w;
    return true;
  });
  TrajectoryCorrections tc;
  tc.position_degree = 2;
  tc.attitude_degree = 1;
  P.setCorrections(tc, 0.01);
  const Vec3 u(10, -20, -100);
  int probe = -1;
  for (double t : {100.0, 140.0, 130.0}) {
    probe = P.addResidualBlock(new OffsetEcho, 0.0, {P.mounting(), P.stripOffset("a")});
    P.setEpoch(probe, "a", t, u);
  }
  P.commit();
  ASSERT_EQ(P.stripCorrections().size(), 1u);
  ASSERT_NE(P.timeOffsetBlock(), nullptr);
  const double o[3] = {0.01, -0.02, 0.03}, c[9] = {0.01, 0.02, -0.03, 0.002, -0.001, 0.003, -1e-4, 5e-5, 2e-4};
  std::copy(o, o + 3, P.stripOffset("a"));
  std::copy(c, c + 9, P.stripCorrections()[0].values);
  *P.timeOffsetBlock() = 0.004;
  // By hand at τ = 0.5: o + c₁ τ + c₂ (3τ² − 1)/2 + (e₁ τ) × u + δt (v + ω × u).
  const double tau = 0.5, p2 = 0.5 * (3 * tau * tau - 1);
  const Vec3 hand = Vec3(o[0], o[1], o[2]) + Vec3(c[0], c[1], c[2]) * tau + Vec3(c[3], c[4], c[5]) * p2 +
                    (Vec3(c[6], c[7], c[8]) * tau).cross(u) + 0.004 * (v + w.cross(u));
  const PointShifts shifts = P.pointShifts();
  const Vec3 at = shifts.strip("a").at(130.0, u);
  const Eigen::VectorXd applied = P.residual(probe);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(at[k], hand[k], 1e-12) << k;
    EXPECT_NEAR(at[k], applied[k], 1e-12) << k;
  }
  // Beyond the span τ is clamped, as in the cost; a strip the solve did not see moves by δt alone.
  EXPECT_LT((shifts.strip("a").at(150.0, u) - shifts.strip("a").at(140.0, u)).norm(), 1e-12);
  EXPECT_LT((shifts.strip("b").at(130.0, u) - 0.004 * (v + w.cross(u))).norm(), 1e-12);
  EXPECT_TRUE(PointShifts().empty());
  EXPECT_EQ(PointShifts().strip("a").at(130.0, u), Vec3::Zero());
}

}  // namespace
}  // namespace mountcal

// PlanGrid::box visits only the occupied cells: a box of ±10⁶ m (or ±1e300 m) returns the same
// points as one around the data, at once; an inverted or NaN box returns none.
TEST(Kernels, PlanGridBoxIsBoundedByTheOccupiedCells) {
  using mountcal::Vec3;
  namespace detail = mountcal::detail;
  std::vector<Vec3> x;
  for (int i = 0; i < 50; ++i) x.emplace_back(0.37 * i - 3.0, 0.21 * i + 1.0, 0.0);
  const detail::PlanGrid g(x, 4.0);
  const auto all = g.box(x, -10, -10, 30, 30);
  ASSERT_EQ(all.size(), x.size());
  EXPECT_EQ(g.box(x, -1e6, -1e6, 1e6, 1e6), all);
  EXPECT_EQ(g.box(x, -1e300, -1e300, 1e300, 1e300), all);
  EXPECT_EQ(g.box(x, 0.0, 0.0, 5.0, 5.0).size(), static_cast<std::size_t>(std::count_if(x.begin(), x.end(), [](const Vec3& p) {
              return p.x() >= 0 && p.x() <= 5 && p.y() >= 0 && p.y() <= 5;
            })));
  EXPECT_TRUE(g.box(x, 5, 5, 0, 0).empty());
  EXPECT_TRUE(g.box(x, std::nan(""), 0, 5, 5).empty());
}

// The share of a Gauss–Markov error that stays in the residuals when the strip's terms absorb
// polynomials in time, against hand derivations: two epochs of equal weight whose mean is
// absorbed keep (1 − ρ)/2 each; three equally spaced epochs with a line absorbed keep the part
// along v = (1, −2, 1)/√6, i.e. (vᵀρv) v_i² with vᵀρv = (6 − 8ρ₁ + 2ρ₂)/6; nothing absorbed keeps 1.
TEST(ResidualShare, IsWhatTheAbsorbedPolynomialsLeaveByHand) {
  const double tau = 30.0;
  const double rho = std::exp(-10.0 / tau);
  const Eigen::VectorXd two = mountcal::detail::residualShare({0.0, 10.0}, {1.0, 1.0}, tau, {0});
  EXPECT_NEAR(two(0), (1 - rho) / 2, 1e-12);
  EXPECT_NEAR(two(1), (1 - rho) / 2, 1e-12);
  const double r1 = std::exp(-5.0 / tau), r2 = std::exp(-10.0 / tau), vrv = (6 - 8 * r1 + 2 * r2) / 6;
  const Eigen::VectorXd three = mountcal::detail::residualShare({0.0, 5.0, 10.0}, {1.0, 1.0, 1.0}, tau, {0, 1});
  EXPECT_NEAR(three(0), vrv / 6, 1e-12);
  EXPECT_NEAR(three(1), 4 * vrv / 6, 1e-12);
  EXPECT_NEAR(three(2), vrv / 6, 1e-12);
  const Eigen::VectorXd none = mountcal::detail::residualShare({0.0, 5.0, 10.0}, {1.0, 1.0, 1.0}, tau, {});
  EXPECT_NEAR(none(0), 1.0, 0.0);
  EXPECT_NEAR(none(2), 1.0, 0.0);
  // Epochs many τ apart are independent: the mean of two takes half of each one's variance.
  const Eigen::VectorXd far = mountcal::detail::residualShare({0.0, 300.0}, {1.0, 1.0}, tau, {0});
  EXPECT_NEAR(far(0), 0.5 * (1 - std::exp(-10.0)), 1e-12);
  // An offset that takes κ of the mean (a random effect, κ = 1 − σ²_post/σ²_prior): e₀ − κ(e₀ + e₁)/2
  // keeps (1 − κ/2)² + κ²/4 − 2 (1 − κ/2)(κ/2) ρ; κ = 1 is the full mean above, κ = 0 keeps all.
  for (double kappa : {0.0, 0.3, 0.5, 1.0}) {
    const Eigen::VectorXd part = mountcal::detail::residualShare({0.0, 10.0}, {1.0, 1.0}, tau, {0}, kappa);
    const double expected = std::pow(1 - kappa / 2, 2) + kappa * kappa / 4 - 2 * (1 - kappa / 2) * (kappa / 2) * rho;
    EXPECT_NEAR(part(0), expected, 1e-12) << "kappa " << kappa;
    EXPECT_NEAR(part(1), expected, 1e-12) << "kappa " << kappa;
  }
  // With a line absorbed too, only the constant is shared: κ = 1 gives the full projection.
  const Eigen::VectorXd line = mountcal::detail::residualShare({0.0, 5.0, 10.0}, {1.0, 1.0, 1.0}, tau, {0, 1}, 1.0);
  EXPECT_NEAR(line(1), 4 * vrv / 6, 1e-12);
}

namespace {

/// r = (x − y) / σ for a point block x (3 residuals).
class PointEcho final : public ceres::SizedCostFunction<3, 3> {
 public:
  PointEcho(const mountcal::Vec3& y, double sigma) : y_(y), s_(sigma) {}
  bool Evaluate(double const* const* p, double* r, double** J) const override {
    for (int a = 0; a < 3; ++a) r[a] = (p[0][a] - y_[a]) / s_;
    if (J && J[0]) {
      std::fill(J[0], J[0] + 9, 0.0);
      J[0][0] = J[0][4] = J[0][8] = 1.0 / s_;
    }
    return true;
  }

 private:
  mountcal::Vec3 y_;
  double s_;
};

/// r = (m_j − y) / σ on one mounting parameter.
class MountingEcho final : public ceres::SizedCostFunction<1, 6> {
 public:
  MountingEcho(int j, double y, double sigma) : j_(j), y_(y), s_(sigma) {}
  bool Evaluate(double const* const* p, double* r, double** J) const override {
    r[0] = (p[0][j_] - y_) / s_;
    if (J && J[0]) {
      std::fill(J[0], J[0] + 6, 0.0);
      J[0][j_] = 1.0 / s_;
    }
    return true;
  }

 private:
  int j_;
  double y_, s_;
};

}  // namespace

TEST(AdjustmentProblem, LeverageIsTheWeightedMeansHatMatrix) {
  // A point observed three times (σ 1, 2 and 4 cm) with a prior of 3 cm, the mounting's roll
  // observed twice (σ 2 and 4 mrad) and its pitch once, pitch held. By hand, a weighted mean's
  // hat matrix is w_i / Σ w on each axis (w = 1/σ²), a held parameter's observation has none,
  // and the redundancies sum to observations − unknowns: 15 − (3 + 1) = 11.
  using mountcal::AdjustmentProblem;
  AdjustmentProblem P({0, 0, 0, 0, 0, 0}, 0.0, mountcal::LossType::kTrivial, 0.5, 1e-6);
  const double zero[3] = {0, 0, 0};
  double* x = P.addNuisanceBlock(3, zero);
  const double point_sigma[4] = {0.01, 0.02, 0.04, 0.03};  // the last: the prior
  std::vector<int> records;
  for (double s : point_sigma) records.push_back(P.addResidualBlock(new PointEcho(mountcal::Vec3(0.1, -0.2, 0.3), s), 0.0, {x}));
  const double roll_sigma[2] = {0.002, 0.004};
  for (double s : roll_sigma) records.push_back(P.addResidualBlock(new MountingEcho(3, 0.001, s), 0.0, {P.mounting()}));
  records.push_back(P.addResidualBlock(new MountingEcho(4, 0.002, 0.003), 0.0, {P.mounting()}));
  P.setEstimated({true, true, true, true, false, true});
  const std::vector<Eigen::MatrixXd> H = P.leverage(records);
  ASSERT_EQ(H.size(), records.size());
  double W = 0, Wr = 0, redundancy = 0;
  for (double s : point_sigma) W += 1 / (s * s);
  for (double s : roll_sigma) Wr += 1 / (s * s);
  for (int i = 0; i < 4; ++i) {
    const Eigen::Matrix3d expected = Eigen::Matrix3d::Identity() / (point_sigma[i] * point_sigma[i] * W);
    EXPECT_LT((H[static_cast<std::size_t>(i)] - expected).cwiseAbs().maxCoeff(), 1e-9) << "observation " << i;
  }
  for (int i = 0; i < 2; ++i) EXPECT_NEAR(H[static_cast<std::size_t>(4 + i)](0, 0), 1 / (roll_sigma[i] * roll_sigma[i] * Wr), 1e-9);
  EXPECT_NEAR(H[6](0, 0), 0.0, 1e-12) << "a held parameter's observation has no leverage";
  for (const Eigen::MatrixXd& h : H) redundancy += static_cast<double>(h.rows()) - h.trace();
  EXPECT_NEAR(redundancy, 11.0, 1e-9);
}

TEST(AdjustmentProblem, LeaveOneOutCovarianceIsTheWeightedMeansHc3ByHand) {
  // A point observed on one axis by three observations (σ 1, 2 and 4 cm) and a prior (3 cm) at 0,
  // x at its weighted mean. By hand, per axis: h_i = w_i / W, e_i = (x − y_i)/σ_i, and the
  // covariance with the three observations' share from their leave-one-out residuals is
  // Σ_i (1/σ_i)² e_i² / (1 − h_i)² / W² + (1/σ_p)² / W² (the prior formal); the formal one 1/W.
  // Relative tolerance 1e-9: N carries a 1e-12 regularisation (a free direction's guard).
  using mountcal::AdjustmentProblem;
  AdjustmentProblem P({0, 0, 0, 0, 0, 0}, 0.0, mountcal::LossType::kTrivial, 0.5, 1e-6);
  const double zero[3] = {0, 0, 0};
  double* x = P.addNuisanceBlock(3, zero);
  const double sigma[3] = {0.01, 0.02, 0.04}, y[3] = {0.012, -0.03, 0.05}, sigma_p = 0.03;
  std::vector<int> observations;
  for (int i = 0; i < 3; ++i)
    observations.push_back(P.addResidualBlock(new PointEcho(mountcal::Vec3(y[i], y[i], y[i]), sigma[i]), 0.0, {x}));
  P.addResidualBlock(new PointEcho(mountcal::Vec3::Zero(), sigma_p), 0.0, {x});
  double W = 1 / (sigma_p * sigma_p), mean = 0;
  for (int i = 0; i < 3; ++i) W += 1 / (sigma[i] * sigma[i]), mean += y[i] / (sigma[i] * sigma[i]);
  mean /= W;
  std::fill(x, x + 3, mean);
  const double prior_term = 1 / (sigma_p * sigma_p * W * W);  // diagonal: the prior's formal share
  double hand = prior_term;
  for (int i = 0; i < 3; ++i) {
    const double h = 1 / (sigma[i] * sigma[i] * W), e = (mean - y[i]) / sigma[i];
    hand += e * e / (sigma[i] * sigma[i] * (1 - h) * (1 - h) * W * W);
  }
  Eigen::MatrixXd formal;
  const Eigen::MatrixXd C = P.leaveOneOutCovariance(x, observations, &formal);
  ASSERT_EQ(C.rows(), 3);
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(C(a, a), hand, 1e-9 * hand) << a;
    EXPECT_NEAR(formal(a, a), 1 / W, 1e-9 / W) << a;
  }
  EXPECT_NEAR(C(0, 1), hand - prior_term, 1e-9 * hand) << "the same error on every axis here: the observations' share is all one";
  const Eigen::MatrixXd none = P.leaveOneOutCovariance(x, {});
  EXPECT_NEAR(none(0, 0), 1 / W, 1e-9 / W) << "nothing listed: the formal covariance";
  EXPECT_THROW(P.leaveOneOutCovariance(P.mounting(), {}), std::invalid_argument);
}
