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
std::vector<double> laplacian_diagonal(std::size_t nodes, std::span<const Index> a, std::span<const Index> b, std::span<const double> g);

/// Result of max_generalized_eigenvalue.
struct EigenEstimate {
  double value = 0.0;           ///< Ritz value theta <= lambda_max (exact arithmetic)
  double residual_bound = 0.0;  ///< ||B y - theta y|| of the Ritz pair: an eigenvalue lies within it
  int iterations = 0;           ///< Lanczos steps (one matrix-vector product each)
  bool converged = false;       ///< residual_bound <= rel_tol * value (or an exact invariant subspace)
};

/// lambda_max(C^-1 A) for a symmetric positive semi-definite A (both triangles stored) and C > 0
/// per row, by the Lanczos iteration on the symmetric B = C^-1/2 A C^-1/2 (same eigenvalues). It is
/// the Krylov form of the power iteration: the same products, from a fixed deterministic start
/// vector, but it converges in tens of steps where the plain power iteration needs thousands when
/// the top eigenvalues cluster (measured on a random polydisperse network: power iteration
/// 1e-3 relative error after 30 steps, 7e-6 after 1000; Lanczos 2e-9 after 20). Stops when the
/// residual bound of the largest Ritz pair is <= rel_tol x its value. Deterministic for any thread
/// count (fixed-order block sums).
EigenEstimate max_generalized_eigenvalue(const Eigen::SparseMatrix<double>& A, std::span<const double> C, double rel_tol = 1e-6,
                                         int max_iterations = 300);

/// The cheap safe pseudo-transient step min_v C_v / A_vv (Gershgorin: every eigenvalue of C^-1 A
/// lies in a disc of centre A_vv / C_v and radius sum_{w != v} |A_vw| / C_v <= A_vv / C_v, so
/// lambda_max <= max_v 2 A_vv / C_v, so this step is <= the true limit 2 / lambda_max; for two
/// nodes, one of them prescribed, it is exactly half of it, Eq. 43). A_vv = sum_j K_vj (+ shunt)
/// is the whole row of the Laplacian: the note's rule (sintering-electrical.md §2.10). +inf for an
/// empty matrix.
double gershgorin_step(const Eigen::SparseMatrix<double>& A, std::span<const double> C);

/// The full N x N Laplacian (column-major, compressed), for tests and small dense studies.
Eigen::SparseMatrix<double> assemble_laplacian(std::size_t nodes, std::span<const Index> a, std::span<const Index> b,
                                               std::span<const double> g);

/// Connected components over the conducting edges (g != 0 and not NaN, a != b: a negative element entry joins its nodes too), by union-find: the root of
/// every node, which is the smallest node index of its component (deterministic). Node
/// indices must be valid. The one component search shared by the Laplacian solver, the
/// effective resistance and the network modules.
std::vector<Index> component_roots(std::size_t nodes, std::span<const Index> a, std::span<const Index> b, std::span<const double> g);

/// Nodes held at one value (an electrode, an isothermal wall, ...). Its net flux is reported.
struct DirichletGroup {
  std::vector<Index> nodes;
  double value = 0.0;
};

/// Input of one solve. The spans must stay valid during solve().
struct LaplacianProblem {
  std::size_t nodes = 0;
  std::span<const Index> a, b;  ///< edge end points
  std::span<const double> g;    ///< conductance per edge, >= 0 (0 = no edge)
  /// Accept negative conductances: the edges of a multi-terminal element whose matrix is
  /// positive semi-definite with zero row sums but not an M-matrix (the sphere element of
  /// physics/electrical/sphere_element.hpp). The caller guarantees that the assembled matrix is
  /// positive semi-definite; the pseudo-transient method then has no stability guarantee.
  bool signed_conductances = false;
  std::vector<DirichletGroup> dirichlet;  ///< disjoint node sets with prescribed values
  std::span<const double> source;         ///< injected q_v per node (empty = none); ignored at Dirichlet nodes
  std::span<const double> shunt;          ///< s_v >= 0 per node (empty = none)
  std::span<const double> capacitance;    ///< C_v > 0 per node [F]: PseudoTransient only (required there)
  Step step = -1;                         ///< for error messages only

  /// Problem on the nodes and edges of a graph with one conductance per edge.
  static LaplacianProblem on(const InteractionGraph& graph, std::span<const double> g);
};

