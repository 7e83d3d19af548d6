#include "physics/thermal/heat_conduction.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "engine/core/error.hpp"
#include "engine/core/format.hpp"
#include "engine/graph/interaction_graph.hpp"
#include "engine/state/particle_set.hpp"
#include "engine/state/state.hpp"
#include "physics/electrical/conductance_kernels.hpp"
#include "physics/thermal/expansion.hpp"
#include "physics/thermal/thermal_kernels.hpp"
#include "engine/core/numbers.hpp"

namespace sparkdem::physics {

namespace {

std::vector<std::string> split_names(const std::string& s) {
  std::vector<std::string> out;
  std::string cur;
  std::istringstream is(s);
  while (std::getline(is, cur, ',')) {
    const auto b = cur.find_first_not_of(" \t"), e = cur.find_last_not_of(" \t");
    if (b != std::string::npos) out.push_back(cur.substr(b, e - b + 1));
  }
  return out;
}

}  // namespace

ParamSpec<HeatConduction::Params> HeatConduction::spec() {
  using P = Params;
  ParamSpec<P> s("heat_conduction", "module",
                 "transient heat conduction on the interaction graph with Joule heating, fixed-temperature sets, prescribed "
                 "flux and ambient loss; explicit (own stable step) or implicit; energy balance in the time series");
  s.add("model", &P::model)
      .choices({"transmission_surface", "sintered_neck", "batchelor_obrien"})
      .doc("branch conductance: lambda S_ij / l_ij (seed 001), sintered neck hemispheres (+ layer), or 2 lambda a (Batchelor-O'Brien)");
  s.add("conductivity", &P::conductivity).unit("W/(m K)").positive().required().doc("thermal conductivity lambda of the solid");
  s.add("density", &P::density)
      .unit("kg/m^3")
      .positive()
      .required()
      .doc("true density rho of the solid (heat capacity; mass scaling never enters it)");
  s.add("specific_heat", &P::specific_heat).unit("J/(kg K)").positive().required().doc("specific heat c");
  s.add("capacity", &P::capacity)
      .choices({"sphere", "volume_fraction", "domain"})
      .doc("heat capacity: rho c V_sphere; / f_v,i (GranOO, seed 001 Eq. 13); or scaled so the capacities sum to rho c domain_volume");
  s.add("domain_volume", &P::domain_volume)
      .unit("m^3")
      .nonnegative()
      .doc("volume of the continuum domain (capacity 'domain'; also the denominator of the logged ratio sum V_i / f_v,i / V_d)");
  s.add("initial_temperature", &P::initial_temperature)
      .unit("K")
      .nonnegative()
      .doc("temperature of every particle at the stage start (0: keep the particles' temperature)");
  s.add("joule_heating", &P::joule_heating).doc("add heat_fraction x the field joule_power (needs electrical_network in the stage)");
  s.add("heat_fraction", &P::heat_fraction).unit("1").range(0.0, 1.0).doc("eta: fraction of the electrical power turned into heat");
  s.add("fixed_sets", &P::fixed_sets).doc("comma-separated particle sets held at fixed_temperatures");
  s.add("fixed_temperatures", &P::fixed_temperatures).unit("K").doc("one temperature per fixed set");
  s.add("flux_sets", &P::flux_sets).doc("comma-separated particle sets receiving flux_powers");
  s.add("flux_powers", &P::flux_powers)
      .unit("W")
      .doc("heat flow into each flux set (split in proportion to the heat capacities; < 0 extracts)");
  s.add("conductivity_sets", &P::conductivity_sets)
      .doc(
          "comma-separated particle sets of another material: their conductivity is conductivity_factors x lambda (series halves per "
          "branch)");
  s.add("conductivity_factors", &P::conductivity_factors).unit("1").doc("one factor > 0 per conductivity set");
  s.add("loss_set", &P::loss_set).doc("particles losing heat to the ambient: a set name, \"all\", or \"\" (adiabatic)");
  s.add("convection_coefficient", &P::convection_coefficient).unit("W/(m^2 K)").nonnegative().doc("h of the convective loss");
  s.add("emissivity", &P::emissivity).unit("1").range(0.0, 1.0).doc("emissivity of the radiative loss");
  s.add("ambient_temperature", &P::ambient_temperature).unit("K").positive().doc("T_a of the losses");
  s.add("loss_area_fraction", &P::loss_area_fraction).unit("1").range(0.0, 1.0).doc("exposed area of a loss particle / 4 pi r^2");
  s.add("report_sets", &P::report_sets)
      .doc("comma-separated particle sets: one column heat_temperature_mean_<set> each, the capacity-weighted mean temperature of the set");
  s.add("scheme", &P::scheme)
      .choices({"explicit", "implicit"})
      .doc("forward Euler on its own stable step, or backward Euler (sparse LDL^T)");
  s.add("safety", &P::safety)
      .unit("1")
      .range(0.0, 1.0)
      .doc("explicit: fraction of the Gershgorin bound min C_i / sum_j G_ij used as the stable step");
  s.add("solver", &P::solver).choices({"direct", "cg_ic", "cg_jacobi"}).doc("implicit: linear solver");
  s.add("tolerance", &P::tolerance).unit("1").positive().doc("implicit with CG: relative residual");
  s.add("expansion_coefficient", &P::expansion_coefficient).unit("1/K").doc("alpha_T: radii follow each particle's temperature (0: off)");
  s.add("reference_temperature", &P::reference_temperature).unit("K").positive().doc("T_0 of the reference radii");
  s.add("contact_radius", &P::contact_radius)
      .choices({"hertz", "geometric"})
      .doc("batchelor_obrien: a = sqrt(R* delta) or the lens radius");
  s.add("neck", &P::neck).choices({"law", "coble", "cv"}).doc("sintered_neck: neck radius source");
  s.add("hemisphere", &P::hemisphere).choices({"reading_a", "reading_b", "reading_c", "fe_table"}).doc("sintered_neck: hemisphere law");
  s.add("gb_epsilon", &P::gb_epsilon).unit("1").positive().doc("sintered_neck: conductivity ratio of a neck layer");
  s.add("gb_thickness", &P::gb_thickness).unit("m").nonnegative().doc("sintered_neck: neck layer thickness (0: none)");
  s.add("gbf_correction", &P::gbf_correction).doc("sintered_neck: grain-boundary-fraction correction");
  s.add("alpha_constant", &P::alpha_constant).unit("1").nonnegative().doc("transmission_surface: fixed alpha (0: alpha(n), f(e))");
  s.add("touch_tolerance", &P::touch_tolerance).unit("m").nonnegative().doc("transmission_surface: gap up to which a pair conducts");
  s.add("touch_tolerance_relative", &P::touch_tolerance_relative)
      .unit("1")
      .nonnegative()
      .doc(
          "touching, transmission_surface: the gap tolerance as a fraction of the mean particle radius at the stage start (> 0 overrides "
          "touch_tolerance; kept in the checkpoint)");
  return s;
}

HeatConduction::HeatConduction(const Params& p) : p_(p) {
  std::vector<Diagnostic> d;
  fixed_names_ = split_names(p.fixed_sets);
  flux_names_ = split_names(p.flux_sets);
  factor_names_ = split_names(p.conductivity_sets);
  if (factor_names_.size() != p.conductivity_factors.size())
    d.push_back({"/conductivity_factors", "expected one factor per conductivity set (" + std::to_string(factor_names_.size()) +
                                              "), found " + std::to_string(p.conductivity_factors.size())});
  for (std::size_t k = 0; k < p.conductivity_factors.size(); ++k)
    if (!(p.conductivity_factors[k] > 0.0) || !std::isfinite(p.conductivity_factors[k]))
      d.push_back({"/conductivity_factors/" + std::to_string(k), "expected a finite factor > 0, found " + format_number(p.conductivity_factors[k])});
  report_names_ = split_names(p.report_sets);
  for (std::size_t k = 0; k < report_names_.size(); ++k)
    for (std::size_t j = 0; j < k; ++j)
      if (report_names_[j] == report_names_[k]) d.push_back({"/report_sets", "set '" + report_names_[k] + "' is listed twice"});
  if (fixed_names_.size() != p.fixed_temperatures.size())
    d.push_back({"/fixed_temperatures", "expected one temperature per fixed set (" + std::to_string(fixed_names_.size()) + "), found " +
                                            std::to_string(p.fixed_temperatures.size())});
  for (std::size_t k = 0; k < p.fixed_temperatures.size(); ++k)
    if (!(p.fixed_temperatures[k] > 0.0) || !std::isfinite(p.fixed_temperatures[k]))
      d.push_back({"/fixed_temperatures/" + std::to_string(k), "expected a finite temperature > 0 K, found " + format_number(p.fixed_temperatures[k])});
  if (flux_names_.size() != p.flux_powers.size())
    d.push_back({"/flux_powers", "expected one power per flux set (" + std::to_string(flux_names_.size()) + "), found " +
                                     std::to_string(p.flux_powers.size())});
  if (p.capacity == "domain" && !(p.domain_volume > 0.0))
    d.push_back({"/domain_volume", "capacity \"domain\" needs the domain volume > 0 m^3, found " + format_number(p.domain_volume)});
  if (!p.loss_set.empty() && p.convection_coefficient == 0.0 && p.emissivity == 0.0)
    d.push_back({"/loss_set", "a loss set needs convection_coefficient > 0 or emissivity > 0, found both 0"});
  if (!d.empty()) throw ConfigError(d);
  branch_.model = p.model == "batchelor_obrien" ? "holm" : p.model;
  branch_.contact_radius = p.contact_radius;
  branch_.neck = p.neck;
  branch_.hemisphere = p.hemisphere;
  branch_.gb_epsilon = p.gb_epsilon;
  branch_.gb_thickness = p.gb_thickness;
  branch_.gbf_correction = p.gbf_correction;
  branch_.alpha_constant = p.alpha_constant;
  branch_.touch_tolerance = p.touch_tolerance;
  LaplacianOptions o;
  o.method = p.solver == "cg_ic"       ? LaplacianMethod::CgIncompleteCholesky
             : p.solver == "cg_jacobi" ? LaplacianMethod::CgDiagonal
                                       : LaplacianMethod::Direct;
  o.tolerance = p.tolerance;
  solver_.set_options(o);
}

void HeatConduction::declare(Declarations& d) const {
  d.particle_fields.push_back({"temperature", 1, "K", 0.0, true, FieldCheck::Finite});
  d.particle_fields.push_back({"heat_capacity", 1, "J/K", 0.0, false});
  d.particle_fields.push_back({"temperature_initial", 1, "K", 0.0, false});
  d.particle_fields.push_back({"temperature_carry", 1, "K", 0.0, false});
  d.reads = {"position", "radius"};
  if (p_.joule_heating) d.reads.push_back("joule_power");
  d.writes = {"temperature"};
  if (p_.expansion_coefficient != 0.0) thermal::declare_expansion(d);
}

Clock HeatConduction::clock() const {
  Clock c;
  c.kind = p_.scheme == "explicit" ? Clock::Kind::AdaptiveSubsteps : Clock::Kind::EveryStep;
  c.n = 1;
  return c;
}

namespace {
/// FNV-1a over the bytes of the geometry the network depends on (positions, radii, table sizes):
/// the network is rebuilt whenever any of them changed, whoever calls (advance, stable_dt, the
/// columns) and whenever (a restart rebuilds the same network from the same state).
std::uint64_t geometry_key(const State& s) {
  std::uint64_t h = 1469598103934665603ull;
  auto mix = [&h](const void* data, std::size_t bytes) {
    const auto* c = static_cast<const unsigned char*>(data);
    for (std::size_t k = 0; k < bytes; ++k) {
      h ^= c[k];
      h *= 1099511628211ull;
    }
  };
  const auto& p = s.particles;
  if (!p.position.empty()) mix(p.position.data(), p.position.size() * sizeof(Vec3));
  if (!p.radius.empty()) mix(p.radius.data(), p.radius.size() * sizeof(double));
  const std::size_t sizes[3] = {s.contacts.size(), s.bonds.size(), s.bonds.broken_count()};
  mix(sizes, sizeof sizes);
  return h;
}
}  // namespace

const HeatConduction::Network& HeatConduction::network(const State& s) const {
  const std::uint64_t key = geometry_key(s);
  if (net_.valid && net_.key == key) return net_;
  GraphOptions go;
  go.near_gap = branch_model_near_gap(branch_);
  const InteractionGraph g = build_interaction_graph(s, go);
  std::vector<double> share;
  try {
    net_.g = branch_conductances(branch_, s, g, std::vector<double>(g.size(), p_.conductivity), share);
  } catch (const ConfigError& e) { throw PhysicsError(s.step, {}, "thermal conductance", e.what()); }
  if (!factor_names_.empty()) {  // series halves: G / (s_a / f_a + (1 - s_a) / f_b)
    const auto& p = s.particles;
    std::vector<double> f(g.nodes(), 1.0);
    std::vector<char> seen(p.size(), 0);
    for (std::size_t k = 0; k < factor_names_.size(); ++k) {
      const auto& m = set_field(s, factor_names_[k], "heat_conduction");
      for (std::size_t i = 0; i < p.size(); ++i) {
        if (!(m[i] > 0.5)) continue;
        if (seen[i]) throw SetupError("heat_conduction: particle id " + std::to_string(p.id[i]) + " belongs to two conductivity sets");
        seen[i] = 1;
        f[i] = p_.conductivity_factors[k];
      }
    }
    for (std::size_t e = 0; e < g.size(); ++e) {
      const double sa = std::isnan(share[e]) ? 0.5 : share[e];
      net_.g[e] /= sa / f[g.a[e]] + (1.0 - sa) / f[g.b[e]];
    }
  }
  net_.a = g.a;
  net_.b = g.b;
  net_.degree = laplacian_diagonal(g.nodes(), net_.a, net_.b, net_.g);
  net_.inc.build(g.nodes(), net_.a, net_.b);
  net_.key = key;
  net_.valid = true;
  return net_;
}

void HeatConduction::bind(State& s) {
  net_.valid = false;
  if (!restored_) resolve_touch_tolerance(branch_, p_.touch_tolerance_relative, s);
  auto& p = s.particles;
  for (const auto& n : fixed_names_) (void)set_field(s, n, "heat_conduction");
  for (const auto& n : flux_names_) (void)set_field(s, n, "heat_conduction");
  for (const auto& n : factor_names_) (void)set_field(s, n, "heat_conduction");
  for (const auto& n : report_names_) (void)set_field(s, n, "heat_conduction");
  if (!p_.loss_set.empty() && p_.loss_set != "all") (void)set_field(s, p_.loss_set, "heat_conduction");
  if (restored_) {  // resumed mid-stage: temperatures, capacities and energies come from the checkpoint
    restored_ = false;
    return;
  }
  if (p_.expansion_coefficient != 0.0) thermal::capture_reference_radii(s, p_.reference_temperature, "heat_conduction");
  auto& T = p.fields.data("temperature");
  if (p_.initial_temperature > 0.0) std::fill(T.begin(), T.end(), p_.initial_temperature);
  for (std::size_t i = 0; i < p.size(); ++i)
    if (!(T[i] > 0.0))
      throw SetupError("heat_conduction: particle id " + std::to_string(p.id[i]) + " has temperature " + format_number(T[i]) +
                       " K; give initial_temperature or run after a stage that set the temperature");
  for (std::size_t k = 0; k < fixed_names_.size(); ++k) {
    const auto& f = set_field(s, fixed_names_[k], "heat_conduction");
    for (std::size_t i = 0; i < p.size(); ++i)
      if (f[i] > 0.5) T[i] = p_.fixed_temperatures[k];
  }
  // Heat capacities (thermal_kernels.hpp); the reference radius when the radii expand.
  const bool expands = p_.expansion_coefficient != 0.0;
  auto& C = p.fields.data("heat_capacity");
  double vsum = 0.0, vfsum = 0.0;
  std::vector<double> fv(p.size(), 1.0);
  {
    GraphOptions go;
    go.near_gap = branch_model_near_gap(branch_);
    const InteractionGraph g = build_interaction_graph(s, go);
    const auto n = electrical::coordination_numbers(g.nodes(), g.a, g.b);
    const auto e = electrical::eccentricities(p.position, p.radius, g.a, g.b);
    const auto model = electrical::TransmissionSurfaceModel::platonic();
    for (std::size_t i = 0; i < p.size(); ++i) fv[i] = model.volume_fraction(n[i], e[i]);
  }
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double r = expands ? p.fields.data("radius_ref")[i] : p.radius[i];
    const double v = 4.0 / 3.0 * kPi * r * r * r;
    vsum += v;
    vfsum += v / fv[i];
    C[i] = thermal::sphere_heat_capacity(p_.density, p_.specific_heat, r);
    if (p_.capacity == "volume_fraction") C[i] /= fv[i];
  }
  if (p_.capacity == "domain" && vsum > 0.0)
    for (double& c : C) c *= p_.domain_volume / vsum;
  capacity_ratio_ = p_.domain_volume > 0.0 ? vfsum / p_.domain_volume : kNaN;
  p.fields.data("temperature_initial") = T;
  auto& carry = p.fields.data("temperature_carry");
  std::fill(carry.begin(), carry.end(), 0.0);
  e_ = Energy{};
  // The stage's first force pass sees the radii of the initial temperatures.
  if (expands) thermal::apply_expansion(s, p_.expansion_coefficient, p_.reference_temperature, T);
}

