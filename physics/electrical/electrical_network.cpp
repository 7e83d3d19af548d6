#include "physics/electrical/electrical_network.hpp"

#include <algorithm>
#include <unordered_map>
#include <chrono>
#include <cmath>
#include <limits>

#include "engine/core/error.hpp"
#include "engine/state/state.hpp"
#include "physics/electrical/branch_models.hpp"
#include "physics/electrical/conductance_kernels.hpp"
#include "physics/electrical/sphere_element.hpp"
#include "physics/packing/neck_statistics.hpp"
#include "engine/core/numbers.hpp"

namespace sparkdem::physics {

namespace el = electrical;

namespace {


bool is_wall_electrode(const std::string& e) { return e.rfind("wall:", 0) == 0; }

/// Nodes of one electrode: the particles of a set, or a wall node.
std::vector<Index> electrode_nodes(const State& s, const InteractionGraph& g, const std::string& e, bool allow_empty = false) {
  std::vector<Index> out;
  if (is_wall_electrode(e)) {
    const std::string w = e.substr(5);
    for (std::size_t k = 0; k < s.walls.size(); ++k)
      if (s.walls[k].name == w) out.push_back(g.wall_node(k));
    if (out.empty()) throw SetupError("electrical_network: electrode '" + e + "': no wall named '" + w + "'");
    return out;
  }
  if (!s.particles.fields.has("set/" + e))
    throw SetupError("electrical_network: electrode '" + e + "' is neither a particle set of this stage (\"sets\") nor \"wall:<name>\"");
  const auto& f = s.particles.fields.data("set/" + e);
  for (std::size_t i = 0; i < f.size(); ++i)
    if (f[i] > 0.5) out.push_back(static_cast<Index>(i));
  if (out.empty() && !allow_empty)
    throw SetupError("electrical_network: electrode set '" + e +
                     "' holds no particle (empty_electrode: \"open\" reads it as an open circuit)");
  return out;
}

/// True if some branch path (edges with g > 0) joins a node of `high` to a node of `low`.
bool spanning(std::size_t nodes, const std::vector<Index>& ea, const std::vector<Index>& eb, const std::vector<double>& g,
              const std::vector<Index>& high, const std::vector<Index>& low) {
  const std::vector<Index> root = component_roots(nodes, ea, eb, g);
  std::vector<char> high_root(nodes, 0);
  for (Index v : high) high_root[root[v]] = 1;
  for (Index v : low)
    if (high_root[root[v]]) return true;
  return false;
}

/// The resistor network actually solved: nodes, resistors and which particle each resistor
/// heats (its dissipation is split between heat_a and heat_b by `share`; -1 = not a particle).
/// Empty heat_a and heat_b: each resistor heats its own ends, a node below `particles` being
/// that particle and any other none (the particle-centred net, whose nodes are the graph's).
struct ResistorNet {
  std::size_t nodes = 0;
  std::vector<Index> a, b, heat_a, heat_b;
  std::vector<double> g;
  std::vector<double> share;  ///< share of the resistor's dissipation that heats heat_a (the rest heats heat_b)
  std::vector<Index> high, low;
  std::size_t particles = 0;  ///< with empty heat_a / heat_b: the nodes that are particles
  Index heated_a(std::size_t e) const { return heat_a.empty() ? own_heat(a[e]) : heat_a[e]; }
  Index heated_b(std::size_t e) const { return heat_b.empty() ? own_heat(b[e]) : heat_b[e]; }
  Index own_heat(Index v) const { return static_cast<std::size_t>(v) < particles ? v : Index{-1}; }
  void add(Index x, Index y, double gxy, Index ha, Index hb, double share_a = 0.5) {
    a.push_back(x);
    b.push_back(y);
    g.push_back(gxy);
    heat_a.push_back(ha);
    heat_b.push_back(hb);
    share.push_back(share_a);
  }
};

/// Contact point of graph edge e as seen from particle `i` (one of its ends): on the centre
/// line at the radical-plane distance for spheres, the foot of the particle on a wall.
Vec3 contact_point(const State& s, const InteractionGraph& g, std::size_t e, Index i) {
  const auto& p = s.particles;
  const Index j = g.a[e] == i ? g.b[e] : g.a[e];
  if (g.is_wall_node(j)) {
    Vec3 n;
    double d;
    s.walls[static_cast<std::size_t>(j) - g.particle_nodes].distance(p.position[i], n, d);
    return p.position[i] - d * n;
  }
  const Vec3 dx = p.position[j] - p.position[i];
  const double D = dx.norm();
  if (!(D > 0.0)) return p.position[i];
  const double ri = p.radius[i], rj = p.radius[j];
  const double di = std::clamp((D * D + ri * ri - rj * rj) / (2.0 * D), 0.0, D);
  return p.position[i] + dx * (di / D);
}

/// Extent of the particles along the unit vector e, surfaces included: max(x.e + r) - min(x.e - r) [m].
double extent_along(const ParticleStore& p, const Vec3& e) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double z = p.position[i].dot(e);
    lo = std::min(lo, z - p.radius[i]);
    hi = std::max(hi, z + p.radius[i]);
  }
  return hi - lo;
}

Vec3 centroid(const State& s, const std::vector<Index>& nodes) {
  Vec3 c = Vec3::Zero();
  for (Index i : nodes) c += s.particles.position[i];
  return c / static_cast<double>(nodes.size());
}

}  // namespace

