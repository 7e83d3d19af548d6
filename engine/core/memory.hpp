#pragma once
/// Giving freed heap memory back to the system.
///
/// libsuperlu_dist, which HYPRE links, sets glibc's M_MMAP_MAX to 0 and M_TRIM_THRESHOLD to -1 in
/// its static initialisers: every block comes from the brk heap and glibc never trims it, so the
/// resident set never falls below the largest heap the run has reached, and memory a stage freed
/// is still counted while the next one runs. Restoring glibc's defaults (blocks over 128 KiB
/// mapped on their own, returned on free) gave that memory back but made the hot press of
/// configs/sps_nial.json 35-40 % slower on the reference machine: each neighbour rebuild's new
/// arrays were then fresh pages, faulted in again every ~30 steps. So the heap stays as the
/// libraries leave it, and release_free_memory() is called between stages and after a
/// contact-table rebuild, at most every 0.25 s (Simulation::update_neighbors: the old columns, the
/// candidate pairs and the look-up are freed there; release_free_memory_every), which is what
/// keeps the hot press's resident set near its heap in use (issue 63).
#include <chrono>
#ifdef __GLIBC__
#include <malloc.h>
#endif

namespace sparkdem {

/// Returns the heap's free pages to the system (glibc's malloc_trim; a no-op elsewhere).
inline void release_free_memory() {
#ifdef __GLIBC__
  malloc_trim(0);
#endif
}

/// release_free_memory() unless it ran less than `interval_s` of wall time ago (process-wide). A
/// trim gives back every free page of the heap, and the next rebuild faults the ones it reuses in
/// again: after every contact-table rebuild that cost the pour (1,233 rebuilds in 30,000 steps)
/// 5 % of its one-thread time and a quarter of its 2-thread neighbour pass (pour, 2 interleaved
/// rounds: 1 thread 14.38/14.24 s trimmed against 13.58/13.63 s not, neighbours 3.26/3.18 against
/// 2.59/2.60 s; 2 threads, neighbours 2.60/2.55 against 1.65/2.02 s). Rate-limited, a scene that
/// rebuilds every few milliseconds trims a few times a second and the hot press (a rebuild every
/// ~0.3 s) after nearly every rebuild. Only the resident set depends on it, never a result.
inline void release_free_memory_every(double interval_s) {
  static std::chrono::steady_clock::time_point last{};
  const auto now = std::chrono::steady_clock::now();
  if (last != std::chrono::steady_clock::time_point{} && std::chrono::duration<double>(now - last).count() < interval_s) return;
  release_free_memory();
  last = std::chrono::steady_clock::now();
}

}  // namespace sparkdem