double HeatConduction::stable_dt(const State& s) const {
  if (p_.scheme == "implicit") return kInf;
  const auto& p = s.particles;
  if (p.size() == 0) return kInf;
  const Network& n = network(s);
  const auto& C = p.fields.data("heat_capacity");
  const auto& T = p.fields.data("temperature");
  std::vector<char> fixed(p.size(), 0);
  for (const auto& name : fixed_names_) {
    const auto& f = set_field(s, name, "heat_conduction");
    for (std::size_t i = 0; i < p.size(); ++i)
      if (f[i] > 0.5) fixed[i] = 1;
  }
  const bool all_lose = p_.loss_set == "all";
  const std::vector<double>* lose = (!p_.loss_set.empty() && !all_lose) ? &set_field(s, p_.loss_set, "heat_conduction") : nullptr;
  double dt = kInf;
  limiting_id_ = -1;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (fixed[i]) continue;
    double rate = n.degree[i];
    if (all_lose || (lose && (*lose)[i] > 0.5)) {
      const double A = p_.loss_area_fraction * 4.0 * kPi * p.radius[i] * p.radius[i];
      rate += thermal::ambient_loss_slope(p_.convection_coefficient, p_.emissivity, A, T[i]);
    }
    if (rate > 0.0 && C[i] / rate < dt) {
      dt = C[i] / rate;
      limiting_id_ = p.id[i];
    }
  }
  return p_.safety * dt;
}

