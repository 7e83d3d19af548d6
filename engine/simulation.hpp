#pragma once
/// Simulation: owns nothing physics-specific. It holds the State, the active contact model,
/// the active modules and monitors of a stage, builds the step plan once and executes it.
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <memory>
#include <string>
#include <vector>

#include "engine/contact/bond_model.hpp"
#include "engine/core/hash.hpp"
#include "engine/contact/contact_model.hpp"
#include "engine/integrate/quasi_static.hpp"
#include "engine/model/module.hpp"
#include "engine/schedule/scheduler.hpp"
#include "engine/start_checks.hpp"
#include "engine/state/state.hpp"
#include "engine/watchdog.hpp"

namespace sparkdem {

/// A named scalar (or several) computed from the state: time-series columns and stop criteria.
/// A wall a monitor reads: the parameter that names it, the name, and the shape it must have.
struct WallUse {
  std::string key;    ///< parameter of the monitor naming the wall (e.g. "die")
  std::string name;   ///< wall name
  bool plane = true;  ///< true: a plane wall is expected, false: a cylinder
};

class Monitor {
 public:
  virtual ~Monitor() = default;
  /// Column names, fixed for the stage.
  virtual std::vector<std::string> columns(const State& s) const = 0;
  virtual std::vector<double> values(const State& s) const = 0;
  /// Walls the monitor reads, checked by the loader against the stage's walls. Default: none.
  virtual std::vector<WallUse> wall_uses() const { return {}; }
};

struct StopCondition {
  std::string quantity;  ///< a monitor column
  bool at_least = true;  ///< true: quantity >= value; false: quantity <= value
  double value = 0.0;
};

/// Rigid motion of a prescribed particle set during a stage (LAMMPS `fix move rotate` + `linear`):
/// the set translates at `velocity` and turns at `angular_velocity` about the point `center`
/// (which moves with the set). Members are moved, not integrated; each step turns them by the
/// exact rotation of angle |w| dt, so the radius about the axis does not drift.
struct PrescribedMotion {
  Vec3 velocity = Vec3::Zero();          ///< [m/s] (zero with no rotation = clamped)
  Vec3 angular_velocity = Vec3::Zero();  ///< [rad/s]
  Vec3 center = Vec3::Zero();            ///< [m] at the stage start: rotation centre and torque reference
  PrescribedMotion() = default;
  PrescribedMotion(const Vec3& v) : velocity(v) {}  // NOLINT(google-explicit-constructor): a velocity alone
  bool rotates() const { return angular_velocity.squaredNorm() > 0.0; }
};

/// Time-series columns of a prescribed set (count, force, torque about its centre, turned angle).
std::vector<std::string> prescribed_set_columns(const std::string& name);

/// An adaptive step (stage key "dt": {"adaptive": F, ...}): every check_every steps the step
/// becomes F x the stable step of the current state (the contact law's and that of every
/// fixed-clock module, as a mechanical step), bounded by [min, max], growing by at most `growth`
/// per check and shrinking at once; a step before a stop time, a frame_every_s time or a wall
/// table's breakpoint is shortened to land on it.
struct AdaptiveDt {
  double fraction = 0.0;  ///< F (0 < F <= 1); 0: a fixed step
  double min = 0.0;       ///< [s] below this the run stops (the state needs a smaller step)
  double max = std::numeric_limits<double>::infinity();  ///< [s]
  Step check_every = 50;  ///< steps between estimates of the stable step
  double growth = 1.1;    ///< largest factor of growth per check
  bool on() const { return fraction > 0.0; }
};

struct StageConfig {
  std::string name = "stage";
  double dt = 0.0;           ///< [s] fixed step; 0 = dt_fraction * stable step at stage start
  double dt_fraction = 0.0;  ///< fraction of the stable step (used when dt == 0)
  AdaptiveDt adaptive;       ///< on: the step follows the state (dt and dt_fraction unused)
  /// false: frozen stage, no mechanical step (scheduler.hpp); dt is then `dt`, or dt_fraction x
  /// the smallest stable step of the modules (in mechanical time).
  bool mechanics = true;
  bool allow_unstable_dt = false;                             ///< run above the stable step (blow-ups are still caught)
  double duration = std::numeric_limits<double>::infinity();  ///< [s] hard stop
  Step max_steps = std::numeric_limits<Step>::max();          ///< hard stop
  std::vector<StopCondition> until;                           ///< stop early when all hold (checked every check_every)
  Step check_every = 100;
  bool require_until = false;  ///< a hard stop before `until` holds is an error
  double skin = 0.0;           ///< [m] Verlet skin; 0 = 0.3 * smallest radius
  double mass_scaling = 1.0;   ///< multiplies masses and inertias during the stage (reported)
  /// > 0: during the stage a particle smaller than this radius [m] also takes the mass of a
  /// sphere of this radius and its own density (inertia likewise): density scaling of the fines,
  /// whose stable step limits dt (quasi-static stages only; reported).
  double mass_floor_radius = 0.0;
  double time_scale = 1.0;  ///< physical seconds per mechanical second (TimeDomain::Physical modules)
  Step stability_check_every = 1000;
  double blowup_speed = 0.0;      ///< [m/s] a speed above this is a blow-up; 0 = radius/dt rule (= watchdog.max_speed when that is 0)
  WatchdogConfig watchdog;        ///< the run watchdog's checks (engine/watchdog.hpp)
  Step sort_every_rebuilds = 50;  ///< spatial sort of the particles for cache locality
  Step frame_every = 0;           ///< 0 = only the final frame
  Step timeseries_every = 100;
  Step checkpoint_every = 0;
  double frame_every_s = 0.0;  ///< [s] of stage time between frames (0: off); adaptive steps land on them
  double checkpoint_every_s = 0.0;  ///< wall-clock seconds between checkpoints (0: none; the I/O layer keeps the clock)
  /// Pair sets drawn as lines in the frames' XDMF: "auto", "none", "contacts", "bonds", "both"
  /// (io/scenario/stage_facets.cpp documents them).
  std::string network_output = "auto";
  Step log_every = 0;                         ///< progress callback cadence; 0 = auto
  std::map<std::string, WallMotion> motions;  ///< motions of named walls during this stage
  /// Particle sets (field "set/<name>") moved rigidly during the stage (PrescribedMotion; zero =
  /// clamped); their total force and torque about their centre are in the time series
  /// (prescribed_set_columns).
  std::map<std::string, PrescribedMotion> prescribed_sets;
  /// What to do with overlaps above initial_overlap_limit (delta / smaller radius) in the packing
  /// the stage starts from: "allow", "refuse" or "relax" (engine/start_checks.hpp). Always reported.
  std::string initial_overlap = "allow";
  double initial_overlap_limit = 0.01;
  /// The inertia-free path (engine/integrate/quasi_static.hpp): each step solves the contacts for
  /// the velocities that balance every particle; dt is then given (the step of the modules and the
  /// output; max_strain_increment splits it), masses and time are not scaled, pressure walls are
  /// force-controlled unknowns. Needs a law with linear_contact (sintering).
  bool quasi_static = false;
  QuasiStaticConfig quasi;
};

/// A module's step at the stage start: its own stable step and the step it runs with (both in
/// its time domain) and its calls per mechanical step (k substeps, 1/N for every N steps, 0 for
/// an event clock).
struct ModuleStep {
  std::string name;
  double stable_dt = 0.0;
  double dt = 0.0;
  double calls_per_step = 1.0;
  std::string clock;
};

struct StageResult;

/// Callbacks to the I/O layer (the engine never writes files itself).
class Observer {
 public:
  virtual ~Observer() = default;
  virtual void frame(const State&) {}
  virtual void timeseries(const std::vector<std::string>& cols, const std::vector<double>& vals) {
    (void)cols;
    (void)vals;
  }
  virtual void checkpoint(State&) {}
  /// Polled after every step whose state a checkpoint may hold: true when a wall-clock
  /// checkpoint is due (StageConfig::checkpoint_every_s).
  virtual bool checkpoint_due() { return false; }
  virtual void progress(const State&, Step stage_steps, double stage_time, double dt) {
    (void)stage_steps;
    (void)stage_time;
    (void)dt;
  }
  /// An event worth a line in the run log (e.g. an adaptive step's change and why).
  virtual void event(const std::string& text) { (void)text; }
  /// At the stage start (also on resume): the mechanical step and each module's step.
  virtual void steps_planned(double dt_mechanical, double stable_mechanical, const std::vector<ModuleStep>& modules) {
    (void)dt_mechanical;
    (void)stable_mechanical;
    (void)modules;
  }
  /// At the stage start, after steps_planned (also on resume): the result so far, whose start
  /// figures (initial overlaps, stable step at the start, module steps) a resumed stage cannot
  /// measure again, so the I/O layer keeps them with its restart points.
  virtual void stage_started(const StageResult& so_far) { (void)so_far; }
  /// The state passed the run watchdog (engine/watchdog.hpp): at the stage start (before step 0,
  /// also on resume) and every watchdog.snapshot_every_checks checks, at the point of the step
  /// where checkpoints are taken. The I/O layer keeps a copy, written as a checkpoint if the run
  /// later fails; the state must not be modified (non-const only to be written through an Archive).
  virtual void healthy(State&) {}
  /// Stage steps between extra watch() calls (0: none beyond the time-series rows).
  virtual Step watch_every() const { return 0; }
  /// The monitor values together with the state they were sampled from: at the stage start
  /// (not on resume), at every time-series row, every watch_every() stage steps (inside the
  /// step loop, before that step's frame and checkpoint) and at the stage end. Lets the I/O
  /// layer act on a column (e.g. save a snapshot when it crosses a value); the state must not be
  /// modified (non-const only so that it can be written through an Archive).
  virtual void watch(State&, const std::vector<std::string>& cols, const std::vector<double>& vals) {
    (void)cols;
    (void)vals;
  }
};

/// One step in kSplitEvery has its core plan items timed (StageResult::core_seconds): the steps
/// whose mixed step number (split_timed) is 0 modulo kSplitEvery. Not every kSplitEvery-th step:
/// a Verlet list rebuilt every 32 steps would then fall on half the timed steps and the
/// neighbour item's share come out about 16 times too large.
inline constexpr Step kSplitEvery = 16;
/// Whether step k is one of the timed steps (a fixed hash of k: the same steps on a restart).
inline bool split_timed(Step k) { return mix64(static_cast<std::uint64_t>(k)) % static_cast<std::uint64_t>(kSplitEvery) == 0; }

struct StageResult {
  std::string name;
  Step steps = 0;      ///< the stage's steps (on resume: those before the checkpoint included)
  Step steps_run = 0;  ///< steps this call made (the rates count these)
  double simulated_time = 0.0;
  double wall_seconds = 0.0;
  double dt = 0.0;
  double stable_dt_at_start = 0.0;
  double dt_fraction_used = 0.0;
  /// Adaptive stages: the step's smallest, median (over steps) and largest value [s], its
  /// changes, and the checks that found the step in use above the state's stable step (the
  /// state stiffened past it between two checks).
  struct AdaptiveStats {
    double min = 0.0, median = 0.0, max = 0.0;
    Step changes = 0, overshoots = 0;
    double check_seconds = 0.0;  ///< wall time of this run's checks (the stable-step estimates) [s]
    Step checks = 0;             ///< checks made by this run
  };
  std::optional<AdaptiveStats> adaptive;
  bool until_reached = true;
  std::size_t particles = 0;
  double particle_steps_per_second = 0.0;
  double physical_time = 0.0;  ///< [s] physical time simulated in the stage (time_scale * mechanical)
  std::vector<std::string> plan;
  std::map<std::string, double> final_values;    ///< last monitor values
  std::map<std::string, Step> module_calls;      ///< calls per module in this stage (substeps counted)
  std::map<std::string, Step> max_substeps;      ///< largest per-step substep count (adaptive clocks)
  std::map<std::string, double> module_seconds;  ///< wall time inside each module's calls [s] (the rest is mechanics and I/O)
  /// Wall time of each core item of the step plan [s] (integration halves, walls, neighbours,
  /// zeroing, contact pairs, bonds, wall contacts), estimated from one step in kSplitEvery
  /// (split_timed) scaled by the steps taken: two clock reads per item on every step would cost a
  /// few-particle scene several per cent. Modules are in module_seconds (every call timed).
  std::map<std::string, double> core_seconds;
  Step core_sampled_steps = 0;           ///< steps whose core items were timed
  std::int64_t neighbor_rebuilds = 0;    ///< Verlet-list rebuilds in this run of the stage
  std::vector<ModuleStep> module_steps;  ///< per module at the stage start
  InitialOverlapReport initial_overlap;  ///< overlaps of the starting packing (not measured on resume)
  /// Quasi-static stages: counts of the inertia-free solves (summary.json "quasi_static").
  struct QuasiStaticStats {
    Step substeps = 0;              ///< accepted substeps
    Step rejected = 0;              ///< solves redone at a smaller substep (max_strain_increment)
    Step max_substeps = 0;          ///< largest number of substeps in one step
    Step rounds = 0;                ///< linear solves (nonlinear rounds included)
    Step max_rounds = 0;            ///< largest rounds of one solve
    Step unsettled = 0;             ///< solves whose nonlinear rounds did not settle (friction_iterations)
    std::int64_t cg_iterations = 0; ///< summed
    std::int64_t factorisations = 0; ///< summed (LDL^T or incomplete Cholesky)
    double max_strain_increment = 0.0;
    double max_mean_strain_increment = 0.0;  ///< largest mean flow / r_min of an accepted substep
    double max_residual = 0.0;      ///< largest |net force| of a particle / mean |contact force|, after a step
    double last_residual = 0.0;     ///< the same after the last step
    double solve_seconds = 0.0;     ///< wall time of the rows and solves [s]
  } quasi_static;
};

class Simulation {
 public:
  /// `bonds` is the bond law of the scenario, or null when it has none (no bond pass is planned).
  Simulation(State& state, const ContactModel& law, const BondModel* bonds = nullptr) : s_(state), law_(law), bond_law_(bonds) {}
  void add_module(Module* m) { modules_.push_back(m); }
  void add_monitor(const Monitor* m) { monitors_.push_back(m); }

