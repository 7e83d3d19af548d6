#pragma once
/// # temperature_history — prescribed uniform temperature T(t) and thermal expansion of the radii
/// Seed 000's hot press (physics notes sintering-electrical.md §3.3): the process temperature is
/// applied to every particle, and the radii follow it as a function of T (never compounded per
/// step):
///   T(t)  piecewise linear through (time_k, temperature_k), t = physical time since the stage
///         start [s]; held at the first / last value outside the table
///   r_i = r_ref,i (1 + alpha_T (T - T_0))                                   (notes §3.3)
/// Mass is constant (thermal expansion moves no matter: the density falls as 1/(1+alpha dT)^3);
/// the moment of inertia follows the radius, I_i = 2/5 m_i r_i^2 (mass-scaled mass in a
/// mass-scaled stage). The module runs in physical time (TimeDomain::Physical), so with a stage
/// `time_scale` s the table is read at t = s * (mechanical stage time).
///
/// Fields: "temperature" [K] (written, every particle = T(t)); with alpha_T != 0 also
/// "radius_ref" [m] (the radius at T_0) and "radius_ref_temperature" [K] (the T_0 it refers to).
/// Reference-radius rule: a particle's reference radius is captured ONCE, when a
/// temperature_history module with alpha_T != 0 first binds and the particle has none yet
/// (radius_ref = current radius, taken to be the radius at reference_temperature). The fields
/// are checkpointed and carried to later stages, so a later stage (or a restart) never recaptures
/// from already expanded radii; a later stage must give the same reference_temperature (a
/// different one is a set-up error). Particles added later (no reference yet) are captured at
/// the next binding. With alpha_T = 0 the radii are left alone.
///
/// Timing: a coupling module (after the mechanical step). At a stage start it sets T(0) and the
/// radii before the stage's first neighbour build and force pass; then, at the end of every
/// step, T at the end of that step. A radius change is seen by the Verlet criterion (it compares
/// the radii with those of the last build, like radius_growth), so no extra bookkeeping is needed.
///
/// | parameter              | unit | meaning                                                         |
/// |------------------------|------|-----------------------------------------------------------------|
/// | time                   | s    | table times, physical, from the stage start (strictly increasing)|
/// | temperature            | K    | temperature at each time (> 0)                                  |
/// | expansion_coefficient  | 1/K  | alpha_T, linear thermal expansion coefficient (0 = off)         |
/// | reference_temperature  | K    | T_0, at which the captured radii are the reference radii        |
///
/// Time-series column: `temperature` [K].
#include <string>
#include <vector>

#include "engine/model/module.hpp"
#include "engine/model/param_spec.hpp"
#include "engine/state/state.hpp"
#include "physics/thermal/expansion.hpp"

namespace sparkdem::physics {

namespace thermal {
/// T(t) [K]: piecewise linear through (t_k, T_k), constant beyond the ends. `t` strictly
/// increasing, same length as `T`, at least one point.
double table_temperature(const std::vector<double>& t, const std::vector<double>& T, double time);
}  // namespace thermal

class TemperatureHistory final : public Module {
 public:
  struct Params {
    std::vector<double> time;               ///< [s] physical, from the stage start
    std::vector<double> temperature;        ///< [K]
    bool start_from_current = false;        ///< the first table value is the particles' mean temperature at the stage start
    double expansion_coefficient = 0.0;     ///< [1/K]
    double reference_temperature = 293.15;  ///< [K]
  };
  static ParamSpec<Params> spec();
  /// Throws ConfigError with every problem of the table (paths relative to the module).
  explicit TemperatureHistory(const Params& p);
  std::string name() const override { return "temperature_history"; }
  Phase phase() const override { return Phase::Coupling; }
  TimeDomain time_domain() const override { return TimeDomain::Physical; }
  void declare(Declarations& d) const override;
  void bind(State& s) override;
  void advance(State& s, const StepInfo& step) override;
  std::vector<std::string> columns() const override { return {"temperature"}; }
  std::vector<double> column_values(const State&) const override { return {current_}; }
  void visit(Archive& ar, const std::string& prefix) override;

  /// T at physical time `t` since the stage start [K].
  double temperature_at(double t) const { return thermal::table_temperature(p_.time, table_, t); }

 private:
  void apply(State& s, double T);
  Params p_;
  double current_ = 0.0;       ///< temperature last written [K]
  std::vector<double> table_;  ///< the temperature table as used (start_from_current: first value replaced; checkpointed)
  bool restored_ = false;      ///< set by visit() when reading: bind() leaves the restored state alone
};

}  // namespace sparkdem::physics