ParamSpec<ElectricalNetwork::Params> ElectricalNetwork::spec() {
  using P = Params;
  ParamSpec<P> s("electrical_network", "module",
                 "steady DC resistor network on the interaction graph: potentials, currents, resistance, effective conductivity");
  s.add("topology", &P::topology)
      .choices({"particle_centred", "contact_centred", "sphere_element"})
      .doc(
          "nodes at particle centres; at contact points with resistors through each particle between its contacts (seed 003); or "
          "(sintered_neck) at the necks, each particle a multi-terminal sphere element whose necks share its volume "
          "(physics/electrical/sphere_element.hpp)");
  s.add("element_cap", &P::element_cap)
      .choices({"equal_area", "rim"})
      .doc(
          "sphere_element: a neck's cap on the sphere has the neck's area (default) or its rim radius "
          "(physics/electrical/sphere_element.hpp)");
  s.add("chord_scaling", &P::chord_scaling).doc("contact_centred: scale each intra-particle resistor by chord / (path through the centre)");
  s.add("model", &P::model)
      .choices({"holm", "sintered_neck", "transmission_surface", "touching", "tunnelling"})
      .doc("branch conductance model (physics/electrical/conductance_kernels.hpp)");
  s.add("conductivity", &P::conductivity).unit("S/m").positive().doc("bulk conductivity kappa at reference_temperature");
  s.add("temperature", &P::temperature)
      .unit("K")
      .positive()
      .doc("temperature at which the conductivity is evaluated (measurements of sintered samples are made cold)");
  s.add("reference_temperature", &P::reference_temperature).unit("K").positive().doc("T_ref of `conductivity`");
  s.add("resistivity_coefficient", &P::resistivity_coefficient)
      .unit("1/K")
      .doc("beta of the linear resistivity law kappa(T) = kappa / (1 + beta (T - T_ref)); 0: constant");
  s.add("conductivity_table_temperature", &P::conductivity_table_temperature)
      .unit("K")
      .doc(
          "tabulated kappa(T): temperatures, strictly increasing (>= 2 points; empty: the linear law). Replaces conductivity / "
          "resistivity_coefficient");
  s.add("conductivity_table_values", &P::conductivity_table_values)
      .unit("S/m")
      .doc("tabulated kappa(T): conductivities at conductivity_table_temperature (piecewise linear, constant beyond the ends)");
  s.add("temperature_field", &P::temperature_field)
      .doc(
          "evaluate kappa(T) per branch at the mean of its particles' `temperature` field (written by heat_conduction or "
          "temperature_history) instead of at `temperature`");
  s.add("resolve_temperature_change", &P::resolve_temperature_change)
      .unit("K")
      .positive()
      .doc("default clock with temperature_field: re-solve when a particle's temperature changed by more than this since the last solve");
  s.add("resolve_every", &P::resolve_every)
      .min(0)
      .doc("default clock: also re-solve every this many mechanical steps (0: only on the events)");
  s.add("voltage_signal", &P::voltage_signal)
      .doc("take the voltage from this signal at every solve (written by a controller, e.g. temperature_controller); \"\" = `voltage`");
  s.add("high", &P::high).doc("electrode held at `voltage`: a particle-set name or \"wall:<name>\"");
  s.add("low", &P::low).doc("electrode held at 0 V: a particle-set name or \"wall:<name>\"");
  s.add("empty_electrode", &P::empty_electrode)
      .choices({"error", "open"})
      .doc("an electrode set that holds no particle: a set-up error, or an open circuit (R = +inf; percolation ensembles)");
  s.add("voltage", &P::voltage).unit("V").positive().doc("potential difference between the electrodes");
  s.add("current", &P::current)
      .unit("A")
      .nonnegative()
      .doc("> 0: inject this current at `high` (one equipotential electrode) instead of holding the voltage; `low` stays at 0 V");
  s.add("length", &P::length)
      .unit("m")
      .nonnegative()
      .doc("L of kappa_eff = I L / (dV A); 0: distance between the electrodes' particle centroids");
  s.add("length_mode", &P::length_mode)
      .choices({"electrode_centroids", "sample_height"})
      .doc(
          "L when length = 0: the distance of the electrodes' particle centroids, or the sample height (Eq. 28 as "
          "written: the extent of the particles, surfaces included, along the axis from the low to the high electrode)");
  s.add("area", &P::area)
      .unit("m^2")
      .nonnegative()
      .doc("A of kappa_eff; 0: cross-section of the first cylinder wall (else kappa_eff is not reported)");
  s.add("branches", &P::branches)
      .choices({"all", "bonds"})
      .doc("all: contacts, necks and intact bonds conduct; bonds: only intact bonds (cohesive-beam solids, seed 001)");
  s.add("solver", &P::solver)
      .choices({"direct", "cg_ic", "cg_jacobi", "amg", "pseudo_transient"})
      .doc(
          "sparse Cholesky; CG with incomplete-Cholesky / Jacobi preconditioner; hypre BoomerAMG-PCG (all iterative ones warm-started); "
          "seed 000's pseudo-transient iteration");
  s.add("tolerance", &P::tolerance).unit("1").positive().doc("CG / AMG relative residual");
  s.add("amg_spread_min_rows", &P::amg_spread_min_rows)
      .unit("1")
      .positive()
      .doc(
          "amg on several MPI ranks: outside sweep stages, spread solves of at least this many unknowns over the ranks (README, network "
          "solves across MPI ranks)");
  s.add("specific_capacity", &P::specific_capacity).unit("F/kg").positive().doc("pseudo_transient: c in C_i = m_i c (numerical only)");
  s.add("pseudo_dt", &P::pseudo_dt)
      .unit("s")
      .nonnegative()
      .doc("pseudo_transient: pseudo time step (0: pseudo_dt_fraction x the true limit 2/lambda_max)");
  s.add("pseudo_dt_fraction", &P::pseudo_dt_fraction).unit("1").positive().doc("pseudo_transient: fraction of the true stability limit");
  s.add("beta", &P::beta).unit("1").positive().doc("pseudo_transient: stop when the change indicator (Eq. 14) falls below beta");
  s.add("indicator", &P::indicator)
      .choices({"range", "per_node"})
      .doc("pseudo_transient: Eq. 14 per node as printed, or normalised by the voltage (note §7.6)");
  s.add("allow_unstable", &P::allow_unstable)
      .doc("pseudo_transient: run a step above the true limit (divergence is then detected and stops the run)");
  s.add("resolve_distance", &P::resolve_distance)
      .unit("m")
      .nonnegative()
      .doc("default clock: re-solve when a particle moved this far (0: 0.05 x smallest radius)");
  s.add("contact_radius", &P::contact_radius)
      .choices({"hertz", "geometric"})
      .doc("holm: a = sqrt(R* delta) (Hertz) or the lens radius of the overlap");
  s.add("neck", &P::neck)
      .choices({"law", "coble", "cv"})
      .doc(
          "sintered_neck: neck radius from the contact law's neck_radius column (else Coble), or Coble / constant volume from the overlap");
  s.add("hemisphere", &P::hemisphere)
      .choices({"reading_a", "reading_b", "reading_c", "fe_table"})
      .doc("sintered_neck: hemisphere law of Eq. 19 (see conductance_kernels.hpp)");
  s.add("gb_epsilon", &P::gb_epsilon).unit("1").positive().doc("sintered_neck: conductivity ratio of the grain-boundary layer (Eq. 26)");
  s.add("gb_thickness", &P::gb_thickness)
      .unit("m")
      .nonnegative()
      .doc("sintered_neck: grain-boundary layer thickness delta_gb (0: no layer)");
  s.add("gbf_correction", &P::gbf_correction).doc("sintered_neck: grain-boundary-fraction correction of the necks (Eq. 22-25)");
  s.add("resistivity", &P::resistivity).unit("Ohm m").nonnegative().doc("transmission_surface: rho_e (0: 1/conductivity)");
  s.add("alpha_constant", &P::alpha_constant)
      .unit("1")
      .nonnegative()
      .doc("transmission_surface: hold alpha fixed and f(e) = 1 (0: the alpha(n), f(e) model)");
  s.add("eccentricity", &P::eccentricity)
      .choices({"current", "reference"})
      .doc("transmission_surface: e_i of Eq. 3 from the positions of each solve, or of the first solve (kept in the "
           "particle field electrical_eccentricity_reference: elastic strain does not flip f(e) at e = 0.4)");
  s.add("unit_conductance", &P::unit_conductance).unit("S").positive().doc("touching / tunnelling: conductance of a touching pair");
  s.add("touch_tolerance", &P::touch_tolerance)
      .unit("m")
      .nonnegative()
      .doc("touching, transmission_surface: pairs with a gap up to this count as touching branches");
  s.add("touch_tolerance_relative", &P::touch_tolerance_relative)
      .unit("1")
      .nonnegative()
      .doc(
          "touching, transmission_surface: the gap tolerance as a fraction of the mean particle radius at the stage start (> 0 overrides "
          "touch_tolerance; kept in the checkpoint)");
  s.add("tunnel_g0", &P::tunnel_g0).unit("S").positive().doc("tunnelling: prefactor g0");
  s.add("tunnel_length", &P::tunnel_length).unit("m").positive().doc("tunnelling: decay length xi");
  s.add("tunnel_cutoff", &P::tunnel_cutoff).unit("m").nonnegative().doc("tunnelling: largest gap that conducts");
  s.add("displacement_field", &P::displacement_field)
      .doc(
          "touching, tunnelling: 3-component particle field of displacements [m] added (linearised) to the pair gaps, e.g. "
          "ptc_displacement of ptc_self_heating; \"\" = none");
  s.add("open_conductance", &P::open_conductance)
      .unit("S")
      .nonnegative()
      .doc(
          "touching: conductance of a pair of the graph whose gap after the displacement exceeds touch_tolerance (an opened contact's "
          "polymer film); 0 = none");
  return s;
}

