#include "physics/electrical/contact_percolation.hpp"
#include "physics/electrical/ptc_strain.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>

#include "engine/core/error.hpp"
#include "engine/state/particle_set.hpp"
#include "engine/state/state.hpp"
#include "physics/electrical/ptc_gaps.hpp"
#include "physics/electrical/ptc_matrix.hpp"
#include "physics/electrical/rkpm_matrix.hpp"
#include "engine/core/numbers.hpp"

namespace sparkdem::physics {

namespace {
constexpr std::size_t kFixed = 9;  // columns before the per-eps0 block
constexpr std::size_t kContactFields = 5;

/// The per-contact output's layout (values filled by the caller).
EdgeOutput contact_output(std::vector<std::int64_t> pairs) {
  // break_strain = hi, join_strain = lo of the conduction interval (ptc_matrix.hpp; for a touching
  // contact lo < 0 is where it opens on cooling).
  return EdgeOutput{"ptc_contacts",
                    std::move(pairs),
                    {{"gap", "m", {}},
                     {"unit_opening", "m", {}},
                     {"break_strain", "1", {}},
                     {"join_strain", "1", {}},
                     {"touching", "1", {}}}};
}

}  // namespace

/// The column suffix of a value ("%.2f" with 'p' for the point, then `unit`), checked unique.
bool add_suffix(double v, const char* format, std::set<std::string>& seen, std::vector<std::string>& out) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  std::string sfx(buf);
  std::replace(sfx.begin(), sfx.end(), '.', 'p');
  out.push_back(sfx);
  return seen.insert(sfx).second;
}

/// Edges of a histogram: none, or >= 2 strictly increasing.
void check_edges(const std::vector<double>& e, const std::string& path, std::vector<Diagnostic>& errors) {
  if (e.size() == 1) errors.push_back({path, "needs at least two edges (or none), found one"});
  for (std::size_t k = 1; k < e.size(); ++k)
    if (!(e[k] > e[k - 1])) {
      errors.push_back({path, "must increase strictly, found " + std::to_string(e[k - 1]) + " then " + std::to_string(e[k])});
      break;
    }
}

PtcStrain::PtcStrain(const Params& p) : p_(p) {
  // Every consistency problem at once, with its path relative to the module (the loader prefixes it).
  std::vector<Diagnostic> errors;
  std::set<std::string> seen;
  if (p_.eps0_values.empty()) errors.push_back({"/eps0_values", "expected at least one eps0, found none"});
  for (double e : p_.eps0_values) {
    if (!(e >= 0.0) || !std::isfinite(e))
      errors.push_back({"/eps0_values", "must be finite and >= 0, found " + std::to_string(e)});
    else if (!add_suffix(100.0 * e, "%.2fpct", seen, suffix_))
      errors.push_back({"/eps0_values", "two values round to the same column " + suffix_.back() + " (0.01 % resolution)"});
  }
  if (p_.matrix_model != "bonded" && p_.matrix_model != "rkpm")
    errors.push_back({"/matrix_model", "must be \"bonded\" or \"rkpm\", found \"" + p_.matrix_model + "\""});
  check_edges(p_.opening_histogram_edges, "/opening_histogram_edges", errors);
  if (p_.matrix_model == "bonded" && p_.closing_gap_rel > p_.cutoff_gap_rel)
    errors.push_back({"/closing_gap_rel", "the bonded matrix follows only its springs (gap <= cutoff_gap_rel (R_i + R_j) = " +
                                              std::to_string(p_.cutoff_gap_rel) + "): closing_gap_rel must not exceed it, found " +
                                              std::to_string(p_.closing_gap_rel)});
  if (p_.strain_statistics && p_.matrix_model != "rkpm")
    errors.push_back({"/strain_statistics", "needs matrix_model \"rkpm\" (the bonded network has no strain field)"});
  check_edges(p_.strain_histogram_edges, "/strain_histogram_edges", errors);
  if (p_.strain_points != "matrix" && !p_.strain_statistics)
    errors.push_back({"/strain_points", "\"" + p_.strain_points + "\" needs strain_statistics true"});
  if (!p_.strain_histogram_edges.empty() && !(p_.opening_strain > 0.0))
    errors.push_back({"/opening_strain", "strain_histogram_edges need opening_strain > 0, found " + std::to_string(p_.opening_strain)});
  try {
    faces_ = rkpm::parse_box_faces(p_.boundary_faces);
  } catch (const SetupError& e) { errors.push_back({"/boundary_faces", e.what()}); }
  if (p_.surface_points % 2 != 0)
    errors.push_back({"/surface_points", "must be even (antipodal pairs), found " + std::to_string(p_.surface_points)});
  law_ = ptc::ThermalStrainLaw{
      p_.expansion_coefficient, p_.expansion_coefficient_melt > 0.0 ? p_.expansion_coefficient_melt : p_.expansion_coefficient,
      p_.reference_temperature, p_.melting_temperature,
      p_.melting_strain,        p_.melting_width};
  if (!p_.temperatures.empty()) {
    try {
      ptc::validate(law_);
    } catch (const SetupError& e) { errors.push_back({"", e.what()}); }
    for (double T : p_.temperatures) {
      if (!(T > 0.0) || !std::isfinite(T))
        errors.push_back({"/temperatures", "must be finite and > 0 K, found " + std::to_string(T)});
      else if (!add_suffix(T, "T%.2fK", seen, tsuffix_))
        errors.push_back({"/temperatures", "two temperatures round to the same column " + tsuffix_.back() + " (0.01 K resolution)"});
    }
  }
  if (!errors.empty()) throw ConfigError(std::move(errors));
  held_.assign(kFixed + 3 * suffix_.size() + histogram_columns() + strain_columns() + (tsuffix_.empty() ? 0 : 1 + 4 * tsuffix_.size()), kNaN);
}