void HeatConduction::advance(State& s, const StepInfo& info) {
  auto& p = s.particles;
  const std::size_t np = p.size();
  if (np == 0) return;
  const Network& n = network(s);
  auto& T = p.fields.data("temperature");
  const auto& C = p.fields.data("heat_capacity");
  const double dt = info.dt;
  const double eta = p_.heat_fraction;
  const std::vector<double>* P = p_.joule_heating ? &p.fields.data("joule_power") : nullptr;
  // Per-particle boundary data from the sets (recomputed per call: the sets follow the particles).
  std::vector<double> fixed_value(np, kNaN), F(np, 0.0), area(np, 0.0);
  std::vector<DirichletGroup> groups(fixed_names_.size());
  for (std::size_t k = 0; k < fixed_names_.size(); ++k) {
    const auto& f = set_field(s, fixed_names_[k], "heat_conduction");
    groups[k].value = p_.fixed_temperatures[k];
    for (std::size_t i = 0; i < np; ++i) {
      if (!(f[i] > 0.5)) continue;
      if (!std::isnan(fixed_value[i]))
        throw SetupError("heat_conduction: particle id " + std::to_string(p.id[i]) + " belongs to two fixed sets");
      fixed_value[i] = p_.fixed_temperatures[k];
      groups[k].nodes.push_back(static_cast<Index>(i));
    }
  }
  for (std::size_t k = 0; k < flux_names_.size(); ++k) {
    const auto& f = set_field(s, flux_names_[k], "heat_conduction");
    double csum = 0.0;
    for (std::size_t i = 0; i < np; ++i)
      if (f[i] > 0.5 && std::isnan(fixed_value[i])) csum += C[i];
    if (csum > 0.0)
      for (std::size_t i = 0; i < np; ++i)
        if (f[i] > 0.5 && std::isnan(fixed_value[i])) F[i] += p_.flux_powers[k] * C[i] / csum;
  }
  if (!p_.loss_set.empty()) {
    const std::vector<double>* lose = p_.loss_set == "all" ? nullptr : &set_field(s, p_.loss_set, "heat_conduction");
    for (std::size_t i = 0; i < np; ++i)
      if ((!lose || (*lose)[i] > 0.5) && std::isnan(fixed_value[i]))
        area[i] = p_.loss_area_fraction * 4.0 * kPi * p.radius[i] * p.radius[i];
  }
  const double h = p_.convection_coefficient, em = p_.emissivity, Ta = p_.ambient_temperature;
  scratch_.assign(np, 0.0);
  std::vector<double>& y = scratch_;  // (L T)_i: heat leaving i by conduction [W]
  Energy de;
  if (p_.scheme == "explicit") {
    laplacian_apply(n.inc, n.g, T, y);
    std::vector<double> Tn(np);
    auto& carry = p.fields.data("temperature_carry");
    for (std::size_t i = 0; i < np; ++i) {
      const double Pi = P ? (*P)[i] : 0.0;
      de.electrical += Pi;
      if (!std::isnan(fixed_value[i])) {
        de.fixed += eta * Pi - y[i];
        Tn[i] = fixed_value[i];
        carry[i] = 0.0;
        continue;
      }
      const double Q = area[i] > 0.0 ? thermal::ambient_loss(h, em, area[i], T[i], Ta) : 0.0;
      de.lost += Q;
      de.flux += F[i];
      // Compensated (Kahan) update: an increment below half an ulp of T (a weak branch over
      // many substeps, e.g. 1e-14 K per step on 300 K) accumulates in the carry instead of
      // being lost to round-off.
      const double inc = dt / C[i] * (eta * Pi + F[i] - Q - y[i]) - carry[i];
      Tn[i] = T[i] + inc;
      carry[i] = (Tn[i] - T[i]) - inc;
    }
    T.swap(Tn);
  } else {
    std::vector<double> shunt(np), src(np), a_lin(np, 0.0), b_lin(np, 0.0);
    for (std::size_t i = 0; i < np; ++i) {
      const double Pi = P ? (*P)[i] : 0.0;
      if (area[i] > 0.0) {
        b_lin[i] = thermal::ambient_loss_slope(h, em, area[i], T[i]);
        a_lin[i] = thermal::ambient_loss(h, em, area[i], T[i], Ta) - b_lin[i] * T[i];
      }
      shunt[i] = C[i] / dt + b_lin[i];
      src[i] = C[i] * T[i] / dt + eta * Pi + F[i] - a_lin[i];
    }
    LaplacianProblem prob;
    prob.nodes = np;
    prob.a = n.a;
    prob.b = n.b;
    prob.g = n.g;
    prob.shunt = shunt;
    prob.source = src;
    prob.step = info.step;
    for (auto& g : groups)
      if (!g.nodes.empty()) prob.dirichlet.push_back(g);
    const LaplacianResult res = solver_.solve(prob);
    laplacian_apply(n.inc, n.g, res.value, y);
    for (std::size_t i = 0; i < np; ++i) {
      const double Pi = P ? (*P)[i] : 0.0;
      de.electrical += Pi;
      if (!std::isnan(fixed_value[i])) {
        de.fixed += eta * Pi - y[i];
        continue;
      }
      de.lost += a_lin[i] + b_lin[i] * res.value[i];
      de.flux += F[i];
    }
    T = res.value;
    auto& carry = p.fields.data("temperature_carry");
    std::fill(carry.begin(), carry.end(), 0.0);
  }
  e_.electrical += dt * de.electrical;
  e_.joule += dt * eta * de.electrical;
  e_.flux += dt * de.flux;
  e_.lost += dt * de.lost;
  e_.fixed += dt * de.fixed;
  // Blow-up / NaN watch: the step, the particles and the quantity.
  std::vector<Id> bad;
  for (std::size_t i = 0; i < np; ++i)
    if (!std::isfinite(T[i]) || !(T[i] > 0.0)) bad.push_back(p.id[i]);
  if (!bad.empty()) {
    std::vector<Id> first(bad.begin(), bad.begin() + static_cast<std::ptrdiff_t>(std::min<std::size_t>(bad.size(), 10)));
    std::string limit = "unconditionally stable";
    if (p_.scheme == "explicit") {
      const double sdt = stable_dt(s);  // sets limiting_id_ (evaluated before it is printed)
      limit = "stable step " + format_number(sdt) + " s, set by particle id " + std::to_string(limiting_id_);
    }
    throw PhysicsError(info.step, first, "temperature",
                       "heat_conduction: " + std::to_string(bad.size()) + " particle temperature(s) not finite or <= 0 K after the " +
                           p_.scheme + " step of " + format_number(dt) + " s (" + limit + ")");
  }
  if (p_.expansion_coefficient != 0.0) {
    thermal::apply_expansion(s, p_.expansion_coefficient, p_.reference_temperature, T);
    net_.valid = false;  // the radii changed
  }
}