ElectricalNetwork::ElectricalNetwork(const Params& p) : p_(p) {
  const bool tabulated = !p.conductivity_table_temperature.empty() || !p.conductivity_table_values.empty();
  try {
    if (tabulated) {
      if (p.conductivity_table_temperature.size() != p.conductivity_table_values.size())
        throw ConfigError("", "expected as many conductivities as temperatures, found " + std::to_string(p.conductivity_table_values.size()) +
                                  " and " + std::to_string(p.conductivity_table_temperature.size()));
      law_ = el::ConductivityTable(p.conductivity_table_temperature, p.conductivity_table_values);
    } else {
      law_ = el::LinearResistivityLaw{p.conductivity, p.resistivity_coefficient, p.reference_temperature};
    }
    kappa_ = el::conductivity(law_, p.temperature);
  } catch (const ConfigError& e) {
    const std::string why = e.diagnostics().empty() ? e.what() : e.diagnostics().front().message;
    throw ConfigError(tabulated ? "/conductivity_table_values" : "/resistivity_coefficient",
                      "kappa(T) at the evaluation temperature: " + why);
  }
  branch_ = BranchModel{p.model,        p.contact_radius, p.neck,           p.hemisphere,         p.gb_epsilon,
                        p.gb_thickness, p.gbf_correction, p.alpha_constant, p.touch_tolerance,    p.unit_conductance,
                        p.tunnel_g0,    p.tunnel_length,  p.tunnel_cutoff,  p.displacement_field, p.open_conductance};
  if (p.eccentricity == "reference" && (p.model != "transmission_surface" || p.alpha_constant > 0.0))
    throw ConfigError("/eccentricity", "a reference eccentricity needs model transmission_surface with alpha(n), f(e) "
                                       "(alpha_constant 0), found model '" + p.model + "'");
  if (!p.displacement_field.empty() && p.model != "touching" && p.model != "tunnelling")
    throw ConfigError("/displacement_field", "a displacement field needs model touching or tunnelling, found '" + p.model + "'");
  LaplacianOptions o;
  o.method = p.solver == "cg_ic"              ? LaplacianMethod::CgIncompleteCholesky
             : p.solver == "cg_jacobi"        ? LaplacianMethod::CgDiagonal
             : p.solver == "amg"              ? LaplacianMethod::Amg
             : p.solver == "pseudo_transient" ? LaplacianMethod::PseudoTransient
                                              : LaplacianMethod::Direct;
  o.tolerance = p.tolerance;
  o.amg_spread_min_rows = static_cast<std::int64_t>(p.amg_spread_min_rows);
  o.pseudo.dt = p.pseudo_dt;
  o.pseudo.dt_fraction = p.pseudo_dt_fraction;
  o.pseudo.beta = p.beta;
  o.pseudo.indicator = p.indicator == "per_node" ? ChangeIndicator::PerNode : ChangeIndicator::Range;
  o.pseudo.allow_unstable = p.allow_unstable;
  solver_.set_options(o);
}

void ElectricalNetwork::declare(Declarations& d) const {
  d.particle_fields.push_back({"electric_potential", 1, "V", 0.0, true, FieldCheck::NotInfinite});  // NaN: floating
  d.particle_fields.push_back({"joule_power", 1, "W", 0.0, true, FieldCheck::Finite});
  d.particle_fields.push_back({kParticleCurrentField, 1, "A", 0.0, true, FieldCheck::None});
  // Geometry and temperature as they were at the end of the previous step (or as earlier modules
  // of this step left them): a feedback loop with heat_conduction, which reads this step's
  // joule_power and writes the temperature and the expanded radii, is not an ordering cycle.
  if (reference_eccentricity()) d.particle_fields.push_back({kEccentricityField, 1, "1", -1.0, true, FieldCheck::None});
  d.reads_previous = {"position", "radius"};
  if (p_.temperature_field) d.reads_previous.push_back("temperature");
  if (!p_.displacement_field.empty()) d.reads.push_back(p_.displacement_field);
  d.writes = {"electric_potential", "joule_power", kParticleCurrentField, "signal/electrical_resistance"};
  if (reference_eccentricity()) d.writes.push_back(kEccentricityField);
  if (!p_.voltage_signal.empty()) d.reads.push_back("signal/" + p_.voltage_signal);
}

void ElectricalNetwork::bind(State& s) {
  if (!tolerance_restored_) resolve_touch_tolerance(branch_, p_.touch_tolerance_relative, s);
  tolerance_restored_ = false;
  double rmin = kInf;
  for (double r : s.particles.radius) rmin = std::min(rmin, r);
  default_clock_ = Clock{};
  default_clock_.kind = Clock::Kind::OnEvent;
  default_clock_.trigger.bond_broke = true;
  default_clock_.trigger.moved_beyond = p_.resolve_distance > 0.0 ? p_.resolve_distance : std::isfinite(rmin) ? 0.05 * rmin : 1.0;
  if (p_.temperature_field) {
    default_clock_.trigger.field = "temperature";
    default_clock_.trigger.field_change = p_.resolve_temperature_change;
  }
  default_clock_.trigger.max_interval = p_.resolve_every;
  if (!p_.displacement_field.empty()) default_clock_ = Clock{};  // the displacements change every step: solve every step
  if (p_.model == "transmission_surface" && (is_wall_electrode(p_.high) || is_wall_electrode(p_.low)))
    throw SetupError("electrical_network: the transmission_surface model takes particle-set electrodes, not walls");
}