ParamSpec<PtcStrain::Params> PtcStrain::spec() {
  using P = Params;
  ParamSpec<P> s("ptc_strain", "module",
                 "seed 002 thermoelastic minimum model: rigid fillers, the polymer as axial springs with eigen-elongation "
                 "eps0 h_ij (one linear solve for unit eps0); Z(eps0), rho(eps0), switching strain, contact openings");
  s.add("high", &P::high).doc("electrode particle set on one face");
  s.add("low", &P::low).doc("electrode particle set on the opposite face");
  ptc::add_relative_gaps(s);
  s.add("closing_gap_rel", &P::closing_gap_rel)
      .unit("1")
      .nonnegative()
      .doc("pairs with gap <= this x (R_i + R_j) that do not touch are followed: one joins when its gap closes to "
           "touch_gap_rel (R_i + R_j) (0: contacts only break)");
  s.add("matrix_modulus", &P::matrix_modulus).unit("Pa").positive().doc("E_m (the openings do not depend on it)");
  s.add("bond_area", &P::bond_area).unit("m^2").positive().doc("A (the openings do not depend on it)");
  s.add("regularisation", &P::regularisation)
      .nonnegative()
      .doc("ground spring on every filler, x mean spring stiffness: removes rigid-body and floppy modes");
  s.add("unit_conductance", &P::unit_conductance).unit("S").positive().doc("conductance of a conducting contact");
  s.add("length", &P::length).unit("m").nonnegative().doc("L of rho = R_eq L; 0: the box edge recorded by cpc_fillers");
  s.add("opening_strain", &P::opening_strain).nonnegative().doc("eps0 [1] of the opening statistics (paper: 1 %)");
  s.add("eps0_values", &P::eps0_values).doc("matrix eigenstrains eps0 [1] at which Z and rho are reported");
  s.add("temperatures", &P::temperatures)
      .unit("K")
      .doc("temperatures at which eps0(T), Z and rho are reported, with the switching temperature (empty: no temperature columns)");
  s.add("expansion_coefficient", &P::expansion_coefficient)
      .unit("1/K")
      .positive()
      .doc("alpha_s: linear expansion coefficient of the matrix relative to the fillers (below the melting step)");
  s.add("expansion_coefficient_melt", &P::expansion_coefficient_melt)
      .unit("1/K")
      .nonnegative()
      .doc("alpha_l: the same above the melting step (0: alpha_s)");
  s.add("reference_temperature", &P::reference_temperature).unit("K").positive().doc("T_ref: eps0(T_ref) = 0 (the stress-free state)");
  s.add("melting_temperature", &P::melting_temperature).unit("K").nonnegative().doc("T_m: centre of the melting step (0: no melting step)");
  s.add("melting_strain", &P::melting_strain)
      .unit("1")
      .nonnegative()
      .doc("linear strain jump on melting (about Delta V / (3 V) of the host's volume change)");
  s.add("melting_width", &P::melting_width).unit("K").nonnegative().doc("width of the smoothed melting step (0: sharp)");
  s.add("opening_histogram_edges", &P::opening_histogram_edges)
      .doc(
          "bin edges [1] of the relative contact opening at opening_strain (columns opening_hist_<k>, _below, _above); "
          "empty: no histogram");
  s.add("matrix_model", &P::matrix_model)
      .choices({"bonded", "rkpm"})
      .doc("bonded: axial-spring network (ptc_matrix); rkpm: the paper's meshless continuum (rkpm_matrix)");
  s.add("poisson_ratio", &P::poisson_ratio)
      .range(-0.99, 0.499)
      .doc("rkpm: matrix Poisson ratio (not given by the paper; 0.35 default, not tuned)");
  s.add("node_spacing", &P::node_spacing)
      .unit("m")
      .positive()
      .doc("rkpm: node spacing h (fitted to the box edge; paper 12,000 nodes in a 70 R box ~ 3 R)");
  s.add("support_factor", &P::support_factor).min(1.0).doc("rkpm: support radius / node spacing (> 1)");
  s.add("quadrature_order", &P::quadrature_order).range(1, 8).doc("rkpm: Gauss points per direction per background cell");
  s.add("cell_subdivision", &P::cell_subdivision).range(1, 16).doc("rkpm: background quadrature cells per node spacing, per direction");
  s.add("surface_points", &P::surface_points).range(2, 100000).doc("rkpm: penalty surface points per sphere (even)");
  s.add("bond_penalty", &P::bond_penalty)
      .unit("Pa/m")
      .nonnegative()
      .doc("rkpm: sphere-matrix penalty alpha [Pa/m], absolute: alpha R / E is what sets the response (paper \"100 E\" "
           "in its unit of length; 10 = the SI test's unit at R = 1 m); scale it with 1 / R when the fillers change size");
  s.add("pin_penalty", &P::pin_penalty).positive().doc("rkpm: translation pin at the box centre, beta / (E h)");
  s.add("cg_tolerance", &P::cg_tolerance).positive().doc("rkpm: relative residual of the conjugate-gradient solve");
  s.add("cg_max_iterations", &P::cg_max_iterations).min(1).doc("rkpm: conjugate-gradient iteration limit");
  s.add("cut_cell_depth", &P::cut_cell_depth)
      .range(0, 8)
      .doc("rkpm: octree levels splitting the quadrature cells cut by a sphere surface (0: staircase on the cells)");
  s.add("surface_spacing", &P::surface_spacing)
      .positive()
      .doc("rkpm: penalty surface point spacing / h (at least surface_points per sphere)");
  s.add("boundary", &P::boundary)
      .choices({"free", "clamped", "rollers"})
      .doc("rkpm: free expansion (translation pinned), clamped faces (u = 0) or rollers (u.n = 0) by penalty");
  s.add("boundary_penalty", &P::boundary_penalty).positive().doc("rkpm: clamped / rollers penalty beta / (E / h)");
  s.add("boundary_faces", &P::boundary_faces)
      .doc(
          "rkpm: the box faces held by clamped / rollers: \"all\" or a comma-separated list of x_lo, x_hi, y_lo, y_hi, "
          "z_lo, z_hi (e.g. \"z_lo\": a sample held on one face)");
  s.add("strain_statistics", &P::strain_statistics)
      .doc("rkpm: max principal strain of the matrix at every volume quadrature point (means, negative fractions)");
  s.add("strain_histogram_edges", &P::strain_histogram_edges)
      .doc(
          "bin edges [1] of the max principal strain at eps0 = opening_strain (columns strain_total_hist_<k>, "
          "strain_mech_hist_<k>, _below, _above; needs strain_statistics)");
  s.add("strain_points", &P::strain_points)
      .choices({"matrix", "box", "nodes"})
      .doc(
          "rkpm: where strain_statistics sample (seed 002 does not say what its Fig. 4 histograms): the matrix volume "
          "quadrature (matrix, weighted), a lattice over the whole box at spacing h / cell_subdivision, filler "
          "interiors included (box, equal weights), or the RKPM nodes (nodes, unweighted)");
  s.add("linear_solver", &P::linear_solver)
      .choices({"cg_ic", "cg", "ldlt", "auto", "amg"})
      .doc("rkpm: CG with incomplete Cholesky (cg_ic), Jacobi CG (cg), sparse LDLT (ldlt), auto (LDLT when small), hypre "
           "BoomerAMG-PCG on the 3-component system (amg; needs the MPI build; several times slower than cg_ic on the "
           "penalty-bonded fillers, see rkpm_matrix.hpp)");
  return s;
}