enum class LaplacianMethod : std::uint8_t {
  Direct,                ///< Eigen::SimplicialLDLT (AMD ordering); exact up to rounding
  CgIncompleteCholesky,  ///< conjugate gradients, incomplete-Cholesky preconditioner, warm start
  CgDiagonal,            ///< conjugate gradients, Jacobi preconditioner, warm start
  PseudoTransient,       ///< the explicit pseudo-transient iteration of seed 000 (Eqs. 10-15), warm start
  Amg,                   ///< conjugate gradients preconditioned by hypre's BoomerAMG, warm start
};

/// "direct", "cg_ic", "cg_jacobi", "pseudo_transient", "amg".
const char* laplacian_method_name(LaplacianMethod m);

/// Denominator of the change indicator of the pseudo-transient iteration.
enum class ChangeIndicator : std::uint8_t {
  /// Eq. 14 as printed: eps = max_n |V_n^{i+1} - V_n^i| / |V_n^{i+1}| over the free nodes (a node
  /// at exactly 0 V that still changes makes eps infinite).
  PerNode,
  /// The note's fix (sintering-electrical.md §7.6): eps = max_n |V_n^{i+1} - V_n^i| / S with S the
  /// spread of the Dirichlet values (max - min); if that is 0, S = max_n |V_n^{i+1}| over the
  /// free nodes; if that is 0 too, S = 1.
  Range,
};

/// The pseudo-transient iteration (seed 000, Eqs. 10-15): with a diagonal "capacitance" C > 0
/// (LaplacianProblem::capacitance, C_v = m_v c_v) and pseudo time step dt,
///     x^{i+1} = x^i + dt C^-1 (b - A x^i)            (forward Euler on C dx/dt + A x = b)
/// on the reduced system A x = b (A = K_uu + shunts). It converges iff dt < 2 / lambda_max(C^-1 A)
/// (the "true limit", computed for the whole network before iterating; §2.10). It stops when the
/// change indicator (Eq. 14) falls below beta. CAVEAT: the indicator is not the error: near
/// convergence the change per iteration is (1 - rho) times the error, rho -> 1 the slowest mode's
/// factor, so a small indicator can hide a large error; the true residual is reported beside it.
struct PseudoTransientOptions {
  double dt = 0.0;           ///< pseudo time step [s]; 0 = dt_fraction x the true limit
  double dt_fraction = 0.9;  ///< used when dt == 0; must be in (0, 1) unless allow_unstable
  double beta = 2e-4;        ///< stop when the change indicator < beta (the paper's value)
  ChangeIndicator indicator = ChangeIndicator::PerNode;
  /// Run a dt at or above the true limit instead of refusing it (PhysicsError). The divergence
  /// is then detected and reported as a PhysicsError, never returned as a silent NaN.
  bool allow_unstable = false;
  /// Divergence test: stop with a PhysicsError once the capacitance-weighted norm of the update,
  /// ||x^{i+1} - x^i||_C (non-increasing for a stable dt, in exact arithmetic), exceeds this factor
  /// times its smallest value so far, or becomes non-finite.
  double divergence_factor = 100.0;
  double eigen_tolerance = 1e-6;   ///< relative accuracy of lambda_max (see max_generalized_eigenvalue)
  int eigen_max_iterations = 300;  ///< Lanczos steps at most
};

struct LaplacianOptions {
  LaplacianMethod method = LaplacianMethod::Direct;
  double tolerance = 1e-10;           ///< CG / Amg: stop when ||b - A x|| <= tolerance ||b|| (reduced system)
  int max_iterations = 0;             ///< CG / Amg: 0 = 2 x unknowns; PseudoTransient: 0 = 1,000,000
  bool warm_start = true;             ///< iterative methods: start from the previous solution (per node) when available
  PseudoTransientOptions pseudo{};    ///< PseudoTransient only
  double amg_strong_threshold = 0.5;  ///< Amg: BoomerAMG strength threshold (0.5 suits 3-D networks)
  int amg_aggressive_levels = 1;      ///< Amg: levels of aggressive coarsening (1 halves the 1e6-node time)
  /// Amg on several MPI ranks (set_amg_spread_ranks > 1): spread systems of at least this many
  /// unknowns over the ranks (below, the messages cost more than the second rank saves).
  std::int64_t amg_spread_min_rows = 200000;
  /// Amg: hand hypre the rows in breadth-first order (HypreAmgPcg::Settings::breadth_first;
  /// false: as numbered, the order of sparkdem before issue 23 item 5).
  bool amg_breadth_first = true;
  /// Amg: eliminate the rows with at most two off-diagonal entries exactly before the AMG solve
  /// (dead-end branches, series chains; engine/graph/low_degree_elimination.hpp) and recover them
  /// after it. Same answer to the tolerance, fewer unknowns (a third of the 1e6-node packing
  /// network); false: the whole reduced system goes to hypre (sparkdem before issue 40 item 4).
  bool amg_eliminate_low_degree = true;
};

