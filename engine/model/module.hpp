#pragma once
/// Module contract: what every physics module implements. A module declares the fields it
/// reads and writes, its clock relative to the mechanical step and its own stable step; the
/// scheduler builds the step plan once from these declarations.
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "engine/core/archive.hpp"
#include "engine/core/types.hpp"
#include "engine/state/field_registry.hpp"

namespace sparkdem {

struct State;

/// Conditions of an event clock, checked at the end of every mechanical step; the module runs
/// when any of them holds. References ("since the module last ran") are kept by the simulation
/// in particle fields "trigger/<module>/..." and in State::marks, so they are checkpointed.
struct Trigger {
  double moved_beyond = std::numeric_limits<double>::infinity();  ///< [m] a particle moved more than this
  std::string field;                                              ///< particle field watched ...
  double field_change = std::numeric_limits<double>::infinity();  ///< ... for a change above this [field unit]
  bool bond_broke = false;                                        ///< a bond broke
  std::int64_t max_interval = 0;                                  ///< also after this many steps (0 = never)
};

/// When a module runs, relative to the mechanical step dt_m.
///   EveryStep         once per step, dt = dt_m
///   EveryNSteps       at steps N, 2N, ... (global step count), dt = N dt_m (zero-order hold between)
///   SubstepsPerStep   k = n calls per step, dt = dt_m / k
///   AdaptiveSubsteps  k = max(n, ceil(dt_m / stable_dt)) calls per step, k recomputed every step
///                     from the module's current stable step (honours a shrinking stable step)
///   OnEvent           once on the initial state of a stage (dt = 0; a stage of zero steps is
///                     an evaluation), then at the end of every step where the trigger fires;
///                     dt = time since the module last ran
struct Clock {
  enum class Kind { EveryStep, EveryNSteps, SubstepsPerStep, AdaptiveSubsteps, OnEvent };
  Kind kind = Kind::EveryStep;
  std::int64_t n = 1;  ///< N mechanical steps per call, or (minimum) substeps per mechanical step
  Trigger trigger;     ///< OnEvent only
  /// Nominal step of one call [s] (AdaptiveSubsteps: the largest; OnEvent: one mechanical step).
  double dt(double dt_m) const {
    switch (kind) {
      case Kind::EveryNSteps:
        return static_cast<double>(n) * dt_m;
      case Kind::SubstepsPerStep:
      case Kind::AdaptiveSubsteps:
        return dt_m / static_cast<double>(n);
      default:
        return dt_m;
    }
  }
};

/// Which clock a module's dt and time are in. With time scaling (StageConfig::time_scale =
/// physical seconds per mechanical second, e.g. to compress a sintering cycle), Mechanical
/// modules see dt_m and the mechanical time; Physical modules see time_scale * dt_m and the
/// physical time. Mass scaling changes neither clock.
enum class TimeDomain { Mechanical, Physical };

/// Where in the step a module runs. Force modules add to force/torque between the contact
/// pass and the second half-kick; Coupling modules run after the mechanical step, in the
/// order derived from their reads/writes.
enum class Phase { Force, Coupling };

struct StepInfo {
  Step step;                 ///< global step index of the step being completed
  double time;               ///< time at the end of the call in the module's domain [s] (step * dt, never accumulated)
  double dt;                 ///< step of this call in the module's domain [s]
  std::int64_t substep = 0;  ///< 0-based substep within the mechanical step
};

/// Per-edge results a module publishes for the frames (e.g. branch currents): pairs of global
/// ids (a wall node is -1 - wall index) and fields with one value per pair.
struct EdgeField {
  std::string name;
  std::string unit;
  std::vector<double> values;
};
struct EdgeOutput {
  std::string name;                 ///< group name in the frame (/networks/<name>)
  std::vector<std::int64_t> pairs;  ///< 2 ids per edge
  std::vector<EdgeField> fields;
};

/// A module's one held edge output as Module::edge_outputs() returns it: none while `held` has no
/// name, else one copy (`std::vector<EdgeOutput>{held}` would copy it twice: an initializer list
/// cannot be moved from).
inline std::vector<EdgeOutput> held_edge_output(const EdgeOutput& held) {
  std::vector<EdgeOutput> out;
  if (!held.name.empty()) out.push_back(held);
  return out;
}

/// What a module needs and provides. Declaring is what makes allocation, output, restart and
/// ordering automatic.
struct Declarations {
  std::vector<FieldInfo> particle_fields;  ///< optional per-particle fields to allocate
  std::vector<std::string> reads;          ///< fields read (must be written by someone or core)
  /// Fields read as they were at the end of the previous step: they must exist like `reads`, but
  /// impose no order. This is how a feedback loop is declared (electrical_network reads the
  /// temperature that heat_conduction wrote in the previous step, heat_conduction reads the
  /// joule_power of this step), instead of a read/write cycle.
  std::vector<std::string> reads_previous;
  std::vector<std::string> writes;  ///< fields written
};

class Module {
 public:
  virtual ~Module() = default;
  virtual std::string name() const = 0;
  virtual Phase phase() const { return Phase::Force; }
  virtual void declare(Declarations& d) const { (void)d; }
  virtual void bind(State& s) { (void)s; }
  /// The module's own default clock; a scenario can replace it (set_clock).
  virtual Clock clock() const { return {}; }
  /// The clock the scheduler uses: the scenario's choice if any, else clock().
  Clock effective_clock() const { return configured_clock_ ? *configured_clock_ : clock(); }
  void set_clock(const Clock& c) { configured_clock_ = c; }
  virtual TimeDomain time_domain() const { return TimeDomain::Mechanical; }
  /// Own stable step from the current state [s], in the module's time domain; +inf when
  /// unconditionally stable. Checked at the stage start and every stability_check_every steps
  /// (it may shrink during a stage); AdaptiveSubsteps clocks re-read it every step.
  virtual double stable_dt(const State& s) const {
    (void)s;
    return std::numeric_limits<double>::infinity();
  }
  virtual void advance(State& s, const StepInfo& step) = 0;
  /// Time-series columns the module reports (names fixed at construction, by convention
  /// prefixed with the module name) and their current values, in the same order.
  virtual std::vector<std::string> columns() const { return {}; }
  virtual std::vector<double> column_values(const State& s) const {
    (void)s;
    return {};
  }
  /// Per-edge outputs for the frames (held between calls like the columns; checkpointed by visit()).
  virtual std::vector<EdgeOutput> edge_outputs() const { return {}; }
  /// The module's one held edge output itself, when edge_outputs() is a copy of it (nullptr
  /// otherwise): a frame borrows its arrays instead of copying them and hands them back.
  virtual EdgeOutput* held_edges() { return nullptr; }
  /// Called once the stage's steps are over, before its closing frame and state are written: drop
  /// what only makes later calls faster (a solver's analysis and factorisation). Nothing that
  /// visit() stores or that a result depends on may change. (Issue 63 item 3: a sweep item's
  /// frame was the main scenario's memory peak with the network's solver structure still held.)
  virtual void release_caches() {}
  /// Every piece of state the module keeps between calls goes through here.
  virtual void visit(Archive& ar, const std::string& prefix) {
    (void)ar;
    (void)prefix;
  }

 private:
  std::optional<Clock> configured_clock_;
};

}  // namespace sparkdem