std::vector<double> ElectricalNetwork::conductances(const State& s, const InteractionGraph& g, std::vector<double>& share_a) const {
  // Bulk conductivity per branch: at `temperature`, or at the mean temperature of the branch's
  // particles (a wall end takes its particle's) when temperature_field is set.
  std::vector<double> k(g.size(), kappa_);
  if (p_.temperature_field) {
    const auto& T = s.particles.fields.data("temperature");
    for (std::size_t e = 0; e < g.size(); ++e) {
      const double ta = T[g.a[e]], tb = g.is_wall_node(g.b[e]) ? ta : T[g.b[e]];
      k[e] = el::conductivity(law_, 0.5 * (ta + tb));
    }
  }
  // transmission_surface with `resistivity`: rho_e(T) = resistivity * kappa_ref / kappa(T).
  if (p_.model == "transmission_surface" && p_.resistivity > 0.0)
    for (double& x : k) x /= p_.resistivity * p_.conductivity;
  if (!reference_eccentricity()) return branch_conductances(branch_, s, g, k, share_a);
  BranchModel m = branch_;
  m.eccentricity = &s.particles.fields.data(kEccentricityField);
  return branch_conductances(m, s, g, k, share_a);
}

void ElectricalNetwork::record_reference_eccentricity(State& s, const InteractionGraph& g) const {
  if (!reference_eccentricity()) return;
  auto& e0 = s.particles.fields.data(kEccentricityField);
  std::vector<double> e;  // the current eccentricities, computed only when a particle has none yet
  for (std::size_t i = 0; i < e0.size(); ++i)
    if (e0[i] < 0.0) {
      if (e.empty()) e = el::eccentricities(s.particles.position, s.particles.radius, g.a, g.b);
      e0[i] = e[i];
    }
}

void ElectricalNetwork::record_network_necks(const State& s, const InteractionGraph& g) {
  NetworkNecks n = network_necks(branch_, s, g);
  const NeckStatistics st = neck_statistics(std::move(n.ratios), 10);  // Fig. 6: 10 bins on [0, 1]
  r_.necks = {st.necks, st.median, st.max_bin_percent, st.last_bin_percent, n.bound_share};
}

std::vector<double> ElectricalNetwork::particle_conductivities(const State& s) const {
  std::vector<double> k(s.particles.size(), kappa_);
  if (p_.temperature_field) {
    const auto& T = s.particles.fields.data("temperature");
    for (std::size_t i = 0; i < k.size(); ++i) k[i] = el::conductivity(law_, T[i]);
  }
  return k;
}

