#pragma once
// Internal (not installed): the one k-d tree of the library, an exact FLANN single-index tree
// over points of 2 or 3 coordinates. Every nearest-neighbour and radius search of the methods,
// the job loader and the evaluation goes through it — except the dense matching's, which moves
// every point each round and searches its column grid (column_grid.hpp). Tested against brute
// force in tests/test_kernels.cpp.
//
// FLANN is seen by src/geometry/kd_tree.cpp alone, which uses its single-index tree directly (a
// flann::Index instantiates every index type FLANN has — k-means, LSH, autotuned, … — which cost
// each including translation unit up to a minute of compile time under the sanitizers). The trees
// used are instantiated there: <double, 2>, <double, 3> and <float, 3>.

#include <cstddef>
#include <memory>
#include <vector>

namespace mountcal::detail {

/// Exact k-d tree over `Dim`-dimensional points stored row-major (x, y[, z] per point).
/// Callers centre kilometre-size coordinates before they enter (float trees lose them).
template <typename Scalar, int Dim>
class KdTree {
 public:
  KdTree();
  /// Takes the coordinates: `coords.size() / Dim` points. A tree of no points answers nothing.
  explicit KdTree(std::vector<Scalar> coords);
  KdTree(KdTree&&) noexcept;
  KdTree& operator=(KdTree&&) noexcept;
  ~KdTree();

  std::size_t size() const { return coords_.size() / Dim; }
  bool empty() const { return !index_; }
  /// Coordinate c of point i, as stored.
  Scalar coord(std::size_t i, int c) const { return coords_[Dim * i + static_cast<std::size_t>(c)]; }

  /// The min(k, size()) nearest points of `query` (Dim values), nearest first: their indices
  /// and squared distances in the arrays given (room for k each). Returns how many.
  std::size_t nearest(const Scalar* query, std::size_t k, std::size_t* indices, Scalar* squared_distances) const {
    return nearestMany(query, 1, k, indices, squared_distances);
  }

  /// nearest() for `count` queries stored row-major; the answers row-major, k per query.
  std::size_t nearestMany(const Scalar* queries, std::size_t count, std::size_t k, std::size_t* indices, Scalar* squared_distances) const;

  /// Indices of every point within `radius` of `query` (the boundary checked in double
  /// precision, as FLANN takes the radius as a float), nearest first when `sorted`.
  std::vector<std::size_t> within(const Scalar* query, double radius, bool sorted) const;
  /// within() into a vector the caller keeps (cleared first): no allocation once it has grown.
  void within(const Scalar* query, double radius, bool sorted, std::vector<std::size_t>* out) const;

 private:
  struct Index;  // the FLANN index, defined in kd_tree.cpp
  std::vector<Scalar> coords_;
  std::unique_ptr<Index> index_;
};

extern template class KdTree<double, 2>;
extern template class KdTree<double, 3>;
extern template class KdTree<float, 3>;

}  // namespace mountcal::detail
