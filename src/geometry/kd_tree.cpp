#include "geometry/kd_tree.hpp"

#include <flann/flann.hpp>

#include <algorithm>

namespace mountcal::detail {

template <typename Scalar, int Dim>
struct KdTree<Scalar, Dim>::Index {
  flann::Index<flann::L2_Simple<Scalar>> tree;
};

template <typename Scalar, int Dim>
KdTree<Scalar, Dim>::KdTree() = default;

template <typename Scalar, int Dim>
KdTree<Scalar, Dim>::KdTree(std::vector<Scalar> coords) : coords_(std::move(coords)) {
  const std::size_t n = size();
  if (n == 0) return;
  index_.reset(new Index{{flann::Matrix<Scalar>(coords_.data(), n, Dim), flann::KDTreeSingleIndexParams(12)}});
  index_->tree.buildIndex();
}

template <typename Scalar, int Dim>
KdTree<Scalar, Dim>::KdTree(KdTree&&) noexcept = default;
template <typename Scalar, int Dim>
KdTree<Scalar, Dim>& KdTree<Scalar, Dim>::operator=(KdTree&&) noexcept = default;
template <typename Scalar, int Dim>
KdTree<Scalar, Dim>::~KdTree() = default;

template <typename Scalar, int Dim>
std::size_t KdTree<Scalar, Dim>::nearestMany(const Scalar* queries, std::size_t count, std::size_t k, std::size_t* indices,
                                             Scalar* squared_distances) const {
  k = std::min(k, size());
  if (!index_ || k == 0 || count == 0) return 0;
  flann::Matrix<Scalar> q(const_cast<Scalar*>(queries), count, Dim);
  flann::Matrix<std::size_t> im(indices, count, k);
  flann::Matrix<Scalar> dm(squared_distances, count, k);
  index_->tree.knnSearch(q, im, dm, static_cast<int>(k), flann::SearchParams(flann::FLANN_CHECKS_UNLIMITED));
  return k;
}

template <typename Scalar, int Dim>
std::vector<std::size_t> KdTree<Scalar, Dim>::within(const Scalar* query, double radius, bool sorted) const {
  std::vector<std::size_t> out;
  if (!index_ || !(radius >= 0)) return out;
  flann::Matrix<Scalar> q(const_cast<Scalar*>(query), 1, Dim);
  std::vector<std::vector<std::size_t>> found;
  std::vector<std::vector<Scalar>> dists;
  flann::SearchParams params(flann::FLANN_CHECKS_UNLIMITED);
  params.sorted = sorted;
  // A radius a little wider than asked in float, then the exact boundary below.
  const double r2 = radius * radius;
  index_->tree.radiusSearch(q, found, dists, static_cast<float>(r2 * (1 + 1e-6) + 1e-30), params);
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

template class KdTree<double, 2>;
template class KdTree<double, 3>;
template class KdTree<float, 3>;

}  // namespace mountcal::detail