void PtcStrain::declare(Declarations& d) const { d.reads_previous = {"position", "radius"}; }

void PtcStrain::bind(State& s) {
  clock_ = percolation::geometry_event_clock(s);
  length_ = percolation::box_length(s, p_.length, "ptc_strain");
}

struct PtcStrain::UnitResult {
  ptc::Contacts contacts;
  std::size_t matrix_size = 0;  ///< springs (bonded) or RKPM nodes
  double residual = 0.0;
  std::vector<double> strain;  ///< the strain columns (strain_columns() values)
};

PtcStrain::UnitResult PtcStrain::unit_contacts(const State& s) const {
  ptc::MatrixParams mp;
  mp.matrix_modulus = p_.matrix_modulus;
  mp.bond_area = p_.bond_area;
  mp.min_gap_rel = p_.min_gap_rel;
  mp.cutoff_gap_rel = p_.cutoff_gap_rel;
  mp.touch_gap_rel = p_.touch_gap_rel;
  mp.regularisation = p_.regularisation;
  const std::size_t n = s.particles.size();
  UnitResult u;
  if (p_.matrix_model == "bonded") {
    const ptc::SpringNetwork net = ptc::build_network(s.particles.position, s.particles.radius, mp);
    const ptc::UnitSolution sol = ptc::solve_unit(n, net, mp);
    u.contacts = ptc::candidate_contacts(net, sol, p_.touch_gap_rel, p_.closing_gap_rel);
    u.matrix_size = net.size();
    u.residual = sol.residual;
    return u;
  }
  rkpm::Params rp;
  rp.youngs_modulus = p_.matrix_modulus;
  rp.poisson_ratio = p_.poisson_ratio;
  rp.node_spacing = p_.node_spacing;
  rp.support_factor = p_.support_factor;
  rp.quadrature_order = static_cast<int>(p_.quadrature_order);
  rp.cell_subdivision = static_cast<int>(p_.cell_subdivision);
  rp.cut_cell_depth = static_cast<int>(p_.cut_cell_depth);
  rp.surface_points = static_cast<int>(p_.surface_points);
  rp.surface_spacing = p_.surface_spacing;
  rp.bond_penalty = p_.bond_penalty;
  rp.pin_penalty = p_.pin_penalty;
  rp.boundary = p_.boundary;
  rp.boundary_penalty = p_.boundary_penalty;
  rp.boundary_faces = faces_;
  rp.cg_tolerance = p_.cg_tolerance;
  rp.cg_max_iterations = static_cast<int>(p_.cg_max_iterations);
  rp.solver = p_.linear_solver;
  rp.strain_statistics = p_.strain_statistics;
  rp.strain_points = p_.strain_points;
  for (double e : p_.strain_histogram_edges) rp.strain_edges.push_back(e / p_.opening_strain);
  // The polymer box: the smallest cube holding [0, L]^3 and every filler (the contact algorithm
  // has no walls, so a filler may end partly or wholly outside [0, L]^3; it stays embedded).
  Vec3 lo = Vec3::Zero(), hi = Vec3::Constant(length_);
  for (std::size_t i = 0; i < n; ++i) {
    lo = lo.cwiseMin(s.particles.position[i] - Vec3::Constant(s.particles.radius[i]));
    hi = hi.cwiseMax(s.particles.position[i] + Vec3::Constant(s.particles.radius[i]));
  }
  rkpm::Domain dom;
  dom.lo = lo;
  dom.hi = lo + Vec3::Constant((hi - lo).maxCoeff());
  const rkpm::Result r = rkpm::solve_unit(s.particles.position, s.particles.radius, dom, rp);
  // The touching pairs and closing candidates (springs of a network cut at the larger of the two
  // gaps) with the RKPM openings.
  ptc::MatrixParams tp = mp;
  tp.cutoff_gap_rel = std::max(p_.touch_gap_rel, p_.closing_gap_rel);
  const ptc::SpringNetwork near = ptc::build_network(s.particles.position, s.particles.radius, tp);
  ptc::UnitSolution sol;
  sol.displacement = r.sphere_displacement;
  for (std::size_t e = 0; e < near.size(); ++e)
    sol.opening.push_back(near.normal[e].dot(r.sphere_displacement[near.b[e]] - r.sphere_displacement[near.a[e]]));
  u.contacts = ptc::candidate_contacts(near, sol, p_.touch_gap_rel, p_.closing_gap_rel);
  u.matrix_size = r.approximation.nodes();
  u.residual = r.residual;
  if (p_.strain_statistics) {  // per unit eps0 -> at opening_strain
    const rkpm::StrainStatistics& st = r.strain;
    const double e0 = p_.opening_strain;
    u.strain = {e0 * st.total_mean, e0 * st.mechanical_mean, st.total_negative_fraction, st.mechanical_negative_fraction,
                e0 * ptc::affine_volumetric_strain(s.particles.position, r.sphere_displacement)};
    if (p_.strain_histogram_edges.size() >= 2) {
      u.strain.insert(u.strain.end(), st.total_histogram.begin(), st.total_histogram.end());
      u.strain.insert(u.strain.end(), st.mechanical_histogram.begin(), st.mechanical_histogram.end());
    }
  }
  return u;
}

