#pragma once
/// # heat_conduction — transient heat conduction and Joule heating on the interaction graph
///
/// Seed 001 §2.3 (cohesive-joule-torsion.md §5-7) and the thermal pipe network of seed 000's
/// group (sintering-electrical.md §2.4): a node per particle with heat capacity C_i, a branch per
/// edge of the interaction graph (contacts, necks, intact bonds) whose conductance comes from
/// the same geometric models as the electrical network (physics/electrical/branch_models.hpp):
/// `transmission_surface` (lambda S_ij / l_ij), `sintered_neck` (hemispheres + optional layer) or
/// `batchelor_obrien` (2 lambda a, a plain contact of radius a). Equations, capacity conventions,
/// the stability bound and both time schemes: physics/thermal/thermal_kernels.hpp.
///
/// Sources and boundaries:
///   - Joule heating (joule_heating = true): eta x the particle field `joule_power` [W] written
///     by electrical_network (held between its solves: the zero-order hold of a quasi-static
///     field), which already splits each branch's I^2 R by where it is dissipated;
///   - fixed_sets / fixed_temperatures: particle sets held at a temperature (heat sinks/sources);
///   - flux_sets / flux_powers: a heat flow [W] into each set, split in proportion to C_i
///     (uniform heating rate);
///   - loss_set: particles that lose heat to `ambient_temperature` by convection (h) and
///     radiation (emissivity) through area loss_area_fraction x 4 pi r^2; "" = adiabatic (default).
/// Walls take no part (adiabatic).
///
/// Several materials: conductivity_sets / conductivity_factors give the particles of each set
/// the conductivity f_k lambda (1 elsewhere). A branch joins two sides in series, so its
/// conductance is G_ij = G_ij(lambda) / (s_ij / f_i + (1 - s_ij) / f_j), s_ij the share of the
/// branch resistance on side i returned by the branch model (0.5 for the symmetric models:
/// Batchelor-O'Brien then gives 4 a lambda_i lambda_j / (lambda_i + lambda_j), the transmission
/// surface lambda_ij = the harmonic mean; the sintered neck's share includes half of its layer,
/// which therefore takes the factor of its side). Exact for models in which each side's
/// resistance scales as 1 / lambda of that side.
///
/// Schemes: `explicit` (forward Euler) with its own stable step from the current network
/// (Gershgorin: safety x min_i C_i / (sum_j G_ij + dQ_i/dT)), run on the scheduler's adaptive
/// substeps by default (k = ceil(dt / stable) calls per mechanical step), or on any clock the
/// scenario sets (e.g. every_n_steps when its stable step exceeds the mechanical one; then the
/// step is N dt_m and the held values of the other modules, joule_power and the geometry, are
/// those of the step it runs in); `implicit` (backward Euler, sparse LDL^T through the shared
/// LaplacianSolver; unconditionally stable, every step by default).
///
/// The network (graph and conductances) is rebuilt whenever the geometry changed (a hash of the
/// positions, radii and table sizes), so substeps and frozen stages reuse it. Time domain: physical (a stage time_scale
/// multiplies its step).
///
/// Thermal expansion (expansion_coefficient != 0): r_i = r_ref,i (1 + alpha (T_i - T_0)) after
/// every call (physics/thermal/expansion.hpp).
///
/// Temperature columns: heat_temperature_mean (capacity-weighted), _min, _max, _std
/// (capacity-weighted standard deviation), heat_isolated_particles (no conducting branch: they
/// exchange heat only through their sources and losses).
/// Fields: temperature [K] (written), heat_capacity [J/K] (computed at the stage start),
/// temperature_initial [K] (the stage-start temperatures, for the stored heat), temperature_carry
/// [K] (explicit: the round-off of the compensated update T += dT, carried to the next call).
/// Energy balance columns [J] from the stage start: heat_electrical_energy (integral of the summed
/// joule_power), heat_joule_energy (eta x that), heat_flux_energy (prescribed), heat_lost_energy
/// (to the ambient), heat_fixed_energy (absorbed by the fixed sets), heat_stored_energy
/// (sum C_i (T_i - T_i,0)); heat_balance_error = |stored - (joule + flux - lost - fixed)| /
/// (joule + flux + lost + |fixed|) closes to round-off with either scheme (both conserve energy
/// exactly: the conduction fluxes cancel pairwise).
/// Set means (report_sets = "a,b"): one column heat_temperature_mean_<set> per set, the
/// capacity-weighted mean temperature sum_{i in set} C_i T_i / sum_{i in set} C_i [K] of the
/// particles in the set at the row (NaN when the set is empty); e.g. the slab-mean temperature
/// of a notch (configs/joule_notch.json).
#include <cstdint>
#include <string>
#include <vector>