std::vector<std::string> HeatConduction::columns() const {
  std::vector<std::string> c = {"heat_temperature_mean", "heat_temperature_min", "heat_temperature_max",   "heat_electrical_energy",
                                "heat_joule_energy",     "heat_flux_energy",     "heat_lost_energy",       "heat_fixed_energy",
                                "heat_stored_energy",    "heat_balance_error",   "heat_stable_dt",         "heat_capacity_total",
                                "heat_capacity_ratio",   "heat_temperature_std", "heat_isolated_particles"};
  for (const auto& n : report_names_) c.push_back("heat_temperature_mean_" + n);
  return c;
}

std::vector<double> HeatConduction::column_values(const State& s) const {
  const auto& p = s.particles;
  if (p.size() == 0) return std::vector<double>(columns().size(), kNaN);
  const auto& T = p.fields.data("temperature");
  const auto& T0 = p.fields.data("temperature_initial");
  const auto& C = p.fields.data("heat_capacity");
  double csum = 0.0, ct = 0.0, tmin = kInf, tmax = -kInf, stored = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    csum += C[i];
    ct += C[i] * T[i];
    tmin = std::min(tmin, T[i]);
    tmax = std::max(tmax, T[i]);
    stored += C[i] * (T[i] - T0[i]);
  }
  const double mean = ct / csum;
  double var = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) var += C[i] * (T[i] - mean) * (T[i] - mean);
  const Network& n = network(s);
  double isolated = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i)
    if (!(n.degree[i] > 0.0)) isolated += 1.0;
  const double expected = e_.joule + e_.flux - e_.lost - e_.fixed;
  const double scale = std::abs(e_.joule) + std::abs(e_.flux) + std::abs(e_.lost) + std::abs(e_.fixed);
  const double err = scale > 0.0 ? std::abs(stored - expected) / scale : std::abs(stored);
  std::vector<double> v = {ct / csum, tmin,   tmax, e_.electrical, e_.joule, e_.flux,         e_.lost,
                           e_.fixed,  stored, err,  stable_dt(s),  csum,     capacity_ratio_, std::sqrt(var / csum),
                           isolated};
  for (const auto& name : report_names_) {  // capacity-weighted mean temperature of each reported set
    const auto& f = set_field(s, name, "heat_conduction");
    double cs = 0.0, cts = 0.0;
    for (std::size_t i = 0; i < p.size(); ++i)
      if (f[i] > 0.5) {
        cs += C[i];
        cts += C[i] * T[i];
      }
    v.push_back(cs > 0.0 ? cts / cs : kNaN);
  }
  return v;
}

void HeatConduction::visit(Archive& ar, const std::string& prefix) {
  std::vector<double> e = {e_.electrical, e_.joule, e_.flux, e_.lost, e_.fixed, capacity_ratio_};
  ar.visit(prefix + "/energy", e);
  if (ar.reading()) {
    if (e.size() != 6) throw SetupError("checkpoint heat_conduction state has " + std::to_string(e.size()) + " values, expected 6");
    e_ = Energy{e[0], e[1], e[2], e[3], e[4]};
    capacity_ratio_ = e[5];
    restored_ = true;
    net_.valid = false;
  }
  if (!ar.reading() || ar.has(prefix + "/touch_tolerance_m")) ar.visit(prefix + "/touch_tolerance_m", branch_.touch_tolerance);
  solver_.visit(ar, prefix + "/solver");
}

}  // namespace sparkdem::physics
