#pragma once
// Internal (not installed): asks Linux to back a large, freshly reserved array with transparent
// huge pages. The simulator returns some 100 bytes per pulse (400 MB for a 3.5 M-pulse strip);
// on 4 KiB pages about a fifth of its time went to the kernel faulting those pages in one by
// one (issue 13's profile). Advice only: where the kernel has no huge pages, or says no, nothing
// changes — not the contents, only how the memory is mapped.

#include <cstddef>
#include <cstdint>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace mountcal::detail {

/// Advises huge pages for the whole 2 MiB pages inside [p, p + bytes); arrays under 8 MiB are
/// left alone.
inline void adviseHugePages(const void* p, std::size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  constexpr std::uintptr_t kHuge = std::uintptr_t{2} << 20;
  if (p == nullptr || bytes < 4 * kHuge) return;
  const std::uintptr_t begin = (reinterpret_cast<std::uintptr_t>(p) + kHuge - 1) & ~(kHuge - 1);
  const std::uintptr_t end = (reinterpret_cast<std::uintptr_t>(p) + bytes) & ~(kHuge - 1);
  if (end > begin) (void)::madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
#else
  (void)p;
  (void)bytes;
#endif
}

template <class Vector>
void adviseHugePages(const Vector& v) {
  adviseHugePages(v.data(), v.capacity() * sizeof(typename Vector::value_type));
}

}  // namespace mountcal::detail