void PtcStrain::advance(State& s, const StepInfo&) {
  const std::size_t n = s.particles.size();
  const UnitResult unit = unit_contacts(s);
  const ptc::Contacts& c = unit.contacts;
  const std::size_t matrix_size = unit.matrix_size;
  const double residual = unit.residual;
  const ptc::Intervals iv = ptc::conduction_intervals(c, p_.touch_gap_rel, p_.break_gap_rel);
  const std::vector<Index> high = set_members(s, p_.high, "ptc_strain"), low = set_members(s, p_.low, "ptc_strain");

  std::vector<double> rel;
  std::size_t closing = 0;
  for (std::size_t e = 0; e < c.size(); ++e) {  // the opening statistics: the touching contacts
    if (!c.touching[e]) continue;
    rel.push_back(p_.opening_strain * c.opening[e] / c.distance[e]);
    if (c.opening[e] < 0.0) ++closing;
  }
  const std::size_t touching = rel.size();
  double mean = kNaN, median = kNaN;
  if (!rel.empty()) {
    mean = 0.0;
    for (double v : rel) mean += v;
    mean /= static_cast<double>(rel.size());
    std::vector<double> sorted = rel;
    std::sort(sorted.begin(), sorted.end());
    const std::size_t k = sorted.size();
    median = k % 2 ? sorted[k / 2] : 0.5 * (sorted[k / 2 - 1] + sorted[k / 2]);
  }
  double listed = kInf;
  std::vector<double> per;
  for (double e0 : p_.eps0_values) {
    const ptc::StrainPoint sp = ptc::evaluate(n, c, iv, e0, p_.unit_conductance, high, low, solver_);
    if (!sp.spanning) listed = std::min(listed, e0);
    per.insert(per.end(), {sp.spanning ? 1.0 : 0.0, sp.coordination, sp.resistance * length_});
  }
  held_ = {static_cast<double>(matrix_size),
           static_cast<double>(touching),
           static_cast<double>(c.size() - touching),
           ptc::switching_strain(n, c, iv, high, low),
           listed,
           mean,
           median,
           touching ? static_cast<double>(closing) / static_cast<double>(touching) : kNaN};
  held_.push_back(residual);
  held_.insert(held_.end(), per.begin(), per.end());
  const auto& he = p_.opening_histogram_edges;
  if (!he.empty()) {
    std::vector<double> count(he.size() + 1, 0.0);  // bins, then below, above
    for (double v : rel) {
      if (v < he.front())
        count[he.size() - 1] += 1.0;
      else if (v >= he.back())
        count[he.size()] += 1.0;
      else
        count[static_cast<std::size_t>(std::upper_bound(he.begin(), he.end(), v) - he.begin()) - 1] += 1.0;
    }
    for (double& v : count) v = rel.empty() ? kNaN : v / static_cast<double>(rel.size());
    held_.insert(held_.end(), count.begin(), count.end());
  }
  held_.insert(held_.end(), unit.strain.begin(), unit.strain.end());
  if (!tsuffix_.empty()) {
    held_.push_back(std::isfinite(held_[3]) ? ptc::temperature_at_strain(law_, held_[3]) : kInf);
    for (double T : p_.temperatures) {
      const double e0 = ptc::thermal_strain(law_, T);  // < 0 below T_ref: the intervals hold for either sign
      const ptc::StrainPoint sp = ptc::evaluate(n, c, iv, e0, p_.unit_conductance, high, low, solver_);
      held_.insert(held_.end(), {e0, sp.spanning ? 1.0 : 0.0, sp.coordination, sp.resistance * length_});
    }
  }
  // Per-contact results for the frames: ids, initial gap, unit opening, conduction interval, touching.
  contacts_ = contact_output({});
  for (std::size_t e = 0; e < c.size(); ++e) {
    contacts_.pairs.push_back(s.particles.id[c.a[e]]);
    contacts_.pairs.push_back(s.particles.id[c.b[e]]);
    const double v[kContactFields] = {c.gap[e], c.opening[e], iv.hi[e], iv.lo[e], static_cast<double>(c.touching[e])};
    for (std::size_t q = 0; q < kContactFields; ++q) contacts_.fields[q].values.push_back(v[q]);
  }
}

