#pragma once
/// # ptc_self_heating — local thermal eigenstrain of the CPC matrix from the temperature field
///
/// Source: /work/shared/physics/cpc-and-networks.md §1.6 "Temperature coupling" (with Joule
/// heating a locally varying eps0(x) enters the same linear solve as a right-hand side); the
/// matrix model of ptc_matrix.hpp (rigid fillers, axial polymer springs with eigen-elongation
/// eps0 h*) and the eps0(T) law of ptc_temperature.hpp. For a self-heating current limiter:
///   ptc_self_heating (temperature -> filler displacements) -> electrical_network (model
///   touching, displacement_field = ptc_displacement: a contact conducts while its gap after the
///   displacement is <= its own touch_tolerance [m] (or touch_tolerance_relative x the mean
///   radius): give it 2 touch_gap_rel R for equal fillers of radius R, the set this module counts;
///   open_conductance for an opened contact) ->
///   heat_conduction (joule_power -> temperature, losses to the ambient).
///
/// Each call: eps0_e = eps0(T_e) per spring, T_e the mean temperature of its two fillers; one
/// back-substitution with the factorised network matrix (ptc_local_strain.hpp; factorised on
/// the first call and again only if a position changed: the stage is meant to be frozen) gives
/// the displacements u_i [m] per filler, written to the particle field `ptc_displacement`. The
/// opening of every touching contact is n . (u_b - u_a) (as in ptc_strain). Columns (prefix
/// ptc_self_heating_):
///   contacts                 touching contacts of the configuration
///   conducting               contacts whose gap after the displacement is <= break_gap_rel (R_i + R_j) [-]
///                            (the rule of ptc_matrix.hpp; every gap threshold is relative, ptc_gaps.hpp;
///                            the touching contacts only: no closing candidates here)
///   coordination             Z = 2 conducting / N [1]
///   eps0_mean, eps0_max      over the springs with polymer (h* > 0) [1]
///   switching_strain         exact uniform switching strain of the network (as ptc_strain) [1]
///                            (needs `high` and `low`; NaN otherwise)
///   switching_temperature    eps0^-1(switching_strain) [K] (uniform heating)
/// The electrodes `high`/`low` are used only for the two switching columns.
#include <string>
#include <vector>

#include "engine/model/module.hpp"
#include "engine/model/param_spec.hpp"
#include "physics/electrical/ptc_local_strain.hpp"
#include "physics/electrical/ptc_matrix.hpp"
#include "physics/electrical/ptc_temperature.hpp"

namespace sparkdem::physics {

class PtcSelfHeating final : public Module {
 public:
  struct Params {
    std::string high;  ///< electrode set (switching columns only; "" = none)
    std::string low;
    double touch_gap_rel = 1e-3;              ///< [1] of R_i + R_j
    double break_gap_rel = 1e-3;              ///< [1] of R_i + R_j
    double cutoff_gap_rel = 0.5;              ///< [1] of R_i + R_j: h_max
    double min_gap_rel = 5e-3;                ///< [1] of R_i + R_j: h_min
    double regularisation = 1e-9;             ///< [1]
    double expansion_coefficient = 2e-4;      ///< alpha_s [1/K]
    double expansion_coefficient_melt = 0.0;  ///< alpha_l [1/K]; 0 = alpha_s
    double reference_temperature = 293.15;    ///< [K]
    double melting_temperature = 0.0;         ///< [K]; 0 = none
    double melting_strain = 0.0;              ///< [1]
    double melting_width = 0.0;               ///< [K]
  };
  static ParamSpec<Params> spec();
  explicit PtcSelfHeating(const Params& p);

  std::string name() const override { return "ptc_self_heating"; }
  Phase phase() const override { return Phase::Coupling; }
  void declare(Declarations& d) const override;
  void advance(State& s, const StepInfo& info) override;
  std::vector<std::string> columns() const override;
  std::vector<double> column_values(const State& s) const override;
  void visit(Archive& ar, const std::string& prefix) override;

 private:
  void build(const State& s);
  Params p_;
  ptc::ThermalStrainLaw law_;
  ptc::MatrixParams mp_;
  // Geometry cache (rebuilt from the positions; not checkpointed: deterministic).
  std::vector<Vec3> x_ref_;
  ptc::SpringNetwork net_;
  ptc::LocalStrainSolver solver_;
  std::vector<std::size_t> contact_;  ///< spring index of every touching contact
  double switching_strain_ = 0.0;
  std::vector<double> held_;  ///< column values of the last call
};

}  // namespace sparkdem::physics