namespace {

using Params = ElectricalNetwork::Params;
using Result = ElectricalNetwork::Result;

/// The network of one solve. Contact-centred: centre[v] is the node kept at the centre of an
/// electrode particle v (-1 elsewhere) and star[v] its (contact node, access conductance) pairs.
struct BuiltNet {
  ResistorNet net;
  std::vector<Index> centre;
  std::vector<std::vector<std::pair<Index, double>>> star;
};

/// Particle of a graph node (the side a branch's dissipation heats); -1 for a wall node.
Index particle_of(const InteractionGraph& g, Index v) { return g.is_wall_node(v) ? Index{-1} : v; }

/// Particle-centred: a node per graph node, a resistor per branch. Joule split: each side is
/// heated by the part of the branch resistance on its side (its half-particle and half of any
/// contact layer; a one-resistance branch half-half).
/// The graph's end points, conductances and shares move into the net (held once).
BuiltNet particle_centred_net(InteractionGraph& g, std::vector<double>& G, std::vector<double>& share, const std::vector<Index>& high,
                              const std::vector<Index>& low) {
  BuiltNet b;
  b.centre.assign(g.nodes(), -1);
  b.net.nodes = g.nodes();
  b.net.particles = g.particle_nodes;  // a wall node heats no particle
  for (double& x : share)
    if (!std::isfinite(x)) x = 0.5;
  b.net.a = std::move(g.a);
  b.net.b = std::move(g.b);
  b.net.g = std::move(G);
  b.net.share = std::move(share);
  b.net.high = high;
  b.net.low = low;
  return b;
}

/// Contact-centred: a node at each conducting contact; a particle's resistance between two of
/// its contacts p, q is the star-mesh transform of its access resistances R_i(p) (the branch
/// model's share of side i), g_pq = g_p g_q / sum_k g_k, times the path-length factor
/// (|x_p - x_i| + |x_q - x_i|) / |x_p - x_q| >= 1 (chord_scaling): current turning near the
/// edge of a particle takes the chord, not the way through the centre. Without the factor it
/// is exactly the particle-centred network (star-mesh theorem); on a straight chain the
/// factor is 1, so both topologies agree there. Electrode particles keep a centre node and
/// their star.
BuiltNet contact_centred_net(const State& s, const InteractionGraph& g, const std::vector<double>& G, const std::vector<double>& share,
                             const std::vector<Index>& high, const std::vector<Index>& low, const Params& p) {
  BuiltNet b;
  ResistorNet& net = b.net;
  b.centre.assign(g.nodes(), -1);
  b.star.assign(g.nodes(), {});
  for (std::size_t e = 0; e < g.size(); ++e) {
    if (!(G[e] > 0.0)) continue;
    if (!std::isfinite(share[e]))
      throw SetupError(
          "electrical_network: the contact_centred topology needs a model with resistance inside the particles (holm, sintered_neck, "
          "transmission_surface), not '" +
          p.model + "'");
    const Index c = static_cast<Index>(net.nodes++);
    const double Ra = share[e] / G[e], Rb = (1.0 - share[e]) / G[e];
    b.star[g.a[e]].push_back({c, Ra > 0.0 ? 1.0 / Ra : kInf});
    b.star[g.b[e]].push_back({c, Rb > 0.0 ? 1.0 / Rb : kInf});
  }
  std::vector<char> keeps(g.nodes(), 0);
  for (Index v : high) keeps[v] = 1;
  for (Index v : low) keeps[v] = 1;
  for (std::size_t v = 0; v < g.nodes(); ++v) {
    if (!keeps[v]) continue;
    b.centre[v] = static_cast<Index>(net.nodes++);
    const Index pv = particle_of(g, static_cast<Index>(v));
    for (const auto& [c, gc] : b.star[v]) net.add(b.centre[v], c, gc, pv, pv);
  }
  for (Index v : high) net.high.push_back(b.centre[v]);
  for (Index v : low) net.low.push_back(b.centre[v]);
  // Contact positions per node (for the chord factor).
  std::vector<Vec3> xc(net.nodes, Vec3::Zero());
  for (std::size_t e = 0, c = 0; e < g.size(); ++e)
    if (G[e] > 0.0) xc[c++] = contact_point(s, g, e, g.is_wall_node(g.a[e]) ? g.b[e] : g.a[e]);
  for (std::size_t v = 0; v < s.particles.size(); ++v) {
    if (keeps[v]) continue;
    const auto& st = b.star[v];
    double sum = 0.0;
    for (const auto& [c, gc] : st) sum += gc;
    const Vec3& xi = s.particles.position[v];
    for (std::size_t x = 0; x < st.size(); ++x)
      for (std::size_t y = x + 1; y < st.size(); ++y) {
        double f = 1.0;
        if (p.chord_scaling) {
          const double arms = (xc[st[x].first] - xi).norm() + (xc[st[y].first] - xi).norm();
          const double chord = (xc[st[x].first] - xc[st[y].first]).norm();
          f = arms > 0.0 ? arms / std::max(chord, 1e-6 * arms) : 1.0;  // capped at 1e6
        }
        net.add(st[x].first, st[y].first, st[x].second * st[y].second / sum * f, static_cast<Index>(v), static_cast<Index>(v));
      }
  }
  return b;
}

/// Sphere-element topology (sintered_neck): a node at each neck (two, joined by the grain-boundary
/// layer's conductance K_c (Eq. 26), when the layer is on); each particle joins its necks by its
/// sphere element (physics/electrical/sphere_element.hpp), one resistor per pair of necks p, q
/// with conductance -K_pq. An element entry K_pq > 0 (between far patches) is a NEGATIVE
/// conductance and is kept: the element is positive semi-definite, not an M-matrix, and dropping
/// those entries raises the simple cubic lattice's conductivity by 15-25 % at a/r = 0.77-0.82
/// (issue 21). `negative` returns the sum of the negative conductances over the positive ones.
/// Electrode particles keep a centre node joined to their necks by the hemisphere law
/// (Eqs. 19-20: the paper's model where the particle is held at the electrode potential). Joule
/// heat: all resistors of an element heat its particle (their sum is the element's dissipation
/// V^T K V >= 0), the layer both halves. star[v] holds each particle's (neck node, cap area
/// weight) for its mean potential.
BuiltNet sphere_element_net(const State& s, const InteractionGraph& g, const BranchModel& m, const std::vector<double>& k_particle,
                            const std::vector<Index>& high, const std::vector<Index>& low, el::CapRule cap, double& negative) {
  if (m.model != "sintered_neck")
    throw SetupError("electrical_network: the sphere_element topology needs model sintered_neck, not '" + m.model + "'");
  const auto& P = s.particles;
  const std::vector<double> a = sintered_neck_radii(m, s, g);
  BuiltNet b;
  ResistorNet& net = b.net;
  b.centre.assign(g.nodes(), -1);
  b.star.assign(g.nodes(), {});
  std::vector<std::vector<std::size_t>> necks(g.nodes());  // edges per particle
  std::vector<Index> node_a(g.size(), -1), node_b(g.size(), -1);
  for (std::size_t e = 0; e < g.size(); ++e) {
    if (!(a[e] > 0.0)) continue;
    if (g.is_wall_node(g.a[e]) || g.is_wall_node(g.b[e]))
      throw SetupError("electrical_network: the sphere_element topology takes particle-set electrodes, not walls");
    node_a[e] = node_b[e] = static_cast<Index>(net.nodes++);
    const double kc = layer_conductance(m, 0.5 * (k_particle[g.a[e]] + k_particle[g.b[e]]), a[e]);
    if (std::isfinite(kc)) {
      node_b[e] = static_cast<Index>(net.nodes++);
      net.add(node_a[e], node_b[e], kc, g.a[e], g.b[e]);
    }
    necks[g.a[e]].push_back(e);
    necks[g.b[e]].push_back(e);
  }
  std::vector<char> keeps(g.nodes(), 0);
  for (Index v : high) keeps[v] = 1;
  for (Index v : low) keeps[v] = 1;
  double positive = 0.0;
  negative = 0.0;
  for (std::size_t v = 0; v < P.size(); ++v) {
    const auto& nv = necks[v];
    const double r = P.radius[v];
    std::vector<Vec3> u(nv.size());
    std::vector<double> alpha(nv.size());
    std::vector<Index> node(nv.size());
    for (std::size_t k = 0; k < nv.size(); ++k) {
      const std::size_t e = nv[k];
      const bool side_a = g.a[e] == static_cast<Index>(v);
      u[k] = (P.position[side_a ? g.b[e] : g.a[e]] - P.position[v]).normalized();
      alpha[k] = el::cap_half_angle(a[e], r, cap);
      node[k] = side_a ? node_a[e] : node_b[e];
      b.star[v].push_back({node[k], 1.0 - std::cos(alpha[k])});
    }
    if (keeps[v]) {
      b.centre[v] = static_cast<Index>(net.nodes++);
      for (std::size_t k = 0; k < nv.size(); ++k)
        net.add(b.centre[v], node[k], hemisphere_access_conductance(m, k_particle[v], r, a[nv[k]]), static_cast<Index>(v),
                static_cast<Index>(v));
      continue;
    }
    const Eigen::MatrixXd K = el::sphere_patch_conductance(k_particle[v], r, u, alpha);
    for (std::size_t x = 0; x < nv.size(); ++x)
      for (std::size_t y = x + 1; y < nv.size(); ++y) {
        const double gxy = -K(static_cast<Eigen::Index>(x), static_cast<Eigen::Index>(y));
        if (gxy == 0.0) continue;
        net.add(node[x], node[y], gxy, static_cast<Index>(v), static_cast<Index>(v));
        (gxy > 0.0 ? positive : negative) += std::abs(gxy);
      }
  }
  for (Index v : high) net.high.push_back(b.centre[v]);
  for (Index v : low) net.low.push_back(b.centre[v]);
  negative = positive > 0.0 ? negative / positive : 0.0;
  return b;
}

/// Applied voltage [V]: the parameter, or the controller's signal.
double applied_voltage(const State& s, const Params& p, Step step) {
  double applied = p.voltage;
  if (!p.voltage_signal.empty()) {
    const auto it = s.marks.find("signal/" + p.voltage_signal);
    if (it != s.marks.end()) applied = it->second;
    if (!(applied >= 0.0) || !std::isfinite(applied))
      throw PhysicsError(step, {}, "voltage",
                         "electrical_network: the voltage signal '" + p.voltage_signal + "' is " + std::to_string(applied));
  }
  return applied;
}

/// One solve of the network. Current-driven (p.current > 0): the high electrode is one
/// equipotential node `super` fed with `current`, the low one grounded; edge_g are the solved
/// conductances (0 inside the merged electrode). Otherwise both electrodes are held at their
/// potentials; the network is linear, so a zero voltage is solved at 1 V and scaled by 0 (the
/// resistance stays known: a controller needs it). unit_resistance = dV / I of the solve.
struct NetSolution {
  LaplacianResult res;
  std::vector<double> edge_g;
  Index super = 0;
  double unit_resistance = kInf;
};
NetSolution solve_net(const State& s, const ResistorNet& net, const Params& p, double applied, Step step, LaplacianSolver& solver) {
  NetSolution out;
  const bool driven = p.current > 0.0;
  const double solved_voltage = applied > 0.0 ? applied : 1.0;
  out.super = net.high.front();
  out.edge_g = net.g;
  LaplacianProblem prob;
  prob.nodes = net.nodes;
  std::vector<Index> ma, mb;  // driven: the ends with the high electrode merged into one node
  std::vector<double> source;
  if (driven) {
    ma = net.a;
    mb = net.b;
    std::vector<char> in_high(net.nodes, 0);
    for (Index v : net.high) in_high[v] = 1;
    for (std::size_t e = 0; e < out.edge_g.size(); ++e) {
      if (in_high[ma[e]]) ma[e] = out.super;
      if (in_high[mb[e]]) mb[e] = out.super;
      if (ma[e] == mb[e]) out.edge_g[e] = 0.0;  // inside the electrode: carries nothing
    }
    source.assign(net.nodes, 0.0);
    source[out.super] = p.current;
    prob.source = source;
    prob.dirichlet = {DirichletGroup{net.low, 0.0}};
  } else {
    prob.dirichlet = {DirichletGroup{net.high, solved_voltage}, DirichletGroup{net.low, 0.0}};
  }
  prob.a = driven ? std::span<const Index>(ma) : std::span<const Index>(net.a);
  prob.b = driven ? std::span<const Index>(mb) : std::span<const Index>(net.b);
  prob.g = out.edge_g;
  prob.signed_conductances = p.topology == "sphere_element";
  prob.step = step;
  std::vector<double> cap;
  if (p.solver == "pseudo_transient") {
    if (p.topology != "particle_centred")
      throw SetupError("electrical_network: the pseudo_transient solver needs the particle_centred topology (C_i = m_i c per particle)");
    cap.assign(net.nodes, p.specific_capacity);  // wall nodes: 1 x c (they are electrodes, never free)
    for (std::size_t i = 0; i < s.particles.size(); ++i) cap[i] = s.particles.mass[i] * p.specific_capacity;
    prob.capacitance = cap;
  }
  out.res = solver.solve(prob);
  LaplacianResult& res = out.res;
  if (!driven && !res.dirichlet_flux.empty() && res.dirichlet_flux[0] > 0.0) out.unit_resistance = solved_voltage / res.dirichlet_flux[0];
  if (!driven && applied != solved_voltage) {
    const double f = applied / solved_voltage;
    for (double& x : res.value)
      if (std::isfinite(x)) x *= f;
    for (double& x : res.flux) x *= f;
    for (double& x : res.dirichlet_flux) x *= f;
  }
  if (driven)
    for (Index v : net.high) res.value[v] = res.value[out.super];  // the merged electrode nodes
  return out;
}

/// Joule power per particle (q, zeroed first) from the branch currents, each branch's I^2 R split
/// by its share; returns the total [W].
double joule_power(const ResistorNet& net, const NetSolution& sol, std::vector<double>& q) {
  std::fill(q.begin(), q.end(), 0.0);
  double power = 0.0;
  for (std::size_t e = 0; e < sol.edge_g.size(); ++e) {
    if (sol.edge_g[e] == 0.0 || sol.res.flux[e] == 0.0) continue;
    const double pe = sol.res.flux[e] * sol.res.flux[e] / sol.edge_g[e];  // I^2 R (< 0 on a sphere element's negative entry)
    power += pe;
    if (const Index h = net.heated_a(e); h >= 0) q[h] += net.share[e] * pe;
    if (const Index h = net.heated_b(e); h >= 0) q[h] += (1.0 - net.share[e]) * pe;
  }
  return power;
}

/// Particle potentials u (contact-centred: the centre potential of the equivalent star where a
/// particle keeps no centre node); returns the count of floating (NaN) particles.
std::size_t particle_potentials(const BuiltNet& b, bool particle_centred, const LaplacianResult& res, std::vector<double>& u) {
  std::size_t floating = 0;
  for (std::size_t i = 0; i < u.size(); ++i) {
    if (particle_centred || b.centre[i] >= 0) {
      u[i] = res.value[particle_centred ? i : static_cast<std::size_t>(b.centre[i])];
    } else {
      double num = 0.0, den = 0.0;
      for (const auto& [c, gc] : b.star[i])
        if (std::isfinite(res.value[c])) {
          num += gc * res.value[c];
          den += gc;
        }
      u[i] = den > 0.0 ? num / den : kNaN;
    }
    if (std::isnan(u[i])) ++floating;
  }
  return floating;
}

/// Per-branch results of the particle-centred network (resistor e joins nodes a[e] and b[e]; a
/// node from `particle_nodes` on is a wall): ids of the two ends (a wall is -1 - wall index),
/// current from the first to the second [A], conductance [S], power [W] (contact-centred: the
/// fields, no branch).
EdgeOutput branch_output(const State& s, std::size_t particle_nodes, const std::vector<Index>& a, const std::vector<Index>& b,
                         const NetSolution& sol, bool spans, bool particle_centred) {
  EdgeOutput out{"electrical", {}, {{"current", "A", {}}, {"conductance", "S", {}}, {"power", "W", {}}}};
  if (!particle_centred) return out;
  const auto conducting = static_cast<std::size_t>(std::count_if(sol.edge_g.begin(), sol.edge_g.end(), [](double g) { return g > 0.0; }));
  out.pairs.reserve(2 * conducting);
  for (auto& f : out.fields) f.values.reserve(conducting);
  auto id_of = [&](Index v) {
    const auto u = static_cast<std::size_t>(v);
    return u >= particle_nodes ? -1 - static_cast<std::int64_t>(u - particle_nodes) : static_cast<std::int64_t>(s.particles.id[v]);
  };
  for (std::size_t e = 0; e < a.size(); ++e) {
    if (!(sol.edge_g[e] > 0.0)) continue;
    const double I_e = spans ? sol.res.flux[e] : 0.0;
    out.pairs.push_back(id_of(a[e]));
    out.pairs.push_back(id_of(b[e]));
    out.fields[0].values.push_back(I_e);
    out.fields[1].values.push_back(sol.edge_g[e]);
    out.fields[2].values.push_back(I_e * I_e / sol.edge_g[e]);
  }
  return out;
}

/// The current through each particle [A]: half the sum of |I| over everything it exchanges
/// current with, its branches of the particle-centred network (walls included) and, for a
/// particle of an electrode set, the electrode (|sum of its signed branch currents|, which
/// Kirchhoff's law makes round-off elsewhere); from the branch output's ids. NaN on the other
/// topologies (no branch per particle pair).
void particle_currents(const State& s, const EdgeOutput& edges, bool particle_centred, std::vector<double>& out) {
  std::fill(out.begin(), out.end(), particle_centred ? 0.0 : kNaN);
  if (!particle_centred || edges.pairs.empty()) return;
  std::unordered_map<std::int64_t, std::size_t> local;
  local.reserve(s.particles.size());
  for (std::size_t i = 0; i < s.particles.size(); ++i) local.emplace(static_cast<std::int64_t>(s.particles.id[i]), i);
  std::vector<double> net(out.size(), 0.0);  // current leaving each particle through its branches
  const std::vector<double>& current = edges.fields.at(0).values;  // from the first end to the second
  for (std::size_t k = 0; k < current.size(); ++k)
    for (int end = 0; end < 2; ++end) {
      const auto it = local.find(edges.pairs[2 * k + end]);
      if (it == local.end()) continue;
      out[it->second] += std::abs(current[k]);
      net[it->second] += end == 0 ? current[k] : -current[k];
    }
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = 0.5 * (out[i] + std::abs(net[i]));
}

/// Open-circuit results (no particle reaches an electrode, empty_electrode = "open").
void open_circuit(State& s, const Params& p, Result& r, EdgeOutput& edges) {
  auto& u = s.particles.fields.data("electric_potential");
  auto& q = s.particles.fields.data("joule_power");
  std::fill(u.begin(), u.end(), kNaN);
  std::fill(q.begin(), q.end(), 0.0);
  auto& through = s.particles.fields.data(ElectricalNetwork::kParticleCurrentField);
  std::fill(through.begin(), through.end(), 0.0);
  edges = EdgeOutput{};
  const double solves = r.solves;
  const std::vector<double> necks = r.necks;  // the graph's, recorded before the electrodes were found empty
  r = Result{};
  r.necks = necks;
  r.resistance = kInf;
  r.voltage = p.voltage;
  r.length = p.length > 0.0 ? p.length : kNaN;
  r.conductivity_eff = kNaN;
  r.floating = static_cast<double>(s.particles.size());
  r.solves = solves + 1.0;
  s.marks["signal/electrical_resistance"] = -1.0;
}

}  // namespace