std::vector<std::string> PtcStrain::columns() const {
  std::vector<std::string> c = {
      "ptc_strain_springs",      "ptc_strain_contacts",       "ptc_strain_closing_candidates",        "ptc_strain_switching_strain",
      "ptc_strain_switching_strain_listed",
      "ptc_strain_opening_mean", "ptc_strain_opening_median", "ptc_strain_opening_negative_fraction", "ptc_strain_solve_residual"};
  for (const auto& sfx : suffix_)
    for (const char* q : {"spanning_", "coordination_", "resistivity_"}) c.push_back(std::string("ptc_strain_") + q + sfx);
  const std::size_t m = p_.opening_histogram_edges.size();
  if (m >= 2) {
    for (std::size_t k = 0; k + 1 < m; ++k) {
      char buf[64];
      std::snprintf(buf, sizeof buf, "ptc_strain_opening_hist_%02zu", k);
      c.emplace_back(buf);
    }
    c.emplace_back("ptc_strain_opening_hist_below");
    c.emplace_back("ptc_strain_opening_hist_above");
  }
  if (p_.strain_statistics) {
    for (const char* q : {"strain_total_mean", "strain_mech_mean", "strain_total_negative_fraction", "strain_mech_negative_fraction",
                          "composite_volumetric_strain"})
      c.push_back(std::string("ptc_strain_") + q);
    const std::size_t ms = p_.strain_histogram_edges.size();
    if (ms >= 2)
      for (const char* kind : {"total", "mech"}) {
        for (std::size_t k = 0; k + 1 < ms; ++k) {
          char buf[64];
          std::snprintf(buf, sizeof buf, "ptc_strain_strain_%s_hist_%02zu", kind, k);
          c.emplace_back(buf);
        }
        c.push_back(std::string("ptc_strain_strain_") + kind + "_hist_below");
        c.push_back(std::string("ptc_strain_strain_") + kind + "_hist_above");
      }
  }
  if (!tsuffix_.empty()) c.push_back("ptc_strain_switching_temperature");
  for (const auto& sfx : tsuffix_)
    for (const char* q : {"eps0_", "spanning_", "coordination_", "resistivity_"}) c.push_back(std::string("ptc_strain_") + q + sfx);
  return c;
}

