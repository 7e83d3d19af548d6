#pragma once
/// # electrical_network — steady DC resistor network on the interaction graph
///
/// Particle-centred topology (seeds 000/001): a node at each particle centre (and, when an
/// electrode is a wall, a node per wall), a branch per edge of the interaction graph (contacts,
/// sintered necks, intact bonds, near pairs for tunnelling). Kirchhoff's current law with
/// Ohm's law per branch gives K V = I (seed 000 Eqs. 1-9; K = the conductance-weighted graph
/// Laplacian); the two electrodes are held at `voltage` and 0 V, everything else is insulated.
/// Solved by the shared LaplacianSolver (engine/graph/laplacian.hpp). Branch conductances come
/// from physics/electrical/conductance_kernels.hpp, chosen by `model`:
///
///   holm                  G = 2 a kappa, a = Hertz sqrt(R* delta) or the geometric lens radius;
///                         a neck edge uses its neck radius; a wall contact a = sqrt(r delta)
///   sintered_neck         Eq. 17-18: hemispheres (Eq. 19-20, `hemisphere` reading) in series with
///                         the grain-boundary layer (Eq. 26, when gb_thickness > 0); neck radius
///                         from the contact law's neck column, or Coble (Eq. 21) / constant volume
///                         from the overlap; grain-boundary-fraction correction (Eq. 22-25)
///   transmission_surface  R_ij = rho_e l_ij / sqrt(S_i S_j), S_i = alpha(n_i) r_i^2 / f(e_i) (seed
///                         001 Eq. 2-5); `alpha_constant` > 0 holds alpha fixed and f = 1;
///                         `eccentricity` "current" evaluates e_i on the positions of each solve,
///                         "reference" on those of the first solve (particle field
///                         electrical_eccentricity_reference, checkpointed): Eq. 3's switch at
///                         e = 0.4 then does not flip f under elastic strain (steps of R of
///                         1e-4-1e-3 in an elastic twist; issue 58), while n_i follows the bonds
///   touching              G = unit_conductance for every touching pair (seed 002)
///   tunnelling            touching pairs unit_conductance, gaps g0 exp(-2 gap/xi) up to the cut-off
///
/// Signals: writes "signal/electrical_resistance" [Ohm] (-1 without a spanning path) after every
/// solve (a controller's plant measurement); reads "signal/<voltage_signal>" when set.
/// Outputs: fields electric_potential [V] (NaN on floating particles) and joule_power [W]: each
/// branch's I^2 R goes where it is dissipated: a branch of resistances in series (half-particle
/// i, contact layer, half-particle j; sintered_neck) heats i with I^2 R_i + I^2 R_c / 2 and j with
/// I^2 R_j + I^2 R_c / 2; a branch of one resistance (transmission_surface, holm between equal
/// conductivities, touching, tunnelling) heats each end with half. Each branch is counted ONCE
/// (seed 001's Eq. 16 as printed adds the whole branch power at both ends, which doubles the
/// heat; cohesive-joule-torsion.md §5). A wall electrode's share heats the wall (column
/// electrical_power_particles is the part that heats particles);
/// time-series columns electrical_current [A] (leaving the high electrode), its mismatch with the
/// low electrode, electrical_resistance [Ohm] (+inf without a spanning path), the effective
/// conductivity kappa_eff = I L / (dV A) (seed 000 Eq. 28), electrical_power [W] (sum I^2 R) and
/// its mismatch with V I, the Kirchhoff residual, floating nodes, iterations, solve time; with
/// model sintered_neck also the necks the network conducts through (after Eqs. 21-25) as seed
/// 000's Fig. 6 reads them: network_necks, network_neck_median_a_over_rmin,
/// network_neck_max_bin_percent, network_neck_last_bin_percent (10 bins of a / r_min on [0, 1]) and
/// network_neck_gbf_bound_share (particles whose Eq. 25 binds, of those with a neck).
///
/// Clock: on an event by default — on the initial state, when any particle moved more than
/// `resolve_distance` (default 0.05 x the smallest radius), a bond broke, (temperature_field) a
/// particle's temperature changed by more than `resolve_temperature_change`, or `resolve_every`
/// steps passed; a scenario can set any clock (e.g. every N steps). The solve is quasi-static:
/// between solves the potentials, currents and joule_power are held (zero-order hold), so the
/// heat released between two solves is the power of the last solve times the elapsed time.
///
/// | parameter          | unit  | meaning                                                        |
/// |--------------------|-------|----------------------------------------------------------------|
/// | model              | -     | holm, sintered_neck, transmission_surface, touching, tunnelling |
/// | branches           | -     | all (contacts, necks, intact bonds) or bonds (intact bonds only: a broken bond stops conducting even where its faces touch) |
/// | conductivity       | S/m   | bulk conductivity kappa at reference_temperature              |
/// | temperature        | K     | evaluation temperature (default 293.15 K: samples are measured cold) |
/// | temperature_field  | -     | true: kappa(T) per branch at its particles' mean `temperature` field |
/// | resolve_temperature_change | K | default clock with temperature_field: re-solve after this change |
/// | resolve_every      | steps | default clock: also re-solve every this many steps (0: never)  |
/// | resistivity_coefficient | 1/K | beta of kappa(T) = kappa / (1 + beta (T - T_ref)) (0: constant) |
/// | conductivity_table_temperature, _values | K, S/m | tabulated kappa(T) instead (piecewise linear) |
/// | high, low          | -     | electrodes: a particle-set name, or "wall:<name>"              |
/// | empty_electrode    | -     | error (default): an electrode set with no particle is a SetupError; open: an open circuit (R = +inf) |
/// | voltage            | V     | potential of `high` (low = 0)                                  |
/// | voltage_signal     | -     | take the voltage from State signal "signal/<name>" at each solve (a controller's output) |
/// | current            | A     | > 0: inject this current at `high` instead (electrode equipotential) |
/// | length, area       | m, m2 | L and A of Eq. 28 (0: from length_mode; the die cross-section) |
/// | topology           | -     | particle_centred (seeds 000/001), contact_centred (seed 003), sphere_element (sintered_neck: nodes at the necks, each particle a sphere element whose necks share its volume; column electrical_negative_share) |
/// | length_mode        | -     | L when length = 0: electrode_centroids (distance of the electrodes' particle centroids) or sample_height (Eq. 28 as written: the particles' extent, surfaces included, along the electrode axis) |
/// | solver, tolerance  | -, 1  | direct, cg_ic, cg_jacobi, amg, pseudo_transient; iterative relative residual |
/// | displacement_field | -     | touching/tunnelling: a 3-component particle field u [m] (ptc_self_heating's ptc_displacement): pair gaps become gap + n . (u_b - u_a); clock every step by default |
/// | open_conductance   | S     | touching: conductance of a pair of the graph (gap <= touch_tolerance) whose gap after the displacement exceeds the tolerance (0: none) |
#include <string>
#include <vector>

