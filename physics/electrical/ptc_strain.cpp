#include "physics/electrical/ptc_strain.hpp"
#include "physics/electrical/contact_percolation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>

#include "engine/core/error.hpp"
#include "engine/state/state.hpp"
#include "physics/electrical/ptc_matrix.hpp"

namespace sparkdem::physics {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr std::size_t kFixed = 8;  // columns before the per-eps0 block

std::vector<Index> members(const State& s, const std::string& name) {
  if (!s.particles.fields.has("set/" + name))
    throw SetupError("ptc_strain: electrode '" + name + "' is not a particle set of this stage (\"sets\")");
  const auto& f = s.particles.fields.data("set/" + name);
  std::vector<Index> out;
  for (std::size_t i = 0; i < f.size(); ++i)
    if (f[i] > 0.5) out.push_back(static_cast<Index>(i));
  return out;
}
}  // namespace

PtcStrain::PtcStrain(const Params& p) : p_(p) {
  if (p_.eps0_values.empty()) throw SetupError("ptc_strain: eps0_values is empty");
  std::set<std::string> seen;
  for (double e : p_.eps0_values) {
    if (!(e >= 0.0) || !std::isfinite(e)) throw SetupError("ptc_strain: eps0_values must be finite and >= 0");
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.2f", 100.0 * e);
    std::string sfx(buf);
    std::replace(sfx.begin(), sfx.end(), '.', 'p');
    sfx += "pct";
    if (!seen.insert(sfx).second) throw SetupError("ptc_strain: two eps0_values round to the same column " + sfx + " (0.01 % resolution)");
    suffix_.push_back(sfx);
  }
  law_ = ptc::ThermalStrainLaw{p_.expansion_coefficient,
                              p_.expansion_coefficient_melt > 0.0 ? p_.expansion_coefficient_melt : p_.expansion_coefficient,
                              p_.reference_temperature, p_.melting_temperature, p_.melting_strain, p_.melting_width};
  if (!p_.temperatures.empty()) {
    ptc::validate(law_);
    for (double T : p_.temperatures) {
      if (!(T > 0.0) || !std::isfinite(T)) throw SetupError("ptc_strain: temperatures must be finite and > 0 K");
      char buf[64];
      std::snprintf(buf, sizeof buf, "T%.2fK", T);
      std::string sfx(buf);
      std::replace(sfx.begin(), sfx.end(), '.', 'p');
      if (!seen.insert(sfx).second) throw SetupError("ptc_strain: two temperatures round to the same column " + sfx + " (0.01 K resolution)");
      tsuffix_.push_back(sfx);
    }
  }
  held_.assign(kFixed + 3 * suffix_.size() + (tsuffix_.empty() ? 0 : 1 + 4 * tsuffix_.size()), kNaN);
}

ParamSpec<PtcStrain::Params> PtcStrain::spec() {
  using P = Params;
  ParamSpec<P> s("ptc_strain", "module",
                 "seed 002 thermoelastic minimum model: rigid fillers, the polymer as axial springs with eigen-elongation "
                 "eps0 h_ij (one linear solve for unit eps0); Z(eps0), rho(eps0), switching strain, contact openings");
  s.add("high", &P::high).doc("electrode particle set on one face");
  s.add("low", &P::low).doc("electrode particle set on the opposite face");
  s.add("touch_tolerance", &P::touch_tolerance).unit("m").nonnegative()
      .doc("touching contacts: gap <= this (paper 0.1 % of D = 2e-3 R); no eigenstrain in them");
  s.add("break_gap", &P::break_gap).unit("m")
      .doc("a contact stops conducting when its gap exceeds max(break_gap, initial gap); 0 = the gap becomes positive");
  s.add("cutoff_gap", &P::cutoff_gap).unit("m").nonnegative().doc("h_max: springs join fillers with gap <= this");
  s.add("min_gap", &P::min_gap).unit("m").positive().doc("h_min: spring stiffness E_m A / max(h, h_min)");
  s.add("matrix_modulus", &P::matrix_modulus).unit("Pa").positive().doc("E_m (the openings do not depend on it)");
  s.add("bond_area", &P::bond_area).unit("m^2").positive().doc("A (the openings do not depend on it)");
  s.add("regularisation", &P::regularisation).nonnegative()
      .doc("ground spring on every filler, x mean spring stiffness: removes rigid-body and floppy modes");
  s.add("unit_conductance", &P::unit_conductance).unit("S").positive().doc("conductance of a conducting contact");
  s.add("length", &P::length).unit("m").nonnegative().doc("L of rho = R_eq L; 0: the box edge recorded by cpc_fillers");
  s.add("opening_strain", &P::opening_strain).nonnegative().doc("eps0 [1] of the opening statistics (paper: 1 %)");
  s.add("eps0_values", &P::eps0_values).doc("matrix eigenstrains eps0 [1] at which Z and rho are reported");
  s.add("temperatures", &P::temperatures).unit("K")
      .doc("temperatures at which eps0(T), Z and rho are reported, with the switching temperature (empty: no temperature columns)");
  s.add("expansion_coefficient", &P::expansion_coefficient).unit("1/K").positive()
      .doc("alpha_s: linear expansion coefficient of the matrix relative to the fillers (below the melting step)");
  s.add("expansion_coefficient_melt", &P::expansion_coefficient_melt).unit("1/K").nonnegative()
      .doc("alpha_l: the same above the melting step (0: alpha_s)");
  s.add("reference_temperature", &P::reference_temperature).unit("K").positive().doc("T_ref: eps0(T_ref) = 0 (the stress-free state)");
  s.add("melting_temperature", &P::melting_temperature).unit("K").nonnegative().doc("T_m: centre of the melting step (0: no melting step)");
  s.add("melting_strain", &P::melting_strain).unit("1").nonnegative()
      .doc("linear strain jump on melting (about Delta V / (3 V) of the host's volume change)");
  s.add("melting_width", &P::melting_width).unit("K").nonnegative().doc("width of the smoothed melting step (0: sharp)");
  return s;
}

