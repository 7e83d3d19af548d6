#pragma once
/// Branch models of the particle networks: one conductance per edge of the interaction graph
/// from its geometry and a bulk conductivity. Shared by the electrical network (kappa [S/m],
/// conductance [S]) and heat conduction (lambda [W/(m K)], conductance [W/K]): the same
/// geometric models serve both (seed 001 §2.3 uses the transmission surface for both; seed 000's
/// hemisphere law comes from the thermal "pipe network" model, sintering-electrical.md §2.4).
/// The kernels and their equations are in physics/electrical/conductance_kernels.hpp:
///
///   holm                  G = 2 a k (Holm; for heat the Batchelor-O'Brien contact conductance
///                         2 k a), a = Hertz sqrt(R* delta) or the lens radius; a neck or a bond
///                         with a radius uses it; a wall contact a = sqrt(r delta)
///   sintered_neck         hemispheres in series with the grain-boundary layer (Eq. 17-26)
///   transmission_surface  G = k sqrt(S_i S_j) / l_ij (seed 001 Eq. 2-5)
///   touching, tunnelling  unit conductances (seed 002; electrical only in practice)
///
/// Conductivity per edge: `k_edge[e]` (e.g. the bulk value at the pair's mean temperature). The
/// share of the branch RESISTANCE that lies on side a (its half-particle, and half of any
/// contact layer) is returned per edge for the Joule split; NaN when the whole resistance is at
/// the contact (touching, tunnelling), 0.5 when the model is symmetric.
#include <string>
#include <vector>

#include "engine/graph/interaction_graph.hpp"
#include "engine/state/state.hpp"

namespace sparkdem::physics {

struct BranchModel {
  std::string model = "holm";            ///< holm, sintered_neck, transmission_surface, touching, tunnelling
  std::string contact_radius = "hertz";  ///< holm: hertz or geometric
  std::string neck = "law";              ///< sintered_neck: law, coble, cv
  std::string hemisphere = "reading_a";  ///< sintered_neck: reading_a/b/c, fe_table
  double gb_epsilon = 1.0;               ///< sintered_neck: layer conductivity ratio [-]
  double gb_thickness = 0.0;             ///< sintered_neck: layer thickness [m] (0: none)
  bool gbf_correction = true;            ///< sintered_neck: grain-boundary-fraction correction
  double alpha_constant = 0.0;           ///< transmission_surface: fixed alpha (0: alpha(n), f(e))
  double touch_tolerance = 0.0;          ///< [m] gap up to which a pair counts as touching
  double unit_conductance = 1.0;         ///< touching/tunnelling [S]
  double tunnel_g0 = 1.0;                ///< [S]
  double tunnel_length = 1e-9;           ///< [m]
  double tunnel_cutoff = 0.0;            ///< [m]
  /// touching/tunnelling: a per-particle displacement field [m] (3 components, e.g.
  /// ptc_displacement of ptc_self_heating) added to the geometry, linearised: the gap of a
  /// particle pair becomes gap + n . (u_b - u_a), n the unit vector from a to b ("" = none).
  std::string displacement_field;
  /// touching: conductance [S] of a pair of the graph that does not touch (after the
  /// displacement), e.g. the polymer film of an opened filler contact (0: none).
  double open_conductance = 0.0;
  /// transmission_surface: per-particle eccentricity e_i [1] of a reference state (nullptr: e_i
  /// from the current positions and edges).
  const std::vector<double>* eccentricity = nullptr;
};

/// Conductance per graph edge; `share_a` receives the resistance share of side a per edge.
/// `k_edge` has one bulk conductivity per edge (> 0). Throws ConfigError (from the kernels) on
/// invalid geometry or parameters.
std::vector<double> branch_conductances(const BranchModel& m, const State& s, const InteractionGraph& g, const std::vector<double>& k_edge,
                                        std::vector<double>& share_a);

/// sintered_neck: the neck radius [m] per graph edge (0: no neck): the contact law's neck column
/// (neck = law) or Coble / constant volume from the overlap, capped at r_min, then the
/// grain-boundary-fraction correction (Eqs. 21-25) when enabled.
std::vector<double> sintered_neck_radii(const BranchModel& m, const State& s, const InteractionGraph& g);

/// sintered_neck: the necks the network conducts through, between particles (after Eqs. 21-25,
/// as sintered_neck_radii), as x = a / r_min per neck, and the share of the particles with a neck
/// whose grain-boundary fraction binds (Eq. 25: alpha_i = 2 r_i / sqrt(sum a^2) < 1 on the
/// uncorrected necks; reported whether or not the correction is on). Issue 59: seed 000's Fig. 6
/// histogram on the necks the network uses.
struct NetworkNecks {
  std::vector<double> ratios;  ///< a / r_min [1]
  double bound_share = 0.0;    ///< [1]; NaN without necks
};
NetworkNecks network_necks(const BranchModel& m, const State& s, const InteractionGraph& g);

/// sintered_neck: the half-particle conductance [S] of the model's hemisphere law (Eqs. 19-20).
double hemisphere_access_conductance(const BranchModel& m, double kappa_S_per_m, double r_m, double a_m);

/// sintered_neck: the grain-boundary layer's conductance [S] (Eq. 26); +inf without a layer.
double layer_conductance(const BranchModel& m, double kappa_S_per_m, double a_m);

/// The near-pair gap the model needs in the interaction graph (tunnelling cut-off, touching
/// tolerance, 0 otherwise).
double branch_model_near_gap(const BranchModel& m);

/// `touch_tolerance_relative` [1] > 0: sets m.touch_tolerance [m] to that fraction of the mean
/// particle radius of `s` (the neighbour gap tolerance of seed 001's packings, stated relative to
/// r_mean so that it means the same at every N); <= 0 leaves m.touch_tolerance as configured.
void resolve_touch_tolerance(BranchModel& m, double touch_tolerance_relative, const State& s);

}  // namespace sparkdem::physics