  /// Allocate declared fields, bind modules, build the plan (no stepping).
  StepPlan prepare(const StageConfig& cfg);
  /// Run a stage to its stop condition. If `resume` is true the state comes from a checkpoint
  /// taken inside this stage: the set-up force evaluation is skipped so the continuation is exact.
  StageResult run_stage(const StageConfig& cfg, Observer& obs, bool resume = false);

  /// Mechanical stable step of the current state [s] (contact law), and of each module.
  double mechanical_stable_dt() const;
  std::map<std::string, double> module_stable_dts() const;
  /// The step a stage would use [s].
  double resolve_dt(const StageConfig& cfg) const;

  /// Current monitor columns and values (built-in ones first).
  void sample(std::vector<std::string>& cols, std::vector<double>& vals) const;

  const StepPlan& plan() const { return plan_; }

 private:
  void compute_forces(double dt, double t_stage);
  /// Every wall to stage time t_stage (motions, servos), each adding its step's work (Wall::work).
  void advance_walls(double t_stage, double dt, double t_area);
  void zero_forces();
  void pair_forces(double dt);  ///< pair pass + per-particle gather (m* = 0 in a quasi-static stage)
  /// Bond pass + gather; bonds that break are marked at `step` (the step being computed) and
  /// hand their state to the contact table.
  void bond_forces(double dt, Step step);
  void wall_forces(double dt);  ///< wall pass; stores the wall loads (m* = 0 in a quasi-static stage)
  void update_neighbors(double skin, Step sort_every);
  /// Run one plan item of kind Module at the end of mechanical step `step` (global index of the
  /// step being completed), `t_stage` = stage time at its end, on the item's clock.
  void run_module(const PlanItem& it, Step step, double t_stage, double dt_m);
  bool event_due(const PlanItem& it, Step step) const;
  void mark_event_run(const PlanItem& it, Step step);
  // The named steps of run_stage.
  void bind_walls_and_sets(const StageConfig& cfg, bool resume);
  void begin_stage(const StageConfig& cfg);
  void choose_skin(const StageConfig& cfg, bool resume);
  void check_resumed_clocks(const StageConfig& cfg) const;
  std::vector<ModuleStep> module_steps(double dt_used) const;
  void execute_plan(const StageConfig& cfg, double dt_used, double t_new, double t_area);
  WatchdogConfig stage_watchdog(const StageConfig& cfg) const;
  /// What the watchdog needs of the stage: its step, the stable step at its start, its name.
  WatchdogContext watchdog_context(const StageConfig& cfg, double dt, double stable_dt) const;
  /// Module::release_caches of every module of the plan (the stage's steps are over).
  void release_module_caches();
  void evaluate_start(double dt_used, double t_area, StageResult& res);
  void check_module_steps(const StageConfig& cfg, double dt_used, bool at_start) const;
  double choose_step(const StageConfig& cfg, bool resume, StageResult& res);
  /// Adaptive stages: F x the stable step of the current state (`contact_stable`, the contact
  /// law's, and the fixed-clock modules'), within [min, max] and at most growth x `previous` (+inf: no bound). A stable step
  /// that needs less than min is a PhysicsError.
  double adaptive_step(const StageConfig& cfg, double previous, double contact_stable) const;
  /// The contact law's stable step of the state (+inf without explicit mechanics).
  double contact_stable_dt(const StageConfig& cfg) const;
  /// Adaptive stages: the first stage time [s] after `elapsed` a step must land on (the stop time,
  /// the next frame_every_s time, the next breakpoint of a wall's table), +inf when none.
  double next_landing(const StageConfig& cfg, double elapsed) const;
  /// Adaptive stages, every check_every steps: the next step from the state; logs a change.
  void adapt_step(const StageConfig& cfg, Observer& obs);
  /// One step of the stage loop: the stage time before it, its length and the stage time after it
  /// [s] (fixed: k dt and (k + 1) dt; adaptive: the current step, shortened to land on next_landing).
  struct StepSpan {
    double t_old, dt, t_new;
  };
  StepSpan step_span(const StageConfig& cfg, Step k, double dt_used) const;
  /// After stage step kk: the adaptive check (every dt.check_every steps, timed into res), or the
  /// fixed step against the state's stable steps (every stability_check_every, a PhysicsError above them).
  void check_step(const StageConfig& cfg, Step kk, double dt_used, Observer& obs, StageResult& res);
  /// Adaptive stages: the stage's step statistics from State::dt_history, into res.
  void adaptive_stats(StageResult& res) const;
  double last_call_time(const PlanItem& it, double t_start) const;
  void halt_walls(std::vector<std::string>& cols, std::vector<double>& vals);
  void end_stage(const std::vector<std::string>& cols, const std::vector<double>& vals, StageResult& res);
  State& s_;
  const ContactModel& law_;
  const BondModel* bond_law_ = nullptr;
  StageResult* stats_ = nullptr;  ///< counters of the running stage
  std::vector<Module*> modules_;
  std::vector<const Monitor*> monitors_;
  StepPlan plan_;
  double skin_ = 0.0;
  double time_scale_ = 1.0;
  bool inertia_free_ = false;  ///< the running stage is quasi-static
  bool adaptive_ = false;      ///< the running stage has an adaptive step (AdaptiveDt)
  double logged_dt_ = 0.0;     ///< adaptive: the step the run log last reported [s]
  std::function<bool(const double*)> alive_rule_;  ///< persistent pairs of the contact law
  std::map<std::string, PrescribedMotion> prescribed_;
  /// Turn the members of rotating prescribed sets by their step rotation (after the drift).
  void rotate_prescribed(double dt, double t_stage_new);
  // The inertia-free path (StageConfig::quasi_static; order in engine/schedule/scheduler.hpp).
  void check_quasi_static(const StageConfig& cfg) const;
  void quasi_static_step(const StageConfig& cfg, double dt, double t_new, double t_area);
  QuasiStaticProblem quasi_static_problem(double t_end, double h, double t_area) const;
  void commit_quasi_static(const QuasiStaticSolution& sol, const QuasiStaticProblem& prob, double t_end, double t_area);
  double force_residual() const;
  [[noreturn]] void throw_increment_error(const QuasiStaticProblem& prob, const QuasiStaticSolution& sol, const QuasiStaticConfig& q,
                                          double hs) const;
};

/// Built-in monitors available in every stage.
std::vector<std::string> builtin_columns(const State& s);
/// Values of builtin_columns; with `bonds` (the scenario's bond law) also the bonds' elastic energy
/// and largest failure stress (NaN without it).
std::vector<double> builtin_values(const State& s, const BondModel* bonds = nullptr);

}  // namespace sparkdem