#include "engine/graph/laplacian.hpp"
#include "engine/model/module.hpp"
#include "engine/model/param_spec.hpp"
#include "physics/electrical/branch_models.hpp"

namespace sparkdem::physics {

class HeatConduction final : public Module {
 public:
  struct Params {
    std::string model = "transmission_surface";
    double conductivity = 0.0;   ///< lambda [W/(m K)]
    double density = 0.0;        ///< rho [kg/m^3] (true density; mass scaling never enters C)
    double specific_heat = 0.0;  ///< c [J/(kg K)]
    std::string capacity = "sphere";
    double domain_volume = 0.0;        ///< [m^3]
    double initial_temperature = 0.0;  ///< [K]; 0 keeps the particles' temperature
    bool joule_heating = false;
    double heat_fraction = 1.0;              ///< eta [-]
    std::string fixed_sets;                  ///< comma-separated set names
    std::vector<double> fixed_temperatures;  ///< [K], one per fixed set
    std::string flux_sets;
    std::vector<double> flux_powers;  ///< [W], one per flux set
    std::string loss_set;
    std::string conductivity_sets;             ///< comma-separated set names
    std::vector<double> conductivity_factors;  ///< [-] one per conductivity set: lambda_i = f lambda
    double convection_coefficient = 0.0;       ///< h [W/(m^2 K)]
    double emissivity = 0.0;
    double ambient_temperature = 293.15;  ///< [K]
    double loss_area_fraction = 0.5;
    std::string report_sets;  ///< comma-separated sets: columns heat_temperature_mean_<set>
    std::string scheme = "explicit";
    double safety = 0.9;
    std::string solver = "direct";
    double tolerance = 1e-12;
    double expansion_coefficient = 0.0;     ///< [1/K]
    double reference_temperature = 293.15;  ///< [K]
    // branch model details (same meaning as in electrical_network)
    std::string contact_radius = "hertz";
    std::string neck = "law";
    std::string hemisphere = "reading_a";
    double gb_epsilon = 1.0;
    double gb_thickness = 0.0;
    bool gbf_correction = true;
    double alpha_constant = 0.0;
    double touch_tolerance = 0.0;
    double touch_tolerance_relative = 0.0;  // [1] of the mean radius; > 0 overrides touch_tolerance
  };
  static ParamSpec<Params> spec();
  explicit HeatConduction(const Params& p);

  std::string name() const override { return "heat_conduction"; }
  Phase phase() const override { return Phase::Coupling; }
  TimeDomain time_domain() const override { return TimeDomain::Physical; }
  void declare(Declarations& d) const override;
  void bind(State& s) override;
  Clock clock() const override;
  double stable_dt(const State& s) const override;
  void advance(State& s, const StepInfo& info) override;
  std::vector<std::string> columns() const override;
  std::vector<double> column_values(const State& s) const override;
  void visit(Archive& ar, const std::string& prefix) override;
  /// The solver's analysis and factorisation (its warm start, which visit() stores, stays).
  void release_caches() override { solver_.invalidate(); }

  /// Accumulated energies since the stage start [J].
  struct Energy {
    double electrical = 0.0, joule = 0.0, flux = 0.0, lost = 0.0, fixed = 0.0;
  };
  const Energy& energy() const { return e_; }
  /// Id of the particle that set the last stable_dt() (min C_i / rate_i), -1 if none.
  Id stable_dt_particle() const { return limiting_id_; }

 private:
  /// The conduction network of the current geometry (cached while the geometry is unchanged).
  struct Network {
    std::uint64_t key = 0;
    bool valid = false;
    std::vector<Index> a, b;
    std::vector<double> g;       ///< [W/K]
    std::vector<double> degree;  ///< sum_j G_ij [W/K]
    EdgeIncidence inc;
  };
  const Network& network(const State& s) const;
  Params p_;
  BranchModel branch_;
  mutable Network net_;
  std::vector<std::string> fixed_names_, flux_names_, factor_names_, report_names_;
  mutable Id limiting_id_ = -1;
  LaplacianSolver solver_;
  Energy e_;
  bool restored_ = false;
  double capacity_ratio_ = 0.0;  ///< sum V_i / f_v,i over V_d (NaN without domain_volume)
  std::vector<double> scratch_;
};

}  // namespace sparkdem::physics
