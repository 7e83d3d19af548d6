#pragma once
/// The run watchdog: cheap checks of the state, every `check_every` steps of a stepping stage,
/// at its start (before step 0) and at its end, that stop a run going wrong with a PhysicsError
/// naming the step, the time, the particles, the quantity, its value, the bound it broke and what
/// to change. Simulation::run_stage calls it; io/scenario/pipeline.cpp keeps the last state that
/// passed it (Observer::healthy: in memory when small, else in the scratch file
/// OUTDIR/.healthy_state.h5) and writes it as OUTDIR/checkpoint_before_failure.h5 when the run fails.
///
/// Checks, in this order (the first that fails is reported; a frozen stage, mechanics off, runs
/// check 1 only, Simulation::run_stage: its geometry is given, e.g. an overlapping packing built
/// for a network test):
///  1. non-finite values: position, velocity, omega, force, torque of every particle, and every
///     per-particle field whose module declares it checked (FieldInfo::check): temperature and
///     joule_power must be finite, electric_potential must not be infinite (NaN marks a floating
///     particle). quantity() = the first non-finite one in the order: checked fields (by name),
///     force, torque, velocity, omega, position; the message lists all of them.
///  2. speed: |v_i| > max_speed, or with max_speed = 0 > r_i / dt (a particle moving more than its
///     radius in one step; the rule of the former check_finite). quantity() = "velocity", ids
///     fastest first.
///  3. overlap: overlap / min(r_i, r_j) of a particle pair above max_overlap_ratio (0: the contact
///     law's bound, ContactModel::overlap_ratio_bound(): 0.5 for elastic laws,
///     max(1, creep_overlap_limit) + 0.5 for sintering). Walls are not checked (cpc_fillers places
///     particles across the box faces on purpose). quantity() = "overlap", ids = the two
///     particles of each offending pair, worst first.
///  4. kinetic-energy growth (numerical instability): with e = sum(m v^2 + I w^2) / (2 sum m)
///     [J/kg] sampled at every check, the run stops when, over the last energy_window checks,
///     e started positive, never decreased from one check to the next, and grew by more than
///     energy_growth_factor, AND e exceeds the floor 0.5 (energy_floor_fraction x v_blow)^2,
///     v_blow = max_speed or min_i r_i / dt (an rms speed of that fraction of the blow-up
///     speed). The defaults (x1e4 over 5 checks = 50 steps, floor 1 % of r/dt) are the signature
///     of an unstable step: the energy of an unstable mode grows by |lambda|^2 per step, steadily.
///     Healthy runs do not match it: gravity from rest grows e as t^2 (x36 from step 10 to 60),
///     an impact or a relaxing overlap rises and falls within a contact time, a heated packing
///     pushing itself apart stays far below the floor. It catches a slowly growing instability
///     before any particle reaches the speed bound r/dt (check 2); a fast one reaches both within
///     a check and check 2 reports it. The samples are kept in the state's marks during the stage
///     and dropped at its end; they are kept out of every file (io/scenario/pipeline.cpp), so
///     state files are those of a run without the watchdog, and a restart samples afresh from its
///     first check step: it reproduces an energy failure at the same step when the checkpoint is
///     at least energy_window checks before it (checkpoint_before_failure.h5 usually is). quantity() =
///     "kinetic energy", ids = the 10 particles of largest kinetic energy; value = the growth
///     factor over the window, bound = energy_growth_factor.
#include <string>

#include "engine/core/types.hpp"
#include "engine/state/state.hpp"

namespace sparkdem {

struct WatchdogConfig {
  Step check_every = 10;                ///< steps between checks (>= 1)
  double max_overlap_ratio = 0.0;       ///< [1] overlap / smaller radius; 0 = the contact law's bound
  double max_speed = 0.0;               ///< [m/s] 0 = per particle radius / dt
  double energy_growth_factor = 1e4;    ///< [1] 0 = no energy check
  Step energy_window = 5;               ///< checks over which the growth is measured (>= 1)
  double energy_floor_fraction = 0.01;  ///< [1] rms-speed floor as a fraction of the blow-up speed
  /// Checks between copies of the last healthy state (also taken at the start of a stage
  /// with steps to run);
  /// 0 = no copies (a failure then leaves no checkpoint_before_failure.h5).
  Step snapshot_every_checks = 100;
  /// [B] A copy that a checkpoint would store in at most this many bytes is kept in memory; a
  /// larger one is written to the scratch file OUTDIR/.healthy_state.h5 (io/scenario/pipeline.cpp).
  std::int64_t snapshot_memory_max_bytes = std::int64_t{1} << 20;
};

/// What the watchdog needs to know about the running stage.
struct WatchdogContext {
  double dt = 0.0;                 ///< [s] mechanical step of the stage
  double stable_dt = 0.0;          ///< [s] the contact law's stable step at the stage start (inf: none)
  bool allow_unstable_dt = false;  ///< the stage runs above its stable step on purpose
  double law_overlap_bound = 0.5;  ///< the contact law's overlap bound (used when max_overlap_ratio == 0)
  std::string stage;               ///< stage name (for the message)
};

/// Runs checks 1-3 and, with `energy`, records the kinetic-energy sample and runs check 4.
/// Throws PhysicsError (with PhysicsErrorDetail: time, value, bound, hint) on the first failure.
void watchdog_check(State& s, const WatchdogConfig& c, const WatchdogContext& ctx, bool energy);

/// Forgets the kinetic-energy samples (stage start and end).
void watchdog_reset(State& s);

}  // namespace sparkdem
