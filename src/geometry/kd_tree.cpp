#include "geometry/kd_tree.hpp"

#include <flann/algorithms/dist.h>
#include <flann/algorithms/kdtree_single_index.h>
#include <flann/util/result_set.h>

#include <algorithm>
#include <utility>

namespace mountcal::detail {

namespace {

/// FLANN's k-nearest result set, one per thread and k (the caller clears it per search): FLANN's own
/// search loop constructs one (an allocation) per call, which the sparse matching makes millions
/// of times (a share of the sanitizer suite's time in the allocator, 2026-11-28).
template <typename D>
flann::KNNSimpleResultSet<D>& knnResults(std::size_t k) {
  thread_local std::unique_ptr<flann::KNNSimpleResultSet<D>> set;
  thread_local std::size_t capacity = 0;
  if (!set || capacity != k) {
    set = std::make_unique<flann::KNNSimpleResultSet<D>>(k);
    capacity = k;
  }
  return *set;
}

/// Every point closer than a radius (squared, as FLANN measures), unsorted, into a buffer the
/// caller keeps.
template <typename D>
class WithinResults final : public flann::ResultSet<D> {
 public:
  WithinResults(D radius2, std::vector<std::pair<D, std::size_t>>* out) : radius2_(radius2), out_(out) {}
  bool full() const override { return true; }
  void addPoint(D dist, std::size_t index) override {
    if (dist < radius2_) out_->emplace_back(dist, index);
  }
  D worstDist() const override { return radius2_; }

 private:
  D radius2_;
  std::vector<std::pair<D, std::size_t>>* out_;
};

}  // namespace

template <typename Scalar, int Dim>
struct KdTree<Scalar, Dim>::Index {
  flann::KDTreeSingleIndex<flann::L2_Simple<Scalar>> tree;
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
  const flann::SearchParams params(flann::FLANN_CHECKS_UNLIMITED);
  flann::KNNSimpleResultSet<Scalar>& found = knnResults<Scalar>(k);
  for (std::size_t q = 0; q < count; ++q) {
    found.clear();
    index_->tree.findNeighbors(found, queries + Dim * q, params);
    found.copy(indices + k * q, squared_distances + k * q, std::min(found.size(), k), /*sorted=*/true);
  }
  return k;
}

template <typename Scalar, int Dim>
void KdTree<Scalar, Dim>::within(const Scalar* query, double radius, bool sorted, std::vector<std::size_t>* out) const {
  out->clear();
  if (!index_ || !(radius >= 0)) return;
  // A radius a little wider than asked in float, then the exact boundary below.
  const double r2 = radius * radius;
  thread_local std::vector<std::pair<Scalar, std::size_t>> found;
  found.clear();
  WithinResults<Scalar> collect(static_cast<Scalar>(r2 * (1 + 1e-6) + 1e-30), &found);
  index_->tree.findNeighbors(collect, query, flann::SearchParams(flann::FLANN_CHECKS_UNLIMITED));
  if (sorted) std::sort(found.begin(), found.end());
  for (const auto& f : found) {
    double d2 = 0;
    for (int c = 0; c < Dim; ++c) {
      const double d = static_cast<double>(coord(f.second, c)) - static_cast<double>(query[c]);
      d2 += d * d;
    }
    if (d2 <= r2) out->push_back(f.second);
  }
}

template <typename Scalar, int Dim>
std::vector<std::size_t> KdTree<Scalar, Dim>::within(const Scalar* query, double radius, bool sorted) const {
  std::vector<std::size_t> out;
  within(query, radius, sorted, &out);
  return out;
}

template class KdTree<double, 2>;
template class KdTree<double, 3>;
template class KdTree<float, 3>;

}  // namespace mountcal::detail