std::vector<double> PtcStrain::column_values(const State&) const { return held_; }

void PtcStrain::visit(Archive& ar, const std::string& prefix) {
  std::vector<double> held = held_;
  ar.visit(prefix + "/held", held);
  if (ar.reading()) {
    if (held.size() != held_.size())
      throw SetupError("checkpoint ptc_strain state has " + std::to_string(held.size()) + " values, expected " + std::to_string(held_.size()));
    held_ = held;
  }
  solver_.visit(ar, prefix + "/solver");
  // The held per-contact results (written with every frame until the next evaluation).
  std::vector<std::int64_t> pairs = contacts_.pairs;
  std::vector<double> vals;
  if (!ar.reading())
    for (std::size_t k = 0; k < pairs.size() / 2; ++k)
      for (const auto& f : contacts_.fields) vals.push_back(f.values[k]);
  if (!ar.reading() || ar.has(prefix + "/contact_pairs")) {
    ar.visit(prefix + "/contact_pairs", pairs, 2);
    ar.visit(prefix + "/contact_values", vals, kContactFields);
  }
  if (ar.reading()) {
    contacts_ = EdgeOutput{};
    if (!pairs.empty()) {
      if (vals.size() != kContactFields * (pairs.size() / 2)) throw SetupError("checkpoint ptc_strain contact data is inconsistent");
      contacts_ = contact_output(pairs);
      for (std::size_t k = 0; k < pairs.size() / 2; ++k)
        for (std::size_t q = 0; q < kContactFields; ++q) contacts_.fields[q].values.push_back(vals[kContactFields * k + q]);
    }
  }
}

}  // namespace sparkdem::physics
