#include "physics/electrical/contact_percolation.hpp"
#include "physics/electrical/ptc_gaps.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <utility>

#include "engine/core/error.hpp"
#include "engine/graph/interaction_graph.hpp"
#include "engine/state/particle_set.hpp"
#include "engine/state/state.hpp"
#include "engine/core/numbers.hpp"

namespace sparkdem::physics {

namespace percolation {

Metrics metrics(std::size_t n, std::span<const Index> a, std::span<const Index> b, std::span<const Index> high, std::span<const Index> low) {
  Metrics m;
  if (n == 0) return m;
  std::set<std::pair<Index, Index>> distinct;
  for (std::size_t e = 0; e < a.size(); ++e)
    if (a[e] != b[e]) distinct.insert({std::min(a[e], b[e]), std::max(a[e], b[e])});
  m.touching_pairs = distinct.size();
  m.coordination = 2.0 * static_cast<double>(distinct.size()) / static_cast<double>(n);
  const std::vector<double> g(a.size(), 1.0);
  const std::vector<Index> root = component_roots(n, a, b, g);
  std::vector<std::size_t> size(n, 0);
  for (Index r : root) ++size[r];
  m.largest_cluster_fraction = static_cast<double>(*std::max_element(size.begin(), size.end())) / static_cast<double>(n);
  std::vector<char> at_high(n, 0), spans(n, 0);
  for (Index v : high) at_high[root[v]] = 1;
  for (Index v : low)
    if (at_high[root[v]] && !spans[root[v]]) {
      spans[root[v]] = 1;
      ++m.spanning_clusters;
    }
  m.spanning = m.spanning_clusters > 0;
  return m;
}

std::vector<double> cluster_resistances(std::size_t n, std::span<const Index> a, std::span<const Index> b, double g_unit,
                                        std::span<const Index> high, std::span<const Index> low, LaplacianSolver& solver) {
  std::vector<double> out;
  if (n == 0 || high.empty() || low.empty()) return out;
  const std::vector<double> g(a.size(), g_unit);
  const std::vector<Index> root = component_roots(n, a, b, g);
  std::vector<char> is_high(n, 0), at_high(n, 0), spans(n, 0);
  for (Index v : high) {
    is_high[v] = 1;
    at_high[root[v]] = 1;
  }
  for (Index v : low)
    if (at_high[root[v]]) spans[root[v]] = 1;
  // Keep only the edges of spanning clusters: the rest carries no current, and a cluster that
  // touches a single electrode would only add unknowns.
  std::vector<Index> ea, eb;
  for (std::size_t e = 0; e < a.size(); ++e)
    if (spans[root[a[e]]] && a[e] != b[e]) {
      ea.push_back(a[e]);
      eb.push_back(b[e]);
    }
  if (ea.empty()) return out;
  const std::vector<double> ge(ea.size(), g_unit);
  LaplacianProblem p;
  p.nodes = n;
  p.a = ea;
  p.b = eb;
  p.g = ge;
  std::vector<Index> hi, lo;
  for (Index v : high) hi.push_back(v);
  for (Index v : low)
    if (!is_high[v]) lo.push_back(v);
  p.dirichlet = {{hi, 1.0}, {lo, 0.0}};
  const LaplacianResult r = solver.solve(p);
  // I_k: flux (a -> b) on edges leaving a high node into a non-high node of cluster k.
  std::vector<double> current(n, 0.0);
  for (std::size_t e = 0; e < ea.size(); ++e) {
    if (is_high[ea[e]] && !is_high[eb[e]]) current[root[ea[e]]] += r.flux[e];
    if (is_high[eb[e]] && !is_high[ea[e]]) current[root[eb[e]]] -= r.flux[e];
  }
  for (std::size_t c = 0; c < n; ++c)
    if (spans[c]) out.push_back(current[c] > 0.0 ? 1.0 / current[c] : 0.0);  // 0: a high node also in low (short)
  return out;
}

}  // namespace percolation

ParamSpec<ContactPercolation::Params> ContactPercolation::spec() {
  using P = Params;
  ParamSpec<P> s("contact_percolation", "module",
                 "seed 002 connectivity of the touching-contact graph: spanning between two electrode sets, largest cluster, "
                 "coordination Z, R_eq (from electrical_network) and resistivity rho = R_eq L; optionally the paper's mean "
                 "resistance over spanning clusters");
  s.add("high", &P::high).doc("electrode particle set on one face (e.g. touching_wall of the cpc_fillers wall xlo)");
  s.add("low", &P::low).doc("electrode particle set on the opposite face");
  s.add("touch_gap_rel", &P::touch_gap_rel)
      .unit("1")
      .nonnegative()
      .doc("pairs with a surface gap up to this x (R_i + R_j) touch (paper: 0.1 % of D = 1e-3); for equal fillers the "
           "electrical_network's touch_tolerance_relative (of the mean radius) is twice this");
  s.retire("touch_tolerance", ptc::retired_gap("touch_tolerance", "touch_gap_rel", "0.1 % of D: 1e-3, i.e. the old 2e-3 m at R = 1 m"));
  s.add("length", &P::length).unit("m").nonnegative().doc("L of rho = R_eq L; 0: the box edge recorded by cpc_fillers");
  s.add("cluster_resistances", &P::cluster_resistances)
      .doc("also solve each spanning cluster alone (unit conductances): the paper's arithmetic mean of R over spanning clusters");
  s.add("unit_conductance", &P::unit_conductance).unit("S").positive().doc("cluster_resistances: conductance of a touching pair");
  return s;
}

void ContactPercolation::declare(Declarations& d) const { d.reads_previous = {"position", "radius"}; }

Clock percolation::geometry_event_clock(const State& s) {
  double rmin = kInf;
  for (double r : s.particles.radius) rmin = std::min(rmin, r);
  Clock c;
  c.kind = Clock::Kind::OnEvent;
  c.trigger.bond_broke = true;
  c.trigger.moved_beyond = std::isfinite(rmin) ? 0.05 * rmin : 1.0;
  return c;
}

double percolation::box_length(const State& s, double given, const std::string& module) {
  if (given > 0.0) return given;
  const auto it = s.marks.find("cpc_fillers/box_length");
  if (it == s.marks.end()) throw SetupError(module + ": `length` is 0 and no cpc_fillers stage recorded a box length; give length [m]");
  return it->second;
}

void ContactPercolation::bind(State& s) {
  clock_ = percolation::geometry_event_clock(s);
  length_ = percolation::box_length(s, p_.length, "contact_percolation");
}

void ContactPercolation::advance(State& s, const StepInfo&) {
  GraphOptions go;
  go.bonds = false;
  const auto& r = s.particles.radius;
  go.near_gap = r.empty() ? 0.0 : 2.0 * *std::max_element(r.begin(), r.end()) * p_.touch_gap_rel;
  const InteractionGraph g = build_interaction_graph(s, go);
  std::vector<Index> a, b;
  for (std::size_t e = 0; e < g.size(); ++e)
    if ((g.kind[e] == EdgeKind::Contact || g.kind[e] == EdgeKind::Near || g.kind[e] == EdgeKind::Neck) &&
        g.overlap[e] >= -p_.touch_gap_rel * (r[g.a[e]] + r[g.b[e]])) {
      a.push_back(g.a[e]);
      b.push_back(g.b[e]);
    }
  const std::vector<Index> high = set_members(s, p_.high, "contact_percolation"), low = set_members(s, p_.low, "contact_percolation");
  const percolation::Metrics m = percolation::metrics(s.particles.size(), a, b, high, low);
  double mean = kNaN, parallel = kNaN;
  if (p_.cluster_resistances) {
    const std::vector<double> rk = percolation::cluster_resistances(s.particles.size(), a, b, p_.unit_conductance, high, low, solver_);
    if (rk.empty()) {
      mean = parallel = kInf;
    } else {
      double sum = 0.0, inv = 0.0;
      for (double r : rk) {
        sum += r;
        inv += r > 0.0 ? 1.0 / r : kInf;
      }
      mean = sum / static_cast<double>(rk.size());
      parallel = 1.0 / inv;
    }
  }
  held_ = {m.spanning ? 1.0 : 0.0,
           static_cast<double>(m.spanning_clusters),
           m.largest_cluster_fraction,
           m.coordination,
           static_cast<double>(m.touching_pairs),
           mean,
           parallel};
}

std::vector<std::string> ContactPercolation::columns() const {
  std::vector<std::string> c = {
      "contact_percolation_spanning",     "contact_percolation_spanning_clusters", "contact_percolation_largest_cluster_fraction",
      "contact_percolation_coordination", "contact_percolation_touching_pairs",    "contact_percolation_resistance",
      "contact_percolation_resistivity",  "contact_percolation_conductivity"};
  if (p_.cluster_resistances)
    for (const char* x : {"contact_percolation_resistance_cluster_mean", "contact_percolation_resistivity_cluster_mean",
                          "contact_percolation_resistance_parallel"})
      c.push_back(x);
  return c;
}

std::vector<double> ContactPercolation::column_values(const State& s) const {
  // R_eq of the electrical_network's last solve (-1 there means no spanning path).
  double R = kNaN;
  const auto it = s.marks.find("signal/electrical_resistance");
  if (it != s.marks.end()) R = it->second < 0.0 ? kInf : it->second;
  const double rho = R * length_;
  const double sigma = std::isnan(rho) ? kNaN : (std::isinf(rho) ? 0.0 : 1.0 / rho);
  std::vector<double> v(held_.begin(), held_.begin() + 5);
  v.insert(v.end(), {R, rho, sigma});
  if (p_.cluster_resistances) v.insert(v.end(), {held_[5], held_[5] * length_, held_[6]});
  return v;
}

void ContactPercolation::visit(Archive& ar, const std::string& prefix) {
  std::vector<double> held = held_;
  ar.visit(prefix + "/held", held);
  if (ar.reading()) {
    if (held.size() != 7)
      throw SetupError("checkpoint contact_percolation state has " + std::to_string(held.size()) + " values, expected 7");
    held_ = held;
  }
  solver_.visit(ar, prefix + "/solver");
}

}  // namespace sparkdem::physics
