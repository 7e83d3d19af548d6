#pragma once
/// Threads only where they pay (issue 23 item 1). Every OpenMP loop of a time step opens a parallel
/// region, a fork and a join: about a microsecond while the workers spin between regions (the
/// default wait policy), tens of microseconds when they sleep (OMP_WAIT_POLICY=PASSIVE, the setting
/// for shared machines). Opened for every loop, they made a few-particle scene 1.5 (default) to 94
/// (PASSIVE) times slower on two threads than on one (benchmarks/threads/). Each loop therefore
/// carries `if (par::worth(n, par::kLight or par::kHeavy))`: it runs on the calling thread below
/// a minimum item count set by the work per item and by the wait policy, measured there.
/// Results never depend on it: the loops are element-wise, max-reductions or fixed-block sums
/// (tests/scenario/test_restart.cpp compares 1 and 2 threads with every loop forced parallel).
///
/// SPARKDEM_PARALLEL_MIN_ITEMS=N (environment, read once) replaces every minimum: 1 forces every
/// loop onto the team (tests), other values measure where threads start to pay (benchmarks).
#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <utility>

#ifdef _OPENMP
#include <omp.h>
#endif

namespace sparkdem::par {

enum Kind {
  kLight,  ///< a few flops per item (integration, zeroing, checks, the per-particle gather)
  kHeavy,  ///< a contact law, a bond, a neighbour-cell search or a graph row per item
};

/// Minimum items per kind [light, heavy] under each wait policy (benchmarks/threads/README.md):
/// spinning workers pay from a few hundred items, sleeping ones from thousands (rows) to tens of
/// thousands (light items).
inline constexpr std::int64_t kMinSpinning[2] = {256, 128};
inline constexpr std::int64_t kMinPassive[2] = {65536, 8192};

/// True when OMP_WAIT_POLICY asks for sleeping workers (case-insensitive "passive").
inline bool passive_wait_policy() {
  const char* e = std::getenv("OMP_WAIT_POLICY");
  if (!e) return false;
  std::string v(e);
  std::transform(v.begin(), v.end(), v.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return v == "passive";
}

/// The minimum item count of a loop of that kind (the environment override, else by wait policy).
inline std::int64_t min_items(Kind kind) {
  static const std::int64_t forced = [] {
    const char* e = std::getenv("SPARKDEM_PARALLEL_MIN_ITEMS");
    return e ? std::max<std::int64_t>(1, std::atoll(e)) : std::int64_t{0};
  }();
  static const bool passive = passive_wait_policy();
  if (forced > 0) return forced;
  return passive ? kMinPassive[kind] : kMinSpinning[kind];
}

/// Threads a parallel region would get here (1 without OpenMP).
inline int threads() {
#ifdef _OPENMP
  return omp_get_max_threads();
#else
  return 1;
#endif
}

/// This thread's number in its team, and the team's size (0 and 1 without OpenMP).
inline int thread_num() {
#ifdef _OPENMP
  return omp_get_thread_num();
#else
  return 0;
#endif
}
inline int team_size() {
#ifdef _OPENMP
  return omp_get_num_threads();
#else
  return 1;
#endif
}

/// True when a loop of n items of that kind is worth a parallel region.
inline bool worth(std::int64_t n, Kind kind) { return n >= min_items(kind); }

/// body() on a team of threads when `parallel` holds and there is more than one thread; else once
/// on the calling thread, outside any OpenMP region. A region of one thread (what a false `if`
/// clause or OMP_NUM_THREADS=1 opens) still builds a team and wakes its barrier through the
/// kernel (a futex call): 1.2-1.5 us a region on this machine against 0.01 us for the same loop
/// without it, most of the run time of a few-particle scene on one thread and a fifth of the test
/// suite's (benchmarks/threads/README.md, "Regions of one thread"). The body's loops are orphaned
/// worksharing constructs (`#pragma omp for`), which outside a region run on the calling thread;
/// a loop that ends the body takes `nowait` (the region's end is its barrier: one join, as the
/// combined `parallel for` had, not two).
/// Called by a thread already on a team (omp_in_parallel), the body gets a team of its own, as
/// `#pragma omp parallel if (parallel)` gives, so its loops never bind to the caller's team.
template <class Body>
inline void region(bool parallel, Body&& body) {
#ifdef _OPENMP
  if (omp_in_parallel() || (parallel && omp_get_max_threads() > 1)) {
#pragma omp parallel if (parallel)
    body();
    return;
  }
#endif
  body();
}

/// f(i) for i in [0, n), statically scheduled over a team when `parallel` holds (region).
template <class F>
inline void loop(bool parallel, std::int64_t n, F&& f) {
  region(parallel, [&] {
#pragma omp for schedule(static) nowait
    for (std::int64_t i = 0; i < n; ++i) f(i);
  });
}

/// f(i) for i in [0, n), on a team when worth(n, kind) (loop).
template <class F>
inline void for_each(std::int64_t n, Kind kind, F&& f) {
  loop(worth(n, kind), n, std::forward<F>(f));
}

/// An order-independent reduction over i in [0, n) (max, min, or: the merge must give the same
/// result in any order, so results do not depend on the thread count): each thread folds its
/// static share into its own copy of init with acc(T&, i), and the copies are merged into the
/// result with merge(T& out, const T& mine). (An OpenMP reduction clause cannot name a variable
/// captured by the body's lambda in clang: "reduction variable must be shared".)
template <class T, class Acc, class Merge>
inline T reduce(std::int64_t n, Kind kind, const T& init, Acc&& acc, Merge&& merge) {
  T out = init;
  region(worth(n, kind), [&] {
    T mine = init;
#pragma omp for schedule(static) nowait
    for (std::int64_t i = 0; i < n; ++i) acc(mine, i);
#pragma omp critical(sparkdem_par_reduce)
    merge(out, mine);
  });
  return out;
}

/// True when pred(i) holds for some i in [0, n) (reduce; a thread stops calling pred once it holds).
template <class Pred>
inline bool any_of(std::int64_t n, Kind kind, Pred&& pred) {
  return reduce(
      n, kind, false, [&](bool& m, std::int64_t i) { m = m || static_cast<bool>(pred(i)); },
      [](bool& out, bool m) { out = out || m; });
}

}  // namespace sparkdem::par
