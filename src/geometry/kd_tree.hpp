#pragma once
// Internal (not installed): the one k-d tree of the library, an exact FLANN single-index tree
// over points of 2 or 3 coordinates. Every nearest-neighbour and radius search of the methods,
// the job loader and the evaluation goes through it (tested against brute force in
// tests/test_kd_tree.cpp).

#include <flann/flann.hpp>

#include <algorithm>
#include <cstddef>
#include <memory>
#include <vector>

namespace mountcal::detail {

/// Exact k-d tree over `Dim`-dimensional points stored row-major (x, y[, z] per point).
/// Callers centre kilometre-size coordinates before they enter (float trees lose them).
template <typename Scalar, int Dim>
class KdTree {
 public:
  KdTree() = default;
  /// Takes the coordinates: `coords.size() / Dim` points. A tree of no points answers nothing.
  explicit KdTree(std::vector<Scalar> coords) : coords_(std::move(coords)) {
    const std::size_t n = size();
    if (n == 0) return;
    tree_ = std::make_unique<Index>(flann::Matrix<Scalar>(coords_.data(), n, Dim), flann::KDTreeSingleIndexParams(12));
    tree_->buildIndex();
  }
  KdTree(KdTree&&) noexcept = default;
  KdTree& operator=(KdTree&&) noexcept = default;

  std::size_t size() const { return coords_.size() / Dim; }
  bool empty() const { return !tree_; }
  /// Coordinate c of point i, as stored.
  Scalar coord(std::size_t i, int c) const { return coords_[Dim * i + static_cast<std::size_t>(c)]; }

  /// The min(k, size()) nearest points of `query` (Dim values), nearest first: their indices
  /// and squared distances in the arrays given (room for k each). Returns how many.
  std::size_t nearest(const Scalar* query, std::size_t k, std::size_t* indices, Scalar* squared_distances) const {
    return nearestMany(query, 1, k, indices, squared_distances);
  }

  /// nearest() for `count` queries stored row-major; the answers row-major, k per query.
  std::size_t nearestMany(const Scalar* queries, std::size_t count, std::size_t k, std::size_t* indices, Scalar* squared_distances) const {
    k = std::min(k, size());
    if (!tree_ || k == 0 || count == 0) return 0;
    flann::Matrix<Scalar> q(const_cast<Scalar*>(queries), count, Dim);
    flann::Matrix<std::size_t> im(indices, count, k);
    flann::Matrix<Scalar> dm(squared_distances, count, k);
    tree_->knnSearch(q, im, dm, static_cast<int>(k), flann::SearchParams(flann::FLANN_CHECKS_UNLIMITED));
    return k;
  }

  /// Indices of every point within `radius` of `query` (the boundary checked in double
  /// precision, as FLANN takes the radius as a float), nearest first when `sorted`.
  std::vector<std::size_t> within(const Scalar* query, double radius, bool sorted) const {
    std::vector<std::size_t> out;
    if (!tree_ || !(radius >= 0)) return out;
    flann::Matrix<Scalar> q(const_cast<Scalar*>(query), 1, Dim);
    std::vector<std::vector<std::size_t>> found;
    std::vector<std::vector<Scalar>> dists;
    flann::SearchParams params(flann::FLANN_CHECKS_UNLIMITED);
    params.sorted = sorted;
    // A radius a little wider than asked in float, then the exact boundary below.
    const double r2 = radius * radius;
    tree_->radiusSearch(q, found, dists, static_cast<float>(r2 * (1 + 1e-6) + 1e-30), params);
    out.reserve(found[0].size());
    for (std::size_t i : found[0]) {
      double d2 = 0;
      for (int c = 0; c < Dim; ++c) {
        const double d = static_cast<double>(coord(i, c)) - static_cast<double>(query[c]);
        d2 += d * d;
      }
      if (d2 <= r2) out.push_back(i);
    }
    return out;
  }

 private:
  using Index = flann::Index<flann::L2_Simple<Scalar>>;
  std::vector<Scalar> coords_;
  std::unique_ptr<Index> tree_;
};

}  // namespace mountcal::detail
