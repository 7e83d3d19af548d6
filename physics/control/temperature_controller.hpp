#pragma once
/// # temperature_controller — PI control of the electrical supply so that a control point follows
/// a programmed temperature cycle (a spark-plasma-sintering machine's loop)
///
/// Loop (physical time t from the stage start, one call per mechanical step):
///   e(t)   = T_set(t) - T_c,   T_c = capacity-weighted mean temperature (heat_capacity field when
///            present, else the plain mean) of the particles of `set` at the end of the previous
///            step (the sensor sample: a reads_previous of `temperature`). In a loose powder single
///            particles differ by tens of K (Joule heating concentrates where the current
///            crowds), so the control set should hold many particles.
///   P(t)   = clamp(P_ff + k_p e + k_i I, 0, max_power),   I = integral of e dt
///            P_ff = feedforward_capacity x dT_set/dt (optional, J/K; 0 = off)
///   anti-windup: I is not integrated while P is clamped and e pushes further into the clamp
///   V(t)   = sqrt(P R),   R = the network resistance of the last electrical solve (the signal
///            "electrical_resistance"), written to the signal "<signal>" that electrical_network
///            reads as its voltage (voltage_signal).
/// The PI acts on the supplied POWER and the voltage is its image through the plant's static
/// non-linearity P = V^2 / R, so the loop is linear: for a lumped compact C dT/dt = P - losses,
/// the closed loop has s^2 + (k_p/C) s + k_i/C = 0, i.e. k_p = 2 zeta omega C, k_i = omega^2 C
/// for a chosen natural frequency omega [rad/s] and damping zeta. With a pure integrator plant
/// and integral action, a ramp of the set point is followed without steady-state error.
/// Before the first electrical solve (R unknown) the output voltage is `initial_voltage`.
///
/// Signals (State::marks "signal/<name>", checkpointed): reads "signal/electrical_resistance",
/// writes "signal/<signal>". Columns: controller_setpoint [K], controller_temperature [K],
/// controller_error [K], controller_power [W], controller_voltage [V], controller_max_error_after
/// [K] (largest |e| after `track_after` s; the acceptance figure).
#include <string>
#include <vector>

#include "engine/model/module.hpp"
#include "engine/model/param_spec.hpp"

namespace sparkdem::physics {

namespace control {
/// One PI update with clamping and conditional-integration anti-windup (pure function).
///   u = clamp(ff + kp e + ki (I + e dt), lo, hi); I advances by e dt unless u is clamped and
///   e pushes further into the clamp.
struct PiState {
  double integral = 0.0;  ///< [K s]
  double output = 0.0;
};
PiState pi_step(const PiState& s, double error, double dt, double kp, double ki, double feedforward, double lo, double hi);
}  // namespace control

class TemperatureController final : public Module {
 public:
  struct Params {
    std::string set;                    ///< control particle set
    std::vector<double> time;           ///< [s] set-point table, physical, from the stage start
    std::vector<double> temperature;    ///< [K]
    double kp = 0.0;                    ///< [W/K]
    double ki = 0.0;                    ///< [W/(K s)]
    double feedforward_capacity = 0.0;  ///< [J/K]
    double max_power = 1.0;             ///< [W]
    double initial_voltage = 0.0;       ///< [V]
    std::string signal = "supply_voltage";
    double track_after = 60.0;  ///< [s]
  };
  static ParamSpec<Params> spec();
  explicit TemperatureController(const Params& p);
  std::string name() const override { return "temperature_controller"; }
  Phase phase() const override { return Phase::Coupling; }
  TimeDomain time_domain() const override { return TimeDomain::Physical; }
  void declare(Declarations& d) const override;
  void bind(State& s) override;
  void advance(State& s, const StepInfo& info) override;
  std::vector<std::string> columns() const override;
  std::vector<double> column_values(const State& s) const override;
  void visit(Archive& ar, const std::string& prefix) override;

 private:
  double setpoint(double t) const;
  double measured(const State& s) const;
  Params p_;
  control::PiState pi_;
  double last_setpoint_ = 0.0, last_temperature_ = 0.0, last_voltage_ = 0.0, max_error_after_ = 0.0;
  bool restored_ = false;
};

}  // namespace sparkdem::physics
