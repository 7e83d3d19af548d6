#pragma once
/// The one weighted-graph-Laplacian assembly and solve, shared by the electrical and thermal
/// modules and any later network model.
///
/// CONTRACT. Modules (electrical, thermal, percolation) build their matrices only through
/// InteractionGraph (engine/graph/interaction_graph.hpp) + the functions and LaplacianSolver
/// below; none walks the contact table. A module supplies one conductance g >= 0 per graph edge.
///
/// Equations. For nodes v = 0..N-1 and edges e = (a_e, b_e) with conductance g_e >= 0:
///     L_aa = sum_{e incident to a} g_e,   L_ab = -sum_{e joining a and b} g_e,
///     (L u)_a = sum_{e incident to a} g_e (u_a - u_other(e)),
/// i.e. Kirchhoff's current law at node a with branch currents g_e (u_a - u_b) leaving a.
/// The boundary-value problem solved by LaplacianSolver is
///     (L u)_v + s_v u_v = q_v     at every free node v,
///     u_v = U_v                   at every Dirichlet node v,
/// with injected source q_v (current [A], heat flow [W], ...) and an optional shunt s_v >= 0
/// (a conductance from v to the reference value 0; e.g. C_v / dt for a backward-Euler heat step,
/// where q_v then carries C_v T_v^old / dt). Edges with g_e == 0 and self-loops are ignored.
///
/// Floating parts. Union-find over the edges with g > 0 splits the nodes into connected
/// components. A component with no Dirichlet node and no positive shunt has no unique solution
/// (L is singular on it): its nodes are "floating", excluded from the solve, reported as NaN and
/// counted; their edges carry zero flux (the only flux compatible with zero injection). Sources
/// on floating nodes are ignored. This never reaches the factorisation as a singular matrix.
/// A problem with no Dirichlet node and no positive shunt at all is a SetupError.
///
/// Determinism. Assembly sums edge contributions in edge order into fixed slots; laplacian_apply
/// sums per node in ascending edge order through a CSR incidence. Results do not depend on the
/// thread count.
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <Eigen/SparseCore>

#include "engine/core/archive.hpp"
#include "engine/core/types.hpp"

namespace sparkdem {

struct InteractionGraph;

/// Per-node CSR incidence of an edge list: for node v, entries start[v] .. start[v+1]-1 list the
/// incident edges in ascending edge order (edge[k]) with the node at the other end (other[k]).
/// Self-loops are left out.
struct EdgeIncidence {
  std::vector<std::int64_t> start;
  std::vector<std::int64_t> edge;
  std::vector<Index> other;
  std::size_t edges = 0;  ///< length of the edge list it was built from
  void build(std::size_t nodes, std::span<const Index> a, std::span<const Index> b);
  std::size_t nodes() const { return start.empty() ? 0 : start.size() - 1; }
};

/// y_v = sum_{e incident to v} g_e (x_v - x_other(e)) = (L x)_v, matrix-free, for explicit
/// schemes (forward-Euler heat conduction). Edges with g == 0 are skipped (so a NaN at a node
/// joined only by g == 0 edges does not spread). Parallel over nodes, each node summed in edge
/// order: bit-identical for any thread count. y must have inc.nodes() entries.
void laplacian_apply(const EdgeIncidence& inc, std::span<const double> g, std::span<const double> x, std::span<double> y);
/// Convenience overload that builds the incidence (O(E) extra per call).
void laplacian_apply(std::size_t nodes, std::span<const Index> a, std::span<const Index> b, std::span<const double> g,
                     std::span<const double> x, std::span<double> y);

/// Diagonal of L, D_v = sum_{e incident to v} g_e (self-loops excluded), summed in edge order.
/// Gershgorin: lambda_max(C^-1 L) <= max_v 2 D_v / C_v, so forward Euler on C du/dt = -L u is
/// stable for dt <= min_v C_v / D_v.
std::vector<double> laplacian_diagonal(std::size_t nodes, std::span<const Index> a, std::span<const Index> b,
                                       std::span<const double> g);

/// The full N x N Laplacian (column-major, compressed), for tests and small dense studies.
Eigen::SparseMatrix<double> assemble_laplacian(std::size_t nodes, std::span<const Index> a, std::span<const Index> b,
                                               std::span<const double> g);

/// Nodes held at one value (an electrode, an isothermal wall, ...). Its net flux is reported.
struct DirichletGroup {
  std::vector<Index> nodes;
  double value = 0.0;
};

/// Input of one solve. The spans must stay valid during solve().
struct LaplacianProblem {
  std::size_t nodes = 0;
  std::span<const Index> a, b;            ///< edge end points
  std::span<const double> g;              ///< conductance per edge, >= 0 (0 = no edge)
  std::vector<DirichletGroup> dirichlet;  ///< disjoint node sets with prescribed values
  std::span<const double> source;         ///< injected q_v per node (empty = none); ignored at Dirichlet nodes
  std::span<const double> shunt;          ///< s_v >= 0 per node (empty = none)
  Step step = -1;                         ///< for error messages only

