#pragma once
/// \file adjustment/block_arena.hpp
/// Storage for the adjustment's parameter blocks at increasing addresses, in the order the blocks
/// are created.
///
/// Why: Ceres keeps a Schur ordering (ceres::ParameterBlockOrdering) as a std::set<double*> per
/// group, so it eliminates the blocks of a group in the order of their addresses, and that order
/// sets the rounding of every sum of the solve and the covariance. Blocks from the general heap lie
/// wherever the process's earlier allocations left room: the same job then gave other last digits
/// in the Python module than in the command, or with another thread count. Here addresses follow
/// creation, so a calibration gives the same digits in every process.
///
/// One reservation of address space (kReserveBytes, pages committed only when first written); a
/// problem that outgrows it — or a system that refuses the reservation — gets further blocks from
/// the heap: the values are as correct, only their last digits may then depend on the process.

#include <sys/mman.h>

#include <cstddef>
#include <deque>
#include <vector>

namespace mountcal::detail {

class BlockArena {
 public:
  static constexpr std::size_t kReserveBytes = std::size_t{1} << 30;  // 134 M values

  BlockArena() {
    void* p = ::mmap(nullptr, kReserveBytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE, -1, 0);
    if (p != MAP_FAILED) {
      base_ = static_cast<double*>(p);
      capacity_ = kReserveBytes / sizeof(double);
    }
  }
  ~BlockArena() {
    if (base_) ::munmap(base_, kReserveBytes);
  }
  BlockArena(const BlockArena&) = delete;
  BlockArena& operator=(const BlockArena&) = delete;

  /// n values, copied from `initial`; valid until the arena is destroyed.
  double* allocate(std::size_t n, const double* initial) {
    double* p;
    if (base_ && used_ + n <= capacity_) {
      p = base_ + used_;
      used_ += n;
    } else {
      overflow_.emplace_back(n);
      p = overflow_.back().data();
    }
    for (std::size_t i = 0; i < n; ++i) p[i] = initial[i];
    return p;
  }

 private:
  double* base_ = nullptr;
  std::size_t used_ = 0, capacity_ = 0;
  std::deque<std::vector<double>> overflow_;
};

}  // namespace mountcal::detail
