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
/// libraries leave it, and release_free_memory() is called between stages and after every
/// contact-table rebuild (Simulation::update_neighbors: the old columns, the candidate pairs and
/// the look-up are freed there), which is what keeps the hot press's resident set near its heap
/// in use (issue 63).
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

}  // namespace sparkdem