void PtcStrain::declare(Declarations& d) const { d.reads_previous = {"position", "radius"}; }

void PtcStrain::bind(State& s) {
  clock_ = percolation::geometry_event_clock(s);
  length_ = percolation::box_length(s, p_.length, "ptc_strain");
}

void PtcStrain::advance(State& s, const StepInfo&) {
  ptc::MatrixParams mp;
  mp.matrix_modulus = p_.matrix_modulus;
  mp.bond_area = p_.bond_area;
  mp.min_gap = p_.min_gap;
  mp.cutoff_gap = p_.cutoff_gap;
  mp.touch_tolerance = p_.touch_tolerance;
  mp.regularisation = p_.regularisation;
  const std::size_t n = s.particles.size();
  const ptc::SpringNetwork net = ptc::build_network(s.particles.position, s.particles.radius, mp);
  const ptc::UnitSolution sol = ptc::solve_unit(n, net, mp);
  const ptc::Contacts c = ptc::touching_contacts(net, sol, p_.touch_tolerance);
  const std::vector<double> eb = ptc::break_strains(c, p_.break_gap);
  const std::vector<Index> high = members(s, p_.high), low = members(s, p_.low);

  std::vector<double> rel;
  std::size_t closing = 0;
  for (std::size_t e = 0; e < c.size(); ++e) {
    const double D = s.particles.radius[c.a[e]] + s.particles.radius[c.b[e]];
    rel.push_back(p_.opening_strain * c.opening[e] / D);
    if (c.opening[e] < 0.0) ++closing;
  }
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
    const ptc::StrainPoint sp = ptc::evaluate(n, c, eb, e0, p_.unit_conductance, high, low, solver_);
    if (!sp.spanning) listed = std::min(listed, e0);
    per.insert(per.end(), {sp.spanning ? 1.0 : 0.0, sp.coordination, sp.resistance * length_});
  }
  held_ = {static_cast<double>(net.size()),
           static_cast<double>(c.size()),
           ptc::switching_strain(n, c, eb, high, low),
           listed,
           mean,
           median,
           c.size() ? static_cast<double>(closing) / static_cast<double>(c.size()) : kNaN};
  held_.push_back(sol.residual);
  held_.insert(held_.end(), per.begin(), per.end());
  if (!tsuffix_.empty()) {
    held_.push_back(std::isfinite(held_[2]) ? ptc::temperature_at_strain(law_, held_[2]) : kInf);
    for (double T : p_.temperatures) {
      const double e0 = ptc::thermal_strain(law_, T);
      // eps0 < 0 (below T_ref): the break strains are for eps0 > 0; apply the rule of ptc_matrix.hpp
      // directly (a contact conducts while gap + eps0 delta <= max(break_gap, gap): on cooling the
      // contacts with delta < 0 open).
      std::vector<double> ebT = eb;
      if (e0 < 0.0)
        for (std::size_t e = 0; e < c.size(); ++e)
          ebT[e] = c.gap[e] + e0 * c.opening[e] <= std::max(p_.break_gap, c.gap[e]) ? kInf : -kInf;
      const ptc::StrainPoint sp = ptc::evaluate(n, c, ebT, e0, p_.unit_conductance, high, low, solver_);
      held_.insert(held_.end(), {e0, sp.spanning ? 1.0 : 0.0, sp.coordination, sp.resistance * length_});
    }
  }
  // Per-contact results for the frames: ids, initial gap, unit opening, break strain.
  contacts_ = EdgeOutput{"ptc_contacts", {}, {{"gap", "m", {}}, {"unit_opening", "m", {}}, {"break_strain", "1", {}}}};
  for (std::size_t e = 0; e < c.size(); ++e) {
    contacts_.pairs.push_back(s.particles.id[c.a[e]]);
    contacts_.pairs.push_back(s.particles.id[c.b[e]]);
    contacts_.fields[0].values.push_back(c.gap[e]);
    contacts_.fields[1].values.push_back(c.opening[e]);
    contacts_.fields[2].values.push_back(eb[e]);
  }
}

std::vector<std::string> PtcStrain::columns() const {
  std::vector<std::string> c = {"ptc_strain_springs", "ptc_strain_contacts", "ptc_strain_switching_strain",
                                "ptc_strain_switching_strain_listed", "ptc_strain_opening_mean", "ptc_strain_opening_median",
                                "ptc_strain_opening_negative_fraction", "ptc_strain_solve_residual"};
  for (const auto& sfx : suffix_)
    for (const char* q : {"spanning_", "coordination_", "resistivity_"}) c.push_back(std::string("ptc_strain_") + q + sfx);
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
      throw SetupError("checkpoint ptc_strain state has " + std::to_string(held.size()) + " values, expected " +
                       std::to_string(held_.size()));
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
    ar.visit(prefix + "/contact_values", vals, 3);
  }
  if (ar.reading()) {
    contacts_ = EdgeOutput{};
    if (!pairs.empty()) {
      if (vals.size() != 3 * (pairs.size() / 2)) throw SetupError("checkpoint ptc_strain contact data is inconsistent");
      contacts_ = EdgeOutput{"ptc_contacts", pairs, {{"gap", "m", {}}, {"unit_opening", "m", {}}, {"break_strain", "1", {}}}};
      for (std::size_t k = 0; k < pairs.size() / 2; ++k)
        for (int q = 0; q < 3; ++q) contacts_.fields[q].values.push_back(vals[3 * k + q]);
    }
  }
}

}  // namespace sparkdem::physics
