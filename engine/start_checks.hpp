#pragma once
/// Checks made at the start of a stage, before step 0 (engine/simulation.cpp calls them; the
/// tests of tests/extreme/ push them to their limits).
///
/// 1. Initial overlaps. Every stage measures the largest overlap of its starting packing: pairs
///    (delta / min(r_i, r_j), delta = r_i + r_j - |x_i - x_j|) and particle-wall contacts
///    (delta / r_i). What happens then is the stage's `initial_overlap` policy:
///      allow   run as is (the default: a stage that continues another starts with the overlaps
///              of its contacts, and a sintered compact overlaps by design); the figures are
///              still reported (summary.json: initial_overlap);
///      refuse  a SetupError before step 0 if the largest ratio exceeds `initial_overlap_limit`,
///              naming the worst pair (ids) or wall and what to change;
///      relax   move the particles apart (positions only; velocities, masses and fixed
///              particles untouched) until the largest ratio is at most the limit, then run;
///              a SetupError if that takes more than `max_sweeps` sweeps.
///    Relaxation is a Jacobi projection: each sweep finds the overlapping pairs and wall
///    contacts (cell-grid search, exact) and moves each particle by half the sum of the
///    corrections its pairs ask for (each pair's overlap beyond the target shared equally, or
///    taken whole by the free partner of a fixed particle; a wall contact taken whole), so a
///    sweep never more than closes an overlap and cannot overshoot into a new one by more than
///    it removes. Relaxing to a target a little below the limit (0.5 x) makes it converge in
///    a few sweeps for isolated overlaps; dense jams need more.
/// 2. Pressure-controlled walls. A wall driven by a pressure servo needs something to push on:
///    with no particle on its inward side the servo drives it at its speed limit for ever (and
///    through the container). Refused before step 0 with the wall's name and what to change.
#include <cstddef>
#include <map>
#include <string>

#include "engine/core/types.hpp"
#include "engine/state/state.hpp"
#include "engine/walls/wall.hpp"

namespace sparkdem {

/// What the stage start found (and did) about overlaps.
struct InitialOverlapReport {
  double max_ratio = 0.0;            ///< largest delta / r_min over pairs and walls at the start
  std::size_t pairs_over_limit = 0;  ///< pairs above the limit at the start
  std::size_t walls_over_limit = 0;  ///< particle-wall contacts above the limit at the start
  Id worst_i = -1, worst_j = -1;     ///< ids of the worst pair (worst_j = -1: a wall contact)
  std::string worst_wall;            ///< name of the wall of the worst contact, if it is one
  std::string policy = "allow";
  double limit = 0.0;
  int sweeps = 0;                 ///< relax: sweeps made
  double max_ratio_after = 0.0;   ///< relax: largest ratio afterwards (= max_ratio otherwise)
  double max_displacement = 0.0;  ///< relax: largest distance a particle was moved [m]
  std::size_t moved = 0;          ///< relax: particles moved
};

/// Largest initial overlap ratio and the counts above `limit` (no change to the state).
InitialOverlapReport measure_initial_overlap(const State& s, double limit);

/// Apply a stage's policy ("allow", "refuse", "relax") with its limit. Throws SetupError for
/// "refuse" above the limit and for a relaxation that does not reach the limit in max_sweeps.
InitialOverlapReport apply_initial_overlap_policy(State& s, const std::string& stage, const std::string& policy, double limit,
                                                  int max_sweeps = 2000);

/// Throws SetupError if a wall with a pressure motion in `motions` has no particle centre on its
/// inward side (signed distance > -radius).
void check_pressure_walls(const State& s, const std::string& stage, const std::map<std::string, WallMotion>& motions);

}  // namespace sparkdem