  /// Problem on the nodes and edges of a graph with one conductance per edge.
  static LaplacianProblem on(const InteractionGraph& graph, std::span<const double> g);
};

enum class LaplacianMethod : std::uint8_t {
  Direct,        ///< Eigen::SimplicialLDLT (AMD ordering); exact up to rounding
  CgIncompleteCholesky,  ///< conjugate gradients, incomplete-Cholesky preconditioner, warm start
  CgDiagonal,    ///< conjugate gradients, Jacobi preconditioner, warm start
};

struct LaplacianOptions {
  LaplacianMethod method = LaplacianMethod::Direct;
  double tolerance = 1e-10;  ///< CG: stop when ||b - A x|| <= tolerance ||b|| (reduced system)
  int max_iterations = 0;    ///< CG: 0 = Eigen's default (2 x unknowns)
  bool warm_start = true;    ///< CG: start from the previous solution (per node) when available
};

struct LaplacianResult {
  std::vector<double> value;           ///< u per node; NaN on floating nodes
  std::vector<double> flux;            ///< per edge g_e (u_a - u_b), from a to b; 0 for ignored/floating edges
  std::vector<double> dirichlet_flux;  ///< per Dirichlet group: net flux leaving its nodes into the network
  double residual_norm = 0.0;          ///< ||A x - b||_2 of the reduced system
  double relative_residual = 0.0;      ///< residual_norm / ||b||_2 (residual_norm if b = 0)
  int iterations = 0;                  ///< CG iterations (0 for the direct method)
  std::size_t free_nodes = 0;          ///< unknowns of the reduced system
  std::size_t floating_nodes = 0;      ///< nodes in components with no Dirichlet node and no shunt
  std::size_t floating_components = 0;
  bool analyzed = false;               ///< this call recomputed the symbolic analysis (structure changed)
  bool factorized = false;             ///< this call recomputed the numeric factorisation / preconditioner
  double solve_seconds = 0.0;          ///< wall time of the whole call
};

/// Solves LaplacianProblems in sequence, keeping what can be kept between calls:
///  - the symbolic analysis (ordering, pattern) while the structure is unchanged: same node
///    count, same edge list (a, b) with the same set of edges with g > 0, same Dirichlet nodes,
///    same shunted nodes (checked exactly, not by hash);
///  - the numeric factorisation (or preconditioner) while in addition the matrix values (the
///    conductances and shunts) are unchanged; otherwise only factorize() runs;
///  - the previous solution per node, as the CG warm start.
/// Of these only the warm start changes results (CG stops at a tolerance); it is exposed by
/// visit() for checkpoints. The factorisation is recomputed after a restart, which gives the
/// same numbers (it is a deterministic function of the matrix).
class LaplacianSolver {
 public:
  explicit LaplacianSolver(LaplacianOptions opt = {});
  ~LaplacianSolver();
  LaplacianSolver(LaplacianSolver&&) noexcept;
  LaplacianSolver& operator=(LaplacianSolver&&) noexcept;

  /// Solve. Throws SetupError for malformed input (sizes, node indices, a node in two Dirichlet
  /// groups or twice in one, no Dirichlet node and no shunt) and PhysicsError for a
  /// negative or non-finite conductance, shunt, source or Dirichlet value, or a failed
  /// factorisation / CG that does not reach the tolerance.
  LaplacianResult solve(const LaplacianProblem& p);

  const LaplacianOptions& options() const { return opt_; }
  /// Change the options; a different method drops the cached analysis.
  void set_options(const LaplacianOptions& opt);

  std::size_t analyses() const { return analyses_; }         ///< symbolic analyses so far
  std::size_t factorizations() const { return factorizations_; }  ///< numeric factorisations so far
  /// Drop the cached analysis and factorisation (the warm start is kept).
  void invalidate();

  /// Previous solution per node (NaN where unknown); empty before the first solve.
  const std::vector<double>& warm_start() const { return warm_; }
  void reset_warm_start() { warm_.clear(); }
  /// Follow a renumbering of the particle nodes (new[i] = old[perm[i]], the convention of
  /// ParticleStore::permute and filter): the old nodes old_particle_nodes.. (walls) follow the
  /// new particle nodes in their order.
  void permute_warm_start(const std::vector<Index>& perm, std::size_t old_particle_nodes);

  /// Store/restore the state that affects results (the warm start) under prefix/.
  void visit(Archive& ar, const std::string& prefix);

 private:
  struct Impl;
  LaplacianOptions opt_;
  std::unique_ptr<Impl> impl_;
  std::vector<double> warm_;
  std::size_t analyses_ = 0, factorizations_ = 0;
};

}  // namespace sparkdem