/// What the pseudo-transient iteration reports besides the common fields.
struct PseudoTransientReport {
  double dt = 0.0;                     ///< step used [s]
  double lambda_max = 0.0;             ///< estimate of lambda_max(C^-1 A) [1/s] (a Ritz value: <= the exact one)
  double lambda_residual_bound = 0.0;  ///< some eigenvalue lies within this of lambda_max (Lanczos residual)
  int eigen_iterations = 0;            ///< Lanczos steps
  double dt_limit = 0.0;               ///< true stability limit 2 / lambda_max [s]
  double dt_gershgorin = 0.0;          ///< the cheap safe step min_v C_v / A_vv [s] (Gershgorin; <= dt_limit)
  double change_indicator = 0.0;       ///< Eq. 14 indicator at stop (not the error: see relative_residual)
};

struct LaplacianResult {
  std::vector<double> value;           ///< u per node; NaN on floating nodes
  std::vector<double> flux;            ///< per edge g_e (u_a - u_b), from a to b; 0 for ignored/floating edges
  std::vector<double> dirichlet_flux;  ///< per Dirichlet group: net flux leaving its nodes into the network
  double residual_norm = 0.0;          ///< ||A x - b||_2 of the reduced system (recomputed: the true residual)
  double relative_residual = 0.0;      ///< residual_norm / ||b||_2 (residual_norm if b = 0)
  int iterations = 0;                  ///< CG / Amg / pseudo-transient iterations (0 for the direct method)
  std::size_t free_nodes = 0;          ///< unknowns of the reduced system
  std::size_t floating_nodes = 0;      ///< nodes in components with no Dirichlet node and no shunt
  std::size_t floating_components = 0;
  bool analyzed = false;         ///< this call recomputed the symbolic analysis (structure changed)
  bool factorized = false;       ///< this call recomputed the numeric factorisation / preconditioner
  double solve_seconds = 0.0;    ///< wall time of the whole call
  int amg_ranks = 1;             ///< Amg: MPI ranks the solve was spread over (set_amg_spread_ranks)
  std::size_t eliminated_rows = 0;  ///< Amg: unknowns eliminated exactly before the AMG solve (amg_eliminate_low_degree)
  PseudoTransientReport pseudo;  ///< PseudoTransient only
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
  /// groups or twice in one, no Dirichlet node and no shunt, PseudoTransient without a
  /// capacitance or with a step <= 0) and PhysicsError for a negative or non-finite conductance,
  /// shunt, source or Dirichlet value, a capacitance <= 0, a failed factorisation / CG / AMG
  /// that does not reach the tolerance, a pseudo-transient step at or above the true stability
  /// limit (unless allow_unstable), a diverging or non-converging pseudo-transient iteration.
  ///
  /// What "analysis" and "factorisation" mean per method: Direct: ordering + symbolic / numeric
  /// LDL^T; CG: nothing / the preconditioner; Amg: nothing / the AMG hierarchy; PseudoTransient:
  /// nothing / lambda_max and the Gershgorin step (also redone when the capacitance changes).
  LaplacianResult solve(const LaplacianProblem& p);

  const LaplacianOptions& options() const { return opt_; }
  /// Change the options; a different method drops the cached analysis.
  void set_options(const LaplacianOptions& opt);

  std::size_t analyses() const { return analyses_; }              ///< symbolic analyses so far
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
  /// The numeric factorisation step of solve() (laplacian.cpp).
  void factorize_(const LaplacianProblem& p, const std::vector<double>& cap_free, LaplacianResult& res);
  /// The iterative solution step of solve() (laplacian.cpp).
  Eigen::VectorXd iterate_(const LaplacianProblem& p, const std::vector<Index>& free_node, const Eigen::VectorXd& rhs, double fallback,
                           LaplacianResult& res);
  LaplacianOptions opt_;
  std::unique_ptr<Impl> impl_;
  std::vector<double> warm_;
  std::size_t analyses_ = 0, factorizations_ = 0;
};

}  // namespace sparkdem
