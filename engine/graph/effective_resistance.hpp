#pragma once
/// Effective resistance between two electrodes by static condensation, done sparsely
/// (cpc-and-networks.md §2.4-2.5): never a dense pseudo-inverse.
///
/// Union-find over the conducting edges (g > 0) splits the network into connected components.
/// Only components that touch BOTH electrodes carry current ("spanning"); the others are found
/// and left out of the solve: a component touching one electrode only is at that electrode's
/// potential and carries no current, one touching neither floats (NaN). The solve runs on the
/// spanning nodes alone (renumbered compactly, edges in their original order), with the high
/// electrode's nodes at `voltage` and the low electrode's at 0, through the caller's
/// LaplacianSolver (any method; its analysis is reused while the spanning subnetwork keeps its
/// structure). Then I = the current leaving the high electrode, G = I / voltage, R = voltage / I.
/// No spanning component (or I == 0): G = 0 exactly and R = +inf, never NaN.
#include <cstddef>
#include <limits>
#include <span>
#include <vector>

#include "engine/core/types.hpp"
#include "engine/graph/laplacian.hpp"

namespace sparkdem {

struct EffectiveResistance {
  double conductance = 0.0;                                     ///< G = I / voltage [S]; exactly 0 without a spanning path
  double resistance = std::numeric_limits<double>::infinity();  ///< R = voltage / I [Ohm]; +inf without one
  double current = 0.0;                                         ///< I leaving the high electrode into the network [A]
  double current_low = 0.0;                                     ///< current leaving the low electrode (= -I up to the solver's tolerance)
  double voltage = 0.0;                                         ///< potential of the high electrode (the low one is at 0) [V]
  bool spanning = false;                                        ///< at least one component touches both electrodes
  std::size_t spanning_components = 0;
  std::size_t spanning_nodes = 0;          ///< nodes solved (electrode nodes included)
  std::size_t single_electrode_nodes = 0;  ///< in components touching one electrode only (excluded)
  std::size_t floating_nodes = 0;          ///< in components touching neither electrode (excluded)
  std::size_t floating_components = 0;
  std::vector<double> value;  ///< potential per node: solved, the electrode's for single-electrode components, NaN floating
  std::vector<double> flux;   ///< current per edge, a -> b (0 outside the spanning components)
  LaplacianResult solve;      ///< the solve on the spanning subnetwork (its own compact numbering)
};

/// `network` supplies nodes, edges, conductances (and the capacitance, for the pseudo-transient
/// method); its dirichlet, source and shunt must be empty. high / low: the electrode nodes
/// (disjoint; an empty electrode gives G = 0). Throws SetupError for malformed input (see
/// LaplacianSolver::solve) or a voltage that is 0 or not finite, PhysicsError as the solve does.
EffectiveResistance effective_resistance(LaplacianSolver& solver, const LaplacianProblem& network, std::span<const Index> high,
                                         std::span<const Index> low, double voltage = 1.0);

}  // namespace sparkdem