void ElectricalNetwork::advance(State& s, const StepInfo& info) {
  const auto t0 = std::chrono::steady_clock::now();
  // The last solve's branch results are replaced below; released first, they are not held beside
  // this solve's graph, matrix and factorisation (40 B per branch at the run's peak).
  edges_ = EdgeOutput{};
  GraphOptions go;
  go.walls = is_wall_electrode(p_.high) || is_wall_electrode(p_.low);
  go.near_gap = branch_model_near_gap(branch_);
  go.contacts = p_.branches != "bonds";
  InteractionGraph g = build_interaction_graph(s, go);
  std::vector<double> G, share;
  try {  // the sphere-element topology builds its own conductances from the neck radii
    if (branch_.model == "sintered_neck") record_network_necks(s, g);
    record_reference_eccentricity(s, g);
    if (p_.topology != "sphere_element") G = conductances(s, g, share);
  } catch (const ConfigError& e) { throw PhysicsError(info.step, {}, "electrical conductance", e.what()); }
  const bool allow_empty = p_.empty_electrode == "open";
  const std::vector<Index> high = electrode_nodes(s, g, p_.high, allow_empty), low = electrode_nodes(s, g, p_.low, allow_empty);
  if (high.empty() || low.empty()) {
    // empty_electrode = "open": no particle reaches an electrode (e.g. an aggregate that does not
    // reach a face of the cpc_fillers box): no current can flow; open-circuit results.
    open_circuit(s, p_, r_, edges_);
    r_.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return;
  }
  for (Index v : high)
    if (std::find(low.begin(), low.end(), v) != low.end())
      throw SetupError("electrical_network: a particle belongs to both electrodes '" + p_.high + "' and '" + p_.low + "'");
  const bool particle_centred = p_.topology == "particle_centred";
  BuiltNet b;
  if (particle_centred)
    b = particle_centred_net(g, G, share, high, low);
  else if (p_.topology == "contact_centred")
    b = contact_centred_net(s, g, G, share, high, low, p_);
  else {
    try {  // the element kernels throw ConfigError on degenerate geometry (e.g. two necks in one direction)
      b = sphere_element_net(s, g, branch_, particle_conductivities(s), high, low,
                             p_.element_cap == "rim" ? el::CapRule::Rim : el::CapRule::EqualArea, r_.negative_share);
    } catch (const ConfigError& e) { throw PhysicsError(info.step, {}, "sphere element", e.what()); }
  }
  // The conductances and end points are the net's now; the graph is not read past this point.
  std::vector<double>().swap(G);
  std::vector<double>().swap(share);
  const std::size_t particle_nodes = g.particle_nodes;
  g = InteractionGraph{};
  const ResistorNet& net = b.net;
  const bool driven = p_.current > 0.0;
  const double applied = applied_voltage(s, p_, info.step);
  const NetSolution sol = solve_net(s, net, p_, applied, info.step, solver_);
  const LaplacianResult& res = sol.res;

  auto& q = s.particles.fields.data("joule_power");
  double power = joule_power(net, sol, q);
  const std::size_t floating = particle_potentials(b, particle_centred, res, s.particles.fields.data("electric_potential"));
  // No spanning path: exactly zero current (round-off in the equipotential halves is not current).
  const bool spans = spanning(net.nodes, net.a, net.b, net.g, net.high, net.low);
  if (!spans) {
    std::fill(q.begin(), q.end(), 0.0);
    power = 0.0;
  }
  // Past this point only the net's end points are read (the branch output's ids): the rest is
  // not held beside the branch output.
  const std::vector<Index> ends_a = std::move(b.net.a), ends_b = std::move(b.net.b);
  b = BuiltNet{};
  edges_ = branch_output(s, particle_nodes, ends_a, ends_b, sol, spans, particle_centred);
  particle_currents(s, edges_, particle_centred, s.particles.fields.data(kParticleCurrentField));
  if (driven && !spans)
    throw PhysicsError(info.step, {}, "electrical current",
                       "electrical_network: " + std::to_string(p_.current) + " A injected at '" + p_.high + "' has no path to '" + p_.low +
                           "' (the network is open)");
  const double I = !spans ? 0.0 : driven ? p_.current : res.dirichlet_flux[0];
  const double I_low = !spans ? 0.0 : driven ? res.dirichlet_flux[0] : res.dirichlet_flux[1];
  const double V = driven ? res.value[sol.super] : applied;
  r_.current = I;
  r_.voltage = V;
  r_.current_mismatch = I != 0.0 ? std::abs(I + I_low) / std::abs(I) : std::abs(I_low);
  r_.resistance = I > 0.0 ? V / I : (spans && !driven ? sol.unit_resistance : kInf);
  s.marks["signal/electrical_resistance"] = std::isfinite(r_.resistance) ? r_.resistance : -1.0;
  r_.power = power;
  r_.power_particles = 0.0;
  for (double x : q) r_.power_particles += x;
  r_.power_mismatch = I > 0.0 ? std::abs(power - V * I) / (V * I) : power;
  r_.residual = res.relative_residual;
  r_.floating = static_cast<double>(floating);
  r_.iterations = res.iterations;
  r_.amg_ranks = res.amg_ranks;
  // L and A of Eq. 28.
  double L = p_.length;
  if (!(L > 0.0) && !go.walls) {
    const Vec3 axis = centroid(s, high) - centroid(s, low);
    L = p_.length_mode == "sample_height" ? extent_along(s.particles, axis.normalized()) : axis.norm();
  }
  double A = p_.area;
  if (!(A > 0.0))
    for (const auto& w : s.walls)
      if (!w.is_plane()) {
        A = kPi * w.cylinder_radius() * w.cylinder_radius();
        break;
      }
  r_.length = L > 0.0 ? L : kNaN;
  r_.conductivity_eff = (L > 0.0 && A > 0.0) ? L / (r_.resistance * A) : kNaN;  // = I L / (dV A)
  r_.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r_.solves += 1.0;
}

