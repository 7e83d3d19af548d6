#pragma once
/// # torsion_test — measurements of a pin twisted between a clamped and a turned end set
///
/// Seed 001 §4 (../shared/physics/cohesive-joule-torsion.md §8 and §11): one end set of a
/// cylindrical pin is clamped, the other turned about the pin axis (stage key `prescribe` with
/// an `angular_velocity`); this module turns the state into the figures of Fig. 16.
///
///   twist        theta = rotation of a reference member of the turned set about the axis since
///                the module first ran (2 atan2(q_rel.v . a, q_rel.w), q_rel = q q0^-1)
///   torque       T = sum over the clamped set of ((x_i - c) x F_i + T_i) . a  (reaction on the
///                clamp, c = axis_point, a = unit axis); the turned end's -sum is reported beside
///                it (their difference is the inertia of the pin: quasi-static check)
///   shear stress tau_max = 2 T / (pi r^3)  (elastic surface shear of a solid circular section)
///   elastic      T_el = G J theta / L, J = pi r^4 / 2, L = `length` or, when 0, the axial
///                distance between the centroids of the two end sets at the first call
///   resistance   R / R0 with R = signal "electrical_resistance" (electrical_network) and R0
///                its first value; +inf when no path spans the electrodes (the pin separated)
///   onsets       the twist of the first broken bond, the first twist where R / R0 - 1 exceeds
///                `resistance_threshold`, the first where R / R0 >= `resistance_jump_ratio` (2: R
///                doubled, seed 001's "more than doubles"), the first where R is infinite (no
///                path: separation); NaN until then
///   filter       a resistance crossing counts only when the condition holds while the twist
///                advances by `resistance_persistence` [rad]; the onset is the twist where that
///                held span began (0: the first crossing, unfiltered). A crossing that falls back
///                before the span ends (the crack halves rattling, the elastic noise) is rejected
///                and counted (torsion_resistance_rejected_rises / _jumps)
///   trend onset  with `resistance_trend_fit_twist` > 0: the first twist past it where R / R0 leaves
///                its elastic trend (a quadratic fitted on the twists up to it), either sign, by more than
///                `resistance_trend_sigmas` times the fit's residual deviation plus
///                `resistance_trend_floor`, held over `resistance_persistence` (resistance_trend.hpp;
///                issue 58 item 5). Samples are the new values of R at the twist of their re-solve;
///                columns torsion_resistance_trend_onset_twist, _departure (the newest sample's
///                departure in units of the threshold) and _samples (fit samples)
///   reports      R / R0 when the twist first reaches each of `report_twists`
///   stiffness    torsion_stiffness_ratio = k / (G J / L), k the least-squares slope of T against
///                theta through the origin over every call before the first break (averages out
///                the torsional oscillations a twist started at full rate leaves behind)
/// Every quantity kept between calls (reference orientation, R0, onsets, reports) lives in
/// State::marks under "torsion/", so it is checkpointed and carries over from stage to stage
/// (an elastic stage and a cracking stage of the same pin measure one twist).
///
/// | parameter            | unit | meaning                                                      |
/// |----------------------|------|--------------------------------------------------------------|
/// | clamped, twisted     | -    | particle sets of the two ends                                |
/// | axis_point, axis     | m, - | the pin axis                                                 |
/// | radius               | m    | pin radius r (stress and J)                                  |
/// | length               | m    | L of the elastic reference (0: distance of the end centroids)|
/// | shear_modulus        | Pa   | G of the elastic reference                                   |
/// | yield_shear_stress   | Pa   | tau_y (column torsion_shear_ratio = tau_max / tau_y)         |
/// | resistance_signal    | -    | signal holding R ("" : no resistance columns' input, R/R0 NaN) |
/// | resistance_threshold | 1    | onset of the resistance rise: R / R0 - 1 above this          |
/// | resistance_jump_ratio| 1    | R / R0 of the jump onset (2: the twist where R doubles)      |
/// | resistance_persistence| rad | twist span a resistance crossing must hold to count          |
/// | resistance_trend_fit_twist | rad | twist span of the elastic trend fit (0: no trend onset) |
/// | resistance_trend_sigmas | 1  | departure threshold in residual deviations of the fit        |
/// | resistance_trend_floor | 1   | added to the threshold: the solver's relative tolerance on R |
/// | report_twists        | rad  | twists at which R / R0 is recorded                           |
#include <string>
#include <vector>

#include "engine/model/module.hpp"
#include "engine/model/param_spec.hpp"

namespace sparkdem::physics {

class TorsionTest final : public Module {
 public:
  struct Params {
    std::string clamped = "bottom";
    std::string twisted = "top";
    Vec3 axis_point = Vec3::Zero();
    Vec3 axis = Vec3::UnitZ();
    double radius = 0.0;
    double length = 0.0;
    double shear_modulus = 0.0;
    double yield_shear_stress = 0.0;
    std::string resistance_signal = "electrical_resistance";
    double resistance_threshold = 0.01;
    double resistance_jump_ratio = 2.0;
    double resistance_persistence = 0.0;
    double resistance_trend_fit_twist = 0.0;
    double resistance_trend_sigmas = 5.0;
    double resistance_trend_floor = 1e-6;
    std::vector<double> report_twists;
  };
  static ParamSpec<Params> spec();
  explicit TorsionTest(const Params& p);

  std::string name() const override { return "torsion_test"; }
  Phase phase() const override { return Phase::Coupling; }
  void declare(Declarations& d) const override;
  void bind(State& s) override;
  void advance(State& s, const StepInfo& info) override;
  std::vector<std::string> columns() const override;
  std::vector<double> column_values(const State& s) const override;

  /// Column name of the R / R0 report at twist `theta` [rad].
  static std::string report_column(double theta);

 private:
  /// The trend onset's sampling, fit and filter (no-op without resistance_trend_fit_twist).
  void advance_trend(State& s, double theta, double ratio);
  /// The departure of the newest sample of R from the trend (NaN before a fit exists, and while the
  /// newest sample lies inside the fit span).
  double trend_departure(const State& s) const;

  Params p_;
  Vec3 a_;  ///< unit axis
};

}  // namespace sparkdem::physics
