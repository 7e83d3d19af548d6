#pragma once
/// Module contract: what every physics module implements. A module declares the fields it
/// reads and writes, its clock relative to the mechanical step and its own stable step; the
/// scheduler builds the step plan once from these declarations.
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "engine/core/archive.hpp"
#include "engine/core/types.hpp"
#include "engine/state/field_registry.hpp"

namespace sparkdem {

struct State;

/// When a module runs, relative to the mechanical step dt_m.
struct Clock {
  enum class Kind { EveryStep, EveryNSteps, SubstepsPerStep };
  Kind kind = Kind::EveryStep;
  std::int64_t n = 1;  ///< N mechanical steps per call, or k substeps per mechanical step
  /// Effective step of one call [s].
  double dt(double dt_m) const {
    switch (kind) {
      case Kind::EveryNSteps: return static_cast<double>(n) * dt_m;
      case Kind::SubstepsPerStep: return dt_m / static_cast<double>(n);
      default: return dt_m;
    }
  }
};

/// Where in the step a module runs. Force modules add to force/torque between the contact
/// pass and the second half-kick; Coupling modules run after the mechanical step, in the
/// order derived from their reads/writes.
enum class Phase { Force, Coupling };

struct StepInfo {
  Step step;    ///< global step index of the step being completed
  double time;  ///< simulated time at the end of the call [s] (= stage_t0 + steps * dt_m)
  double dt;    ///< step of this call [s] (Clock::dt)
};

/// What a module needs and provides. Declaring is what makes allocation, output, restart and
/// ordering automatic.
struct Declarations {
  std::vector<FieldInfo> particle_fields;  ///< optional per-particle fields to allocate
  std::vector<std::string> reads;          ///< fields read (must be written by someone or core)
  std::vector<std::string> writes;         ///< fields written
};

class Module {
 public:
  virtual ~Module() = default;
  virtual std::string name() const = 0;
  virtual Phase phase() const { return Phase::Force; }
  virtual void declare(Declarations& d) const { (void)d; }
  virtual void bind(State& s) { (void)s; }
  virtual Clock clock() const { return {}; }
  /// Own stable step from the current state [s]; +inf when unconditionally stable.
  virtual double stable_dt(const State& s) const { (void)s; return std::numeric_limits<double>::infinity(); }
  virtual void advance(State& s, const StepInfo& step) = 0;
  /// Every piece of state the module keeps between calls goes through here.
  virtual void visit(Archive& ar, const std::string& prefix) { (void)ar; (void)prefix; }
};

}  // namespace sparkdem