std::vector<std::string> ElectricalNetwork::columns() const {
  std::vector<std::string> c = {
      "electrical_current",          "electrical_voltage",        "electrical_current_mismatch", "electrical_resistance",
      "electrical_conductivity_eff", "electrical_power",          "electrical_power_particles",  "electrical_power_mismatch",
      "electrical_residual",         "electrical_floating_nodes", "electrical_iterations",       "electrical_solve_time",
      "electrical_length",           "electrical_solves"};
  if (p_.topology == "sphere_element") c.push_back("electrical_negative_share");
  if (p_.solver == "amg") c.push_back("electrical_amg_ranks");
  if (branch_.model == "sintered_neck")
    c.insert(c.end(), {"network_necks", "network_neck_median_a_over_rmin", "network_neck_max_bin_percent",
                       "network_neck_last_bin_percent", "network_neck_gbf_bound_share"});
  return c;
}

std::vector<double> ElectricalNetwork::column_values(const State&) const {
  std::vector<double> v = {r_.current,    r_.voltage,         r_.current_mismatch, r_.resistance, r_.conductivity_eff,
                           r_.power,      r_.power_particles, r_.power_mismatch,   r_.residual,   r_.floating,
                           r_.iterations, r_.seconds,         r_.length,           r_.solves};
  if (p_.topology == "sphere_element") v.push_back(r_.negative_share);
  if (p_.solver == "amg") v.push_back(r_.amg_ranks);
  if (branch_.model == "sintered_neck") v.insert(v.end(), r_.necks.begin(), r_.necks.end());
  return v;
}