#include "engine/core/numbers.hpp"
#include "engine/graph/interaction_graph.hpp"
#include "engine/graph/laplacian.hpp"
#include "engine/model/module.hpp"
#include "engine/model/param_spec.hpp"
#include "physics/electrical/branch_models.hpp"
#include "physics/electrical/conductance_kernels.hpp"

namespace sparkdem::physics {

class ElectricalNetwork final : public Module {
 public:
  struct Params {
    std::string model = "holm";
    std::string topology = "particle_centred";
    std::string branches = "all";
    bool chord_scaling = true;
    std::string element_cap = "equal_area";
    double conductivity = 1e6;
    double temperature = 293.15;
    bool temperature_field = false;
    double resolve_temperature_change = 1.0;
    std::int64_t resolve_every = 0;
    double reference_temperature = 293.15;
    double resistivity_coefficient = 0.0;
    std::vector<double> conductivity_table_temperature;  // K; empty: the linear law
    std::vector<double> conductivity_table_values;       // S/m
    std::string high = "top";
    std::string low = "bottom";
    std::string empty_electrode = "error";
    double voltage = 1.0;
    std::string voltage_signal;
    double current = 0.0;
    double length = 0.0;
    std::string length_mode = "electrode_centroids";
    double area = 0.0;
    std::string solver = "direct";
    double tolerance = 1e-10;
    double amg_spread_min_rows = 200000;
    // pseudo_transient (seed 000's iteration, kept to reproduce the paper)
    double specific_capacity = 1.0;
    double pseudo_dt = 0.0;
    double pseudo_dt_fraction = 0.9;
    double beta = 2e-4;
    std::string indicator = "range";
    bool allow_unstable = false;
    double resolve_distance = 0.0;
    // holm
    std::string contact_radius = "hertz";
    // sintered_neck
    std::string neck = "law";
    std::string hemisphere = "reading_a";
    double gb_epsilon = 1.0;
    double gb_thickness = 0.0;
    bool gbf_correction = true;
    // transmission_surface
    double resistivity = 0.0;
    double alpha_constant = 0.0;
    std::string eccentricity = "current";
    // touching, tunnelling
    double unit_conductance = 1.0;
    double touch_tolerance = 0.0;
    double touch_tolerance_relative = 0.0;  // [1] of the mean radius; > 0 overrides touch_tolerance
    double tunnel_g0 = 1.0;
    double tunnel_length = 1e-9;
    double tunnel_cutoff = 0.0;
    std::string displacement_field;  // touching, tunnelling: per-particle displacement added to the gaps
    double open_conductance = 0.0;   // touching: conductance of a graph pair that does not touch [S]
  };
  static ParamSpec<Params> spec();
  explicit ElectricalNetwork(const Params& p);

