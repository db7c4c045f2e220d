#pragma once
/// \file detail/parallel.hpp
/// The one way mountcal spreads work over cores: `parallelFor(n, threads, f)` calls f(i) for
/// i in [0, n) on up to `threads` std::threads (0: every core) pulling indices from a shared
/// counter. Each f(i) writes only its own slot, and the caller combines the slots in index
/// order afterwards, so results never depend on the number of threads or on scheduling.

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <thread>
#include <vector>

namespace mountcal::detail {

/// Threads to use for `requested` (0: every core) and `n` items: at least 1, at most n.
inline unsigned threadCount(int requested, std::size_t n) {
  static const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  const unsigned want = requested > 0 ? static_cast<unsigned>(requested) : cores;
  return static_cast<unsigned>(std::max<std::size_t>(1, std::min<std::size_t>(want, n)));
}

/// f(i) for every i in [0, n), on threadCount(threads, n) threads (the calling thread is one of
/// them). The exception of the lowest index that threw is rethrown after every thread ended, so
/// that a failure is reported the same way whatever the number of threads.
template <typename F>
void parallelFor(std::size_t n, int threads, F&& f) {
  const unsigned T = threadCount(threads, n);
  if (T <= 1) {
    for (std::size_t i = 0; i < n; ++i) f(i);
    return;
  }
  std::atomic<std::size_t> next{0};
  std::vector<std::exception_ptr> errors(n);
  std::atomic<bool> failed{false};
  auto work = [&] {
    for (std::size_t i; !failed.load(std::memory_order_relaxed) && (i = next.fetch_add(1)) < n;) {
      try {
        f(i);
      } catch (...) {
        errors[i] = std::current_exception();
        failed = true;
      }
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(T - 1);
  for (unsigned t = 1; t < T; ++t) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  for (const std::exception_ptr& e : errors)
    if (e) std::rethrow_exception(e);
}

}  // namespace mountcal::detail