void ElectricalNetwork::visit(Archive& ar, const std::string& prefix) {
  // The held outputs (not the wall-clock solve time, which no result depends on) and the warm start.
  std::vector<double> held = {r_.current,        r_.current_mismatch, r_.resistance,     r_.conductivity_eff, r_.power,
                              r_.power_mismatch, r_.residual,         r_.floating,       r_.iterations,       r_.length,
                              r_.solves,         r_.voltage,          r_.power_particles};
  ar.visit(prefix + "/held", held);
  if (ar.reading()) {
    if (held.size() != 13)
      throw SetupError("checkpoint electrical_network state has " + std::to_string(held.size()) + " values, expected 13");
    r_ = Result{held[0], held[1], held[2], held[3], held[4],  held[5],  held[6],
                held[7], held[8], 0.0,     held[9], held[10], held[11], held[12]};
  }
  if (p_.solver == "amg" && (!ar.reading() || ar.has(prefix + "/amg_ranks"))) ar.visit(prefix + "/amg_ranks", r_.amg_ranks);
  if (p_.topology == "sphere_element") ar.visit(prefix + "/negative_share", r_.negative_share);
  if (branch_.model == "sintered_neck" && (!ar.reading() || ar.has(prefix + "/network_necks"))) {
    ar.visit(prefix + "/network_necks", r_.necks);
    if (r_.necks.size() != 5)
      throw SetupError("checkpoint electrical_network network_necks has " + std::to_string(r_.necks.size()) + " values, expected 5");
  }
  solver_.visit(ar, prefix + "/solver");
  // The resolved gap tolerance (touch_tolerance_relative: from the radii at the stage start).
  if (!ar.reading() || ar.has(prefix + "/touch_tolerance_m")) {
    ar.visit(prefix + "/touch_tolerance_m", branch_.touch_tolerance);
    tolerance_restored_ = ar.reading();
  }
  // The held per-branch results (written with every frame until the next solve).
  std::vector<std::int64_t> pairs = edges_.pairs;
  std::vector<double> branch;
  if (!ar.reading()) branch.reserve(edges_.fields.size() * (pairs.size() / 2));
  if (!ar.reading())
    for (std::size_t k = 0; k < pairs.size() / 2; ++k)
      for (const auto& f : edges_.fields) branch.push_back(f.values[k]);
  if (!ar.reading() || ar.has(prefix + "/branch_pairs")) {
    ar.visit(prefix + "/branch_pairs", pairs, 2);
    ar.visit(prefix + "/branch_values", branch, 3);
  }
  // Whether the last solve produced branch output at all: a solve with no particle-centred branch
  // still writes an empty /networks/electrical group, which a restarted run must reproduce
  // (found by the SIGKILL test of the explicit heat scene). Older checkpoints: non-empty pairs.
  bool has_output = !edges_.name.empty();
  if (!ar.reading() || ar.has(prefix + "/branch_output"))
    ar.visit(prefix + "/branch_output", has_output);
  else
    has_output = !pairs.empty();
  if (ar.reading()) {
    edges_ = EdgeOutput{};
    if (has_output) {
      if (branch.size() != 3 * (pairs.size() / 2)) throw SetupError("checkpoint electrical_network branch data is inconsistent");
      edges_ = EdgeOutput{"electrical", pairs, {{"current", "A", {}}, {"conductance", "S", {}}, {"power", "W", {}}}};
      for (std::size_t k = 0; k < pairs.size() / 2; ++k)
        for (int c = 0; c < 3; ++c) edges_.fields[c].values.push_back(branch[3 * k + c]);
    }
  }
}

}  // namespace sparkdem::physics