  std::string name() const override { return "electrical_network"; }
  /// Particle field of the reference eccentricities (eccentricity = "reference"; -1: not yet set).
  static constexpr const char* kEccentricityField = "electrical_eccentricity_reference";
  /// Particle field of the current through each particle [A]: half the sum of |I| over its
  /// branches (particle-centred topology; NaN on the others), written with every solve.
  static constexpr const char* kParticleCurrentField = "particle_current";
  Phase phase() const override { return Phase::Coupling; }
  void declare(Declarations& d) const override;
  void bind(State& s) override;
  Clock clock() const override { return default_clock_; }
  void advance(State& s, const StepInfo& info) override;
  std::vector<std::string> columns() const override;
  std::vector<double> column_values(const State& s) const override;
  void visit(Archive& ar, const std::string& prefix) override;
  /// The solver's analysis and factorisation (its warm start, which visit() stores, stays).
  void release_caches() override { solver_.invalidate(); }
  /// Per conducting branch of the particle-centred network (frames: /networks/electrical): the
  /// ids of its ends (a wall is -1 - wall index), the current from the first to the second [A],
  /// its conductance [S] and dissipated power [W]. Empty before the first solve.
  std::vector<EdgeOutput> edge_outputs() const override {
    return held_edge_output(edges_);
  }
  EdgeOutput* held_edges() override { return &edges_; }

  /// Results of the last solve (held between solves).
  struct Result {
    double current = 0.0;           ///< leaving the high electrode [A]
    double current_mismatch = 0.0;  ///< |I_high + I_low| / |I_high| [-]
    double resistance = 0.0;        ///< dV / I [Ohm]; +inf without a spanning path
    double conductivity_eff = 0.0;  ///< I L / (dV A) [S/m]; NaN when A is unknown
    double power = 0.0;             ///< sum over branches of I^2 R [W]
    double power_mismatch = 0.0;    ///< |P - dV I| / (dV I) [-]
    double residual = 0.0;          ///< relative Kirchhoff residual of the reduced system [-]
    double floating = 0.0;          ///< particles connected to neither electrode
    double iterations = 0.0;
    double seconds = 0.0;
    double length = 0.0;  ///< L used in Eq. 28 [m]
    double solves = 0.0;
    double voltage = 0.0;          ///< potential of the high electrode [V] (given, or from the injected current)
    double power_particles = 0.0;  ///< part of `power` that heats particles (joule_power summed) [W]; the rest heats wall electrodes
    double negative_share = 0.0;   ///< sphere_element: sum of the negative element conductances over the positive ones [-]
    double amg_ranks = 1.0;        ///< amg: MPI ranks the last solve was spread over
    /// sintered_neck: seed 000's Fig. 6 statistics of the necks the network conducts through
    /// (after Eqs. 21-25; 10 bins of a / r_min) and the share of particles Eq. 25 binds.
    std::vector<double> necks = {0.0, kNaN, kNaN, kNaN, kNaN};
  };
  const Result& result() const { return r_; }

 private:
  /// Branch conductances [S] per graph edge, and the share of each branch resistance on side a
  /// (NaN when the model puts all of it at the contact).
  std::vector<double> conductances(const State& s, const InteractionGraph& g, std::vector<double>& share_a) const;
  bool reference_eccentricity() const { return p_.eccentricity == "reference" && p_.model == "transmission_surface"; }
  /// eccentricity = "reference": e_i of every particle that has none yet, from the current graph.
  void record_reference_eccentricity(State& s, const InteractionGraph& g) const;
  /// sintered_neck: Result::necks from the current graph.
  void record_network_necks(const State& s, const InteractionGraph& g);
  /// Bulk conductivity per particle [S/m]: at `temperature`, or at its `temperature` field value.
  std::vector<double> particle_conductivities(const State& s) const;
  Params p_;
  double kappa_ = 0.0;               ///< bulk conductivity at the evaluation temperature [S/m]
  electrical::ConductivityLaw law_;  ///< kappa(T)
  BranchModel branch_;
  bool tolerance_restored_ = false;  // visit() read the resolved touch tolerance: bind() keeps it
  Clock default_clock_;
  LaplacianSolver solver_;
  Result r_;
  EdgeOutput edges_;  ///< held per-branch results of the last solve (particle-centred only)
};

}  // namespace sparkdem::physics
