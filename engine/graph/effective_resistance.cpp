#include "engine/graph/effective_resistance.hpp"

#include <cmath>
#include <numeric>
#include <string>

#include "engine/core/error.hpp"

namespace sparkdem {

EffectiveResistance effective_resistance(LaplacianSolver& solver, const LaplacianProblem& net, std::span<const Index> high,
                                         std::span<const Index> low, double voltage) {
  const std::size_t n = net.nodes, ne = net.a.size();
  if (!net.dirichlet.empty() || !net.source.empty() || !net.shunt.empty())
    throw SetupError(
        "effective_resistance: the network must have no Dirichlet groups, sources or shunts (the "
        "electrodes are given separately)");
  if (!std::isfinite(voltage) || voltage == 0.0)
    throw SetupError("effective_resistance: the electrode voltage must be finite and non-zero");
  if (net.b.size() != ne || net.g.size() != ne) throw SetupError("effective_resistance: edge lists and conductances differ in length");
  if (!net.capacitance.empty() && net.capacitance.size() != n)
    throw SetupError("effective_resistance: capacitance has " + std::to_string(net.capacitance.size()) + " entries for " +
                     std::to_string(n) + " nodes");
  // 1 = high, 2 = low.
  std::vector<std::uint8_t> electrode(n, 0);
  for (int side = 1; side <= 2; ++side)
    for (const Index v : side == 1 ? high : low) {
      if (v < 0 || static_cast<std::size_t>(v) >= n)
        throw SetupError("effective_resistance: electrode node " + std::to_string(v) + " outside 0.." + std::to_string(n) + "-1");
      if (electrode[v] != 0)
        throw SetupError("effective_resistance: node " + std::to_string(v) +
                         (electrode[v] == side ? " is listed twice in one electrode" : " is in both electrodes"));
      electrode[v] = static_cast<std::uint8_t>(side);
    }

  // Components over the conducting edges.
  for (std::size_t e = 0; e < ne; ++e) {
    const Index a = net.a[e], b = net.b[e];
    if (a < 0 || b < 0 || static_cast<std::size_t>(a) >= n || static_cast<std::size_t>(b) >= n)
      throw SetupError("effective_resistance: edge " + std::to_string(e) + " refers to a node outside 0.." + std::to_string(n) + "-1");
    if (!(net.g[e] >= 0.0) || !std::isfinite(net.g[e]))
      throw PhysicsError(net.step, {}, "conductance",
                         "edge " + std::to_string(e) + " (nodes " + std::to_string(a) + ", " + std::to_string(b) +
                             ") has g = " + std::to_string(net.g[e]) + "; conductances must be finite and >= 0");
  }
  const std::vector<Index> root = component_roots(n, net.a, net.b, net.g);
  std::vector<std::uint8_t> touches(n, 0);  // per root: bit 1 high, bit 2 low
  for (std::size_t v = 0; v < n; ++v)
    if (electrode[v]) touches[root[v]] |= electrode[v];

  EffectiveResistance out;
  out.voltage = voltage;
  out.value.assign(n, std::numeric_limits<double>::quiet_NaN());
  out.flux.assign(ne, 0.0);
  std::vector<Index> sub(n, -1), sub_nodes;
  for (std::size_t v = 0; v < n; ++v) {
    const Index r = root[v];
    const bool is_root = r == static_cast<Index>(v);
    switch (touches[r]) {
      case 3:
        sub[v] = static_cast<Index>(sub_nodes.size());
        sub_nodes.push_back(static_cast<Index>(v));
        if (is_root) ++out.spanning_components;
        break;
      case 1:
        out.value[v] = voltage;
        ++out.single_electrode_nodes;
        break;
      case 2:
        out.value[v] = 0.0;
        ++out.single_electrode_nodes;
        break;
      default:
        ++out.floating_nodes;
        if (is_root) ++out.floating_components;
    }
  }
  out.spanning_nodes = sub_nodes.size();
  out.spanning = out.spanning_components > 0;
  if (!out.spanning) return out;

  // The spanning subnetwork, compactly renumbered, edges in their original order.
  std::vector<Index> sa, sb;
  std::vector<double> sg, sc;
  std::vector<std::size_t> edge_of;
  for (std::size_t e = 0; e < ne; ++e) {
    // A conducting edge has both ends in one component; a g = 0 edge may join a spanning node to
    // an excluded one: it carries nothing and is dropped.
    if (sub[net.a[e]] < 0 || sub[net.b[e]] < 0) continue;
    sa.push_back(sub[net.a[e]]);
    sb.push_back(sub[net.b[e]]);
    sg.push_back(net.g[e]);
    edge_of.push_back(e);
  }
  if (!net.capacitance.empty())
    for (const Index v : sub_nodes) sc.push_back(net.capacitance[v]);
  LaplacianProblem p;
  p.nodes = sub_nodes.size();
  p.a = sa;
  p.b = sb;
  p.g = sg;
  p.capacitance = sc;
  p.step = net.step;
  p.dirichlet.resize(2);
  p.dirichlet[0].value = voltage;
  p.dirichlet[1].value = 0.0;
  for (const Index v : sub_nodes) {
    if (electrode[v] == 1) p.dirichlet[0].nodes.push_back(sub[v]);
    if (electrode[v] == 2) p.dirichlet[1].nodes.push_back(sub[v]);
  }
  out.solve = solver.solve(p);
  for (std::size_t k = 0; k < sub_nodes.size(); ++k) out.value[sub_nodes[k]] = out.solve.value[k];
  for (std::size_t k = 0; k < edge_of.size(); ++k) out.flux[edge_of[k]] = out.solve.flux[k];
  out.current = out.solve.dirichlet_flux[0];
  out.current_low = out.solve.dirichlet_flux[1];
  if (out.current != 0.0) {
    out.conductance = out.current / voltage;
    out.resistance = voltage / out.current;
  }
  return out;
}

}  // namespace sparkdem
