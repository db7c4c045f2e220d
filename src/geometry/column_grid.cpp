#include "geometry/column_grid.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <utility>

namespace mountcal::detail {

namespace {

float keyDistance(std::uint64_t key) {
  const std::uint32_t bits = static_cast<std::uint32_t>(key >> 32);
  float d2;
  std::memcpy(&d2, &bits, sizeof d2);
  return d2;
}

}  // namespace

ColumnGrid::ColumnGrid(std::vector<float> coords, double per_column) : coords_(std::move(coords)) {
  coords_.resize(size() * 3);
  const std::size_t n = size();
  if (n == 0) return;
  ids_.resize(n);
  for (std::size_t i = 0; i < n; ++i) ids_[i] = static_cast<std::uint32_t>(i);
  x0_ = x1_ = coords_[0];
  y0_ = y1_ = coords_[1];
  for (std::size_t i = 0; i < n; ++i) {
    x0_ = std::min(x0_, static_cast<double>(coords_[3 * i]));
    x1_ = std::max(x1_, static_cast<double>(coords_[3 * i]));
    y0_ = std::min(y0_, static_cast<double>(coords_[3 * i + 1]));
    y1_ = std::max(y1_, static_cast<double>(coords_[3 * i + 1]));
  }
  // First from the bounding box's density, then once more from the occupied columns' (a strip
  // along a diagonal fills a fraction of its box).
  const double target = std::max(1.0, per_column);
  const double area = std::max((x1_ - x0_) * (y1_ - y0_), 1e-12);
  bin(std::max(std::sqrt(area * target / static_cast<double>(n)), 1e-6));
  std::size_t occupied = 0;
  for (std::size_t c = 0; c + 1 < start_.size(); ++c) occupied += start_[c + 1] > start_[c];
  const double mean = static_cast<double>(n) / static_cast<double>(std::max<std::size_t>(occupied, 1));
  if (mean > 2 * target || mean < 0.5 * target) bin(cell_ * std::sqrt(target / mean));
}

void ColumnGrid::bin(double cell) {
  const std::size_t n = size();
  // At most 4 columns a point (and 1024): a far outlier widens the columns, never the memory.
  const double limit = std::max(4.0 * static_cast<double>(n), 1024.0);
  cell_ = cell;
  for (;;) {
    const double nx = std::floor((x1_ - x0_) / cell_) + 1, ny = std::floor((y1_ - y0_) / cell_) + 1;
    if (nx * ny <= limit) {
      nx_ = static_cast<long>(nx);
      ny_ = static_cast<long>(ny);
      break;
    }
    cell_ *= 1.01 * std::sqrt(nx * ny / limit);
  }
  // A counting sort of the points by column.
  std::vector<std::uint32_t> column(n);
  start_.assign(static_cast<std::size_t>(nx_ * ny_) + 1, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const long cx = std::min(nx_ - 1, static_cast<long>(std::floor((coords_[3 * i] - x0_) / cell_)));
    const long cy = std::min(ny_ - 1, static_cast<long>(std::floor((coords_[3 * i + 1] - y0_) / cell_)));
    column[i] = static_cast<std::uint32_t>(cy * nx_ + cx);
    ++start_[column[i] + 1];
  }
  for (std::size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
  // The coordinates stored in column order (a column's points are read in one sweep), with
  // each one's index as given.
  std::vector<float> sorted(coords_.size());
  std::vector<std::uint32_t> ids(n), fill(start_.begin(), start_.end() - 1);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t j = fill[column[i]]++;
    std::copy_n(&coords_[3 * i], 3, &sorted[3 * static_cast<std::size_t>(j)]);
    ids[j] = ids_[i];
  }
  coords_.swap(sorted);
  ids_.swap(ids);
}

std::size_t ColumnGrid::nearest(const float* query, std::size_t k, double max_nearest, std::size_t* indices,
                                float* squared_distances) const {
  const std::size_t n = size();
  k = std::min(k, n);
  if (k == 0) return 0;
  const double max2 = max_nearest * max_nearest;
  const float qx = query[0], qy = query[1], qz = query[2];
  const long cx = static_cast<long>(std::floor((qx - x0_) / cell_)), cy = static_cast<long>(std::floor((qy - y0_) / cell_));
  // The k best so far as a max-heap of keys (squared distance, index): a non-negative float's
  // bits order as its value, so one 64-bit comparison orders both, ties by the smaller index.
  thread_local std::vector<std::uint64_t> heap;
  heap.clear();
  heap.reserve(k);
  float best = std::numeric_limits<float>::infinity();
  std::uint64_t worst = ~std::uint64_t{0};  // the heap's largest key once it is full
  auto scan = [&](long ix, long iy) {
    const std::size_t c = static_cast<std::size_t>(iy * nx_ + ix);
    for (std::uint32_t j = start_[c]; j < start_[c + 1]; ++j) {
      const std::uint32_t i = ids_[j];
      const float* p = &coords_[3 * static_cast<std::size_t>(j)];
      // As FLANN's L2_Simple: the squared differences summed in float, in coordinate order.
      float d2 = 0;
      const float dx = p[0] - qx, dy = p[1] - qy, dz = p[2] - qz;
      d2 += dx * dx;
      d2 += dy * dy;
      d2 += dz * dz;
      best = std::min(best, d2);
      std::uint32_t bits;
      std::memcpy(&bits, &d2, sizeof bits);
      const std::uint64_t key = (static_cast<std::uint64_t>(bits) << 32) | i;
      if (heap.size() < k) {
        heap.push_back(key);
        std::push_heap(heap.begin(), heap.end());
        if (heap.size() == k) worst = heap.front();
      } else if (key < worst) {
        std::pop_heap(heap.begin(), heap.end());
        heap.back() = key;
        std::push_heap(heap.begin(), heap.end());
        worst = heap.front();
      }
    }
  };
  // Rings of columns around the query's (Chebyshev radius r), from the first that meets the grid.
  const long r_first = std::max({0L, cx - (nx_ - 1), -cx, cy - (ny_ - 1), -cy});
  constexpr double kInf = std::numeric_limits<double>::infinity();
  for (long r = r_first;; ++r) {
    const long xa = cx - r, xb = cx + r, ya = cy - r, yb = cy + r;
    for (long iy = std::max(ya, 0L); iy <= std::min(yb, ny_ - 1); ++iy) {
      if (iy == ya || iy == yb) {
        for (long ix = std::max(xa, 0L); ix <= std::min(xb, nx_ - 1); ++ix) scan(ix, iy);
      } else {
        if (xa >= 0) scan(xa, iy);
        if (xb <= nx_ - 1 && xb != xa) scan(xb, iy);
      }
    }
    // Every point outside the block of columns searched lies beyond one of its sides that is
    // inside the grid: at least `lower` away in plan (less a margin for the column arithmetic,
    // and a relative one for float distances).
    double lower = kInf;
    if (xa > 0) lower = std::min(lower, qx - (x0_ + static_cast<double>(xa) * cell_));
    if (xb < nx_ - 1) lower = std::min(lower, x0_ + static_cast<double>(xb + 1) * cell_ - qx);
    if (ya > 0) lower = std::min(lower, qy - (y0_ + static_cast<double>(ya) * cell_));
    if (yb < ny_ - 1) lower = std::min(lower, y0_ + static_cast<double>(yb + 1) * cell_ - qy);
    if (lower == kInf) break;  // the whole grid searched
    lower = std::max(0.0, lower - 1e-9 * (1.0 + std::abs(static_cast<double>(qx)) + std::abs(static_cast<double>(qy))));
    const double bound = lower * lower * (1.0 - 1e-5);
    if (heap.size() == k && static_cast<double>(keyDistance(worst)) < bound) break;
    if (static_cast<double>(best) > max2 && bound > max2) return 0;  // nothing within max_nearest
  }
  if (static_cast<double>(best) > max2) return 0;
  std::sort_heap(heap.begin(), heap.end());
  for (std::size_t j = 0; j < k; ++j) {
    indices[j] = static_cast<std::uint32_t>(heap[j]);
    squared_distances[j] = keyDistance(heap[j]);
  }
  return k;
}

}  // namespace mountcal::detail
