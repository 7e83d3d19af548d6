#include "engine/graph/laplacian.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/IterativeLinearSolvers>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>

#include "engine/core/error.hpp"
#include "engine/core/numbers.hpp"
#include "engine/graph/hypre_amg.hpp"
#include "engine/graph/interaction_graph.hpp"
#include "engine/graph/low_degree_elimination.hpp"
#include "engine/core/parallel.hpp"

namespace sparkdem {

namespace {

void check_endpoints(std::size_t nodes, std::span<const Index> a, std::span<const Index> b) {
  if (a.size() != b.size())
    throw SetupError("Laplacian: edge lists have different lengths (a " + std::to_string(a.size()) + ", b " + std::to_string(b.size()) +
                     ")");
  for (std::size_t e = 0; e < a.size(); ++e)
    if (a[e] < 0 || b[e] < 0 || static_cast<std::size_t>(a[e]) >= nodes || static_cast<std::size_t>(b[e]) >= nodes)
      throw SetupError("Laplacian: edge " + std::to_string(e) + " (" + std::to_string(a[e]) + ", " + std::to_string(b[e]) +
                       ") refers to a node outside 0.." + std::to_string(nodes) + "-1");
}

void check_edges(std::size_t nodes, std::span<const Index> a, std::span<const Index> b, std::span<const double> g) {
  check_endpoints(nodes, a, b);
  if (g.size() != a.size())
    throw SetupError("Laplacian: " + std::to_string(g.size()) + " conductances for " + std::to_string(a.size()) + " edges");
}

/// Throw a PhysicsError (out of line: keeps the message formatting out of solve()).
[[noreturn, gnu::noinline]] void physics_fail(Step step, const char* quantity, const std::string& what) {
  throw PhysicsError(step, {}, quantity, what);
}

using SpMat = Eigen::SparseMatrix<double>;

/// Work is split into fixed blocks of rows; partial sums and maxima are formed per block and
/// combined in block order, so the results do not depend on the thread count.
constexpr std::int64_t kBlock = 2048;

std::int64_t blocks(std::int64_t n) { return (n + kBlock - 1) / kBlock; }

/// Deterministic sum of f(i), i = 0..n-1.
template <class F>
double block_sum(std::int64_t n, F&& f) {
  const std::int64_t nb = blocks(n);
  std::vector<double> part(static_cast<std::size_t>(nb), 0.0);
  par::loop(nb > 1, nb, [&](std::int64_t k) {
    double s = 0.0;
    for (std::int64_t i = k * kBlock; i < std::min(n, (k + 1) * kBlock); ++i) s += f(i);
    part[k] = s;
  });
  double s = 0.0;
  for (double x : part) s += x;
  return s;
}

/// (A x)_i for a symmetric compressed column-major A: column i is row i.
inline double row_dot(const SpMat& A, const double* x, std::int64_t i) {
  const int* inner = A.innerIndexPtr();
  const double* val = A.valuePtr();
  double s = 0.0;
  for (int k = A.outerIndexPtr()[i]; k < A.outerIndexPtr()[i + 1]; ++k) s += val[k] * x[inner[k]];
  return s;
}

/// Fixed pseudo-random start vector in [0.5, 1.5) (splitmix64 of the index): deterministic and
/// with a component along every eigenvector in practice (unlike a constant vector on a symmetric
/// lattice).
double start_entry(std::uint64_t i) {
  std::uint64_t z = (i + 1) * 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  z ^= z >> 31;
  return 0.5 + static_cast<double>(z >> 11) * 0x1.0p-53;
}

Index find_root(std::vector<Index>& parent, Index v) {
  while (parent[v] != v) {
    parent[v] = parent[parent[v]];  // path halving
    v = parent[v];
  }
  return v;
}

}  // namespace

std::vector<Index> component_roots(std::size_t nodes, std::span<const Index> a, std::span<const Index> b, std::span<const double> g) {
  std::vector<Index> parent(nodes);
  std::iota(parent.begin(), parent.end(), Index{0});
  for (std::size_t e = 0; e < g.size(); ++e) {
    if (a[e] == b[e] || g[e] == 0.0 || std::isnan(g[e])) continue;  // signed elements (sphere_element) connect too
    const Index ra = find_root(parent, a[e]), rb = find_root(parent, b[e]);
    if (ra != rb) parent[std::max(ra, rb)] = std::min(ra, rb);
  }
  for (std::size_t v = 0; v < nodes; ++v) parent[v] = find_root(parent, static_cast<Index>(v));
  return parent;
}

namespace {}  // namespace

// ---------------------------------------------------------------------------------------------
// Matrix-free operator, diagonal, assembly

void EdgeIncidence::build(std::size_t nodes, std::span<const Index> a, std::span<const Index> b) {
  check_endpoints(nodes, a, b);
  edges = a.size();
  start.assign(nodes + 1, 0);
  for (std::size_t e = 0; e < a.size(); ++e) {
    if (a[e] == b[e]) continue;
    ++start[a[e] + 1];
    ++start[b[e] + 1];
  }
  for (std::size_t v = 0; v < nodes; ++v) start[v + 1] += start[v];
  edge.assign(start[nodes], 0);
  other.assign(start[nodes], 0);
  std::vector<std::int64_t> fill(start.begin(), start.end() - 1);
  // Ascending e: each node's list is in edge order.
  for (std::size_t e = 0; e < a.size(); ++e) {
    if (a[e] == b[e]) continue;
    const auto k = fill[a[e]]++, l = fill[b[e]]++;
    edge[k] = static_cast<std::int64_t>(e);
    other[k] = b[e];
    edge[l] = static_cast<std::int64_t>(e);
    other[l] = a[e];
  }
}

void laplacian_apply(const EdgeIncidence& inc, std::span<const double> g, std::span<const double> x, std::span<double> y) {
  const std::size_t n = inc.nodes();
  if (x.size() != n || y.size() != n)
    throw SetupError("laplacian_apply: x has " + std::to_string(x.size()) + " and y " + std::to_string(y.size()) + " entries for " +
                     std::to_string(n) + " nodes");
  if (g.size() != inc.edges)
    throw SetupError("laplacian_apply: " + std::to_string(g.size()) + " conductances for " + std::to_string(inc.edges) + " edges");
  const auto nn = static_cast<std::int64_t>(n);
  par::for_each(nn, par::kHeavy, [&](std::int64_t v) {
    double s = 0.0;
    for (std::int64_t k = inc.start[v]; k < inc.start[v + 1]; ++k) {
      const double ge = g[inc.edge[k]];
      if (ge != 0.0) s += ge * (x[v] - x[inc.other[k]]);
    }
    y[v] = s;
  });
}

void laplacian_apply(std::size_t nodes, std::span<const Index> a, std::span<const Index> b, std::span<const double> g,
                     std::span<const double> x, std::span<double> y) {
  check_edges(nodes, a, b, g);
  EdgeIncidence inc;
  inc.build(nodes, a, b);
  laplacian_apply(inc, g, x, y);
}

std::vector<double> laplacian_diagonal(std::size_t nodes, std::span<const Index> a, std::span<const Index> b, std::span<const double> g) {
  check_edges(nodes, a, b, g);
  std::vector<double> d(nodes, 0.0);
  for (std::size_t e = 0; e < a.size(); ++e) {
    if (a[e] == b[e]) continue;
    d[a[e]] += g[e];
    d[b[e]] += g[e];
  }
  return d;
}

Eigen::SparseMatrix<double> assemble_laplacian(std::size_t nodes, std::span<const Index> a, std::span<const Index> b,
                                               std::span<const double> g) {
  check_edges(nodes, a, b, g);
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(4 * a.size());
  for (std::size_t e = 0; e < a.size(); ++e) {
    if (a[e] == b[e] || g[e] == 0.0) continue;
    t.emplace_back(a[e], a[e], g[e]);
    t.emplace_back(b[e], b[e], g[e]);
    t.emplace_back(a[e], b[e], -g[e]);
    t.emplace_back(b[e], a[e], -g[e]);
  }
  const auto n = static_cast<Eigen::Index>(nodes);
  Eigen::SparseMatrix<double> L(n, n);
  L.setFromTriplets(t.begin(), t.end());
  L.makeCompressed();
  return L;
}

const char* laplacian_method_name(LaplacianMethod m) {
  switch (m) {
    case LaplacianMethod::Direct:
      return "direct";
    case LaplacianMethod::CgIncompleteCholesky:
      return "cg_ic";
    case LaplacianMethod::CgDiagonal:
      return "cg_jacobi";
    case LaplacianMethod::PseudoTransient:
      return "pseudo_transient";
    case LaplacianMethod::Amg:
      return "amg";
  }
  return "?";
}

// ---------------------------------------------------------------------------------------------
// Stability limit of the pseudo-transient iteration

EigenEstimate max_generalized_eigenvalue(const SpMat& A, std::span<const double> C, double rel_tol, int max_iterations) {
  const std::int64_t m = A.rows();
  if (A.cols() != m || !A.isCompressed()) throw SetupError("max_generalized_eigenvalue: the matrix must be square and compressed");
  if (C.size() != static_cast<std::size_t>(m))
    throw SetupError("max_generalized_eigenvalue: " + std::to_string(C.size()) + " capacitances for " + std::to_string(m) + " rows");
  if (!(rel_tol > 0.0) || max_iterations < 1) throw SetupError("max_generalized_eigenvalue: needs rel_tol > 0 and max_iterations >= 1");
  for (std::int64_t i = 0; i < m; ++i)
    if (!(C[i] > 0.0) || !std::isfinite(C[i]))
      throw SetupError("max_generalized_eigenvalue: capacitance " + std::to_string(i) + " is not finite and > 0");
  EigenEstimate est;
  if (m == 0) {
    est.converged = true;
    return est;
  }
  // Lanczos on B = S A S, S = C^-1/2, without reorthogonalisation: the largest Ritz value is not
  // affected by the loss of orthogonality (it only brings spurious copies of converged values).
  Eigen::VectorXd s(m), q(m), q_prev = Eigen::VectorXd::Zero(m), w(m), sq(m);
  for (std::int64_t i = 0; i < m; ++i) {
    s[i] = 1.0 / std::sqrt(C[i]);
    q[i] = start_entry(static_cast<std::uint64_t>(i));
  }
  q /= std::sqrt(block_sum(m, [&](std::int64_t i) { return q[i] * q[i]; }));
  std::vector<double> alpha, beta;
  double b_prev = 0.0;
  for (int k = 1; k <= max_iterations; ++k) {
    par::loop(m > kBlock, m, [&](std::int64_t i) { sq[i] = s[i] * q[i]; });
    par::loop(m > kBlock, m, [&](std::int64_t i) { w[i] = s[i] * row_dot(A, sq.data(), i) - b_prev * q_prev[i]; });
    const double a = block_sum(m, [&](std::int64_t i) { return q[i] * w[i]; });
    par::loop(m > kBlock, m, [&](std::int64_t i) { w[i] -= a * q[i]; });
    const double b = std::sqrt(block_sum(m, [&](std::int64_t i) { return w[i] * w[i]; }));
    alpha.push_back(a);
    // Ritz values of the k x k tridiagonal matrix: every step while k is small, then every 10th
    // (the dense tridiagonal eigen-solve costs O(k^2) per step).
    const bool last = k == max_iterations || b == 0.0;
    if (k <= 60 || k % 10 == 0 || last) {
      double theta = a, sk = 1.0;
      if (k > 1) {
        Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es;
        const Eigen::VectorXd d = Eigen::Map<const Eigen::VectorXd>(alpha.data(), k);
        const Eigen::VectorXd e = Eigen::Map<const Eigen::VectorXd>(beta.data(), k - 1);
        es.computeFromTridiagonal(d, e, Eigen::ComputeEigenvectors);
        theta = es.eigenvalues()[k - 1];
        sk = es.eigenvectors()(k - 1, k - 1);
      }
      est.value = theta;
      est.residual_bound = b * std::abs(sk);
      est.iterations = k;
      if (est.residual_bound <= rel_tol * std::abs(theta)) {
        est.converged = true;
        break;
      }
    }
    if (b == 0.0) break;  // invariant subspace; theta exact (caught above unless theta == 0)
    beta.push_back(b);
    q_prev.swap(q);
    par::loop(m > kBlock, m, [&](std::int64_t i) { q[i] = w[i] / b; });
    b_prev = b;
  }
  return est;
}

double gershgorin_step(const SpMat& A, std::span<const double> C) {
  const std::int64_t m = A.rows();
  if (A.cols() != m || C.size() != static_cast<std::size_t>(m))
    throw SetupError("gershgorin_step: needs a square matrix and one capacitance per row");
  double dt = std::numeric_limits<double>::infinity();
  for (std::int64_t j = 0; j < m; ++j)
    for (SpMat::InnerIterator it(A, static_cast<Eigen::Index>(j)); it; ++it)
      if (it.row() == j && it.value() > 0.0) dt = std::min(dt, C[j] / it.value());
  return dt;
}

LaplacianProblem LaplacianProblem::on(const InteractionGraph& graph, std::span<const double> g) {
  LaplacianProblem p;
  p.nodes = graph.nodes();
  p.a = graph.a;
  p.b = graph.b;
  p.g = g;
  return p;
}

// ---------------------------------------------------------------------------------------------
// Solver

struct LaplacianSolver::Impl {
  using SpMat = Eigen::SparseMatrix<double>;
  using IC = Eigen::IncompleteCholesky<double, Eigen::Lower, Eigen::AMDOrdering<int>>;

  // Structure of the cached reduced system (compared exactly with the next problem).
  bool structure_valid = false;
  std::size_t n = 0;
  std::vector<Index> sa, sb;
  std::vector<char> active;
  std::vector<std::int32_t> role;  // >= 0: free index; -1 Dirichlet; -2 floating
  // Reduced matrix (both triangles) and the slots each edge / node adds into.
  SpMat A;
  std::vector<SpMat::StorageIndex> slot_diag;         // per free unknown
  std::vector<SpMat::StorageIndex> slot_ab, slot_ba;  // per edge (-1 unless both ends free)
  std::vector<double> factored_values;         // matrix values of the current factorisation
  bool factor_valid = false;

  Eigen::SimplicialLDLT<SpMat, Eigen::Lower, Eigen::AMDOrdering<int>> ldlt;
  Eigen::ConjugateGradient<SpMat, Eigen::Lower | Eigen::Upper, IC> cg_ic;
  Eigen::ConjugateGradient<SpMat, Eigen::Lower | Eigen::Upper, Eigen::DiagonalPreconditioner<double>> cg_diag;
  std::unique_ptr<HypreAmgPcg> amg;
  LowDegreeElimination elim;  // Amg with amg_eliminate_low_degree: the rows eliminated before the AMG solve
  // Pseudo-transient: capacitance per free unknown of the cached spectral estimate, and that estimate.
  std::vector<double> pt_capacitance;
  EigenEstimate pt_lambda;
  double pt_gershgorin = 0.0;
};

namespace {

/// The pseudo-transient iteration x <- x + dt C^-1 (b - A x) until the change indicator < beta.
/// Returns {iterations, indicator}; throws PhysicsError on divergence or no convergence.
std::pair<int, double> pseudo_transient(const SpMat& A, const Eigen::VectorXd& b, const std::vector<double>& cap, double dt,
                                        const PseudoTransientOptions& o, double spread, int max_it, Eigen::VectorXd& x, Step step,
                                        double dt_limit) {
  const std::int64_t m = A.rows(), nb = blocks(m);
  Eigen::VectorXd xn(m);
  std::vector<double> p_ind(nb), p_dmax(nb), p_xmax(nb), p_cn(nb), p_xn(nb);
  const bool per_node = o.indicator == ChangeIndicator::PerNode;
  double min_cn = std::numeric_limits<double>::infinity();
  int min_at = 0;
  for (int it = 1; it <= max_it; ++it) {
    par::loop(nb > 1, nb, [&](std::int64_t k) {
      double ind = 0.0, dmax = 0.0, xmax = 0.0, cn = 0.0, xc = 0.0;
      for (std::int64_t i = k * kBlock; i < std::min(m, (k + 1) * kBlock); ++i) {
        const double d = dt / cap[i] * (b[i] - row_dot(A, x.data(), i));
        const double v = x[i] + d;
        xn[i] = v;
        const double ad = std::abs(d), av = std::abs(v);
        if (per_node && ad > 0.0) ind = std::max(ind, av > 0.0 ? ad / av : std::numeric_limits<double>::infinity());
        dmax = std::max(dmax, ad);
        xmax = std::max(xmax, av);
        cn += cap[i] * d * d;
        xc += cap[i] * v * v;
        if (!std::isfinite(v)) cn = std::numeric_limits<double>::quiet_NaN();
      }
      p_ind[k] = ind;
      p_dmax[k] = dmax;
      p_xmax[k] = xmax;
      p_cn[k] = cn;
      p_xn[k] = xc;
    });
    x.swap(xn);
    double ind = 0.0, dmax = 0.0, xmax = 0.0, cn2 = 0.0, xc2 = 0.0;
    for (std::int64_t k = 0; k < nb; ++k) {
      ind = std::max(ind, p_ind[k]);
      dmax = std::max(dmax, p_dmax[k]);
      xmax = std::max(xmax, p_xmax[k]);
      cn2 += p_cn[k];
      xc2 += p_xn[k];
    }
    if (!per_node) {
      const double scale = spread > 0.0 ? spread : xmax > 0.0 ? xmax : 1.0;
      ind = dmax / scale;
    }
    const double cn = std::sqrt(cn2);
    // Stable dt: ||x^{i+1} - x^i||_C is non-increasing (I - dt C^-1 A is C-self-adjoint with
    // spectral radius < 1). Growth by divergence_factor over its minimum (above rounding noise)
    // or a non-finite value means an unstable step.
    const bool blown = !std::isfinite(cn) || !std::isfinite(xc2) || (cn > o.divergence_factor * min_cn && cn > 1e-12 * std::sqrt(xc2));
    if (blown)
      physics_fail(step, "pseudo-transient iteration",
                   "diverges at iteration " + std::to_string(it) + ": the C-norm of the update grew from " + std::to_string(min_cn) +
                       " (iteration " + std::to_string(min_at) + ") to " + std::to_string(cn) + " with dt = " + std::to_string(dt) +
                       " s, dt / true limit = " + std::to_string(dt / dt_limit) + " (limit 2/lambda_max = " + std::to_string(dt_limit) +
                       " s)");
    if (cn < min_cn) {
      min_cn = cn;
      min_at = it;
    }
    if (ind < o.beta) return {it, ind};
    if (it == max_it)
      physics_fail(step, "pseudo-transient iteration",
                   "change indicator " + std::to_string(ind) + " still above beta = " + std::to_string(o.beta) + " after " +
                       std::to_string(max_it) + " iterations (" + std::to_string(m) + " unknowns)");
  }
  return {0, 0.0};  // max_it <= 0: not reached (checked by the caller)
}

}  // namespace

LaplacianSolver::LaplacianSolver(LaplacianOptions opt) : opt_(opt), impl_(std::make_unique<Impl>()) {}
LaplacianSolver::~LaplacianSolver() = default;
LaplacianSolver::LaplacianSolver(LaplacianSolver&&) noexcept = default;
LaplacianSolver& LaplacianSolver::operator=(LaplacianSolver&&) noexcept = default;

void LaplacianSolver::set_options(const LaplacianOptions& opt) {
  if (opt.method != opt_.method || opt.amg_strong_threshold != opt_.amg_strong_threshold ||
      opt.amg_aggressive_levels != opt_.amg_aggressive_levels || opt.amg_spread_min_rows != opt_.amg_spread_min_rows ||
      opt.amg_breadth_first != opt_.amg_breadth_first || opt.amg_eliminate_low_degree != opt_.amg_eliminate_low_degree ||
      opt.pseudo.eigen_tolerance != opt_.pseudo.eigen_tolerance ||
      opt.pseudo.eigen_max_iterations != opt_.pseudo.eigen_max_iterations)
    invalidate();
  opt_ = opt;
}

void LaplacianSolver::invalidate() { impl_ = std::make_unique<Impl>(); }

void LaplacianSolver::permute_warm_start(const std::vector<Index>& perm, std::size_t old_particle_nodes) {
  if (warm_.empty()) return;
  if (old_particle_nodes > warm_.size()) {
    warm_.clear();
    return;
  }
  std::vector<double> w;
  w.reserve(perm.size() + warm_.size() - old_particle_nodes);
  for (const Index i : perm) w.push_back(static_cast<std::size_t>(i) < old_particle_nodes ? warm_[i] : kNaN);
  w.insert(w.end(), warm_.begin() + static_cast<std::ptrdiff_t>(old_particle_nodes), warm_.end());
  warm_.swap(w);
}

void LaplacianSolver::visit(Archive& ar, const std::string& prefix) {
  if (!ar.reading() || ar.has(prefix + "/warm_start")) ar.visit(prefix + "/warm_start", warm_);
}

namespace {

/// The input checks of LaplacianSolver::solve: sizes, finite conductances (>= 0 unless the
/// problem is signed), sources, capacitances and pseudo-transient settings, shunts. Returns
/// whether any node has a shunt.
bool check_problem(const LaplacianProblem& p, const LaplacianOptions& opt) {
  const std::size_t n = p.nodes, ne = p.a.size();
  check_edges(n, p.a, p.b, p.g);
  if (!p.source.empty() && p.source.size() != n)
    throw SetupError("Laplacian: source has " + std::to_string(p.source.size()) + " entries for " + std::to_string(n) + " nodes");
  if (!p.shunt.empty() && p.shunt.size() != n)
    throw SetupError("Laplacian: shunt has " + std::to_string(p.shunt.size()) + " entries for " + std::to_string(n) + " nodes");
  for (std::size_t e = 0; e < ne; ++e)
    if (!std::isfinite(p.g[e]) || (!p.signed_conductances && !(p.g[e] >= 0.0)))
      physics_fail(p.step, "conductance",
                   "edge " + std::to_string(e) + " (nodes " + std::to_string(p.a[e]) + ", " + std::to_string(p.b[e]) +
                       ") has g = " + std::to_string(p.g[e]) + "; conductances must be finite and >= 0");
  for (std::size_t v = 0; v < p.source.size(); ++v)
    if (!std::isfinite(p.source[v])) physics_fail(p.step, "source", "node " + std::to_string(v) + " has a non-finite source");
  const bool pseudo = opt.method == LaplacianMethod::PseudoTransient;
  if (pseudo) {
    if (p.capacitance.size() != n)
      throw SetupError("Laplacian: the pseudo-transient method needs one capacitance per node (" + std::to_string(p.capacitance.size()) +
                       " given for " + std::to_string(n) + " nodes)");
    for (std::size_t v = 0; v < n; ++v)
      if (!(p.capacitance[v] > 0.0) || !std::isfinite(p.capacitance[v]))
        physics_fail(p.step, "capacitance",
                     "node " + std::to_string(v) + " has capacitance " + std::to_string(p.capacitance[v]) + "; it must be finite and > 0");
    const auto& po = opt.pseudo;
    if (!(po.dt >= 0.0) || !std::isfinite(po.dt) || (po.dt == 0.0 && !(po.dt_fraction > 0.0 && std::isfinite(po.dt_fraction))))
      throw SetupError("Laplacian: pseudo-transient step dt = " + std::to_string(po.dt) +
                       ", dt_fraction = " + std::to_string(po.dt_fraction) + ": give dt > 0, or dt = 0 and dt_fraction > 0");
    if (!(po.beta > 0.0) || !(po.divergence_factor > 1.0))
      throw SetupError("Laplacian: pseudo-transient needs beta > 0 and divergence_factor > 1");
  } else if (!p.capacitance.empty() && p.capacitance.size() != n) {
    throw SetupError("Laplacian: capacitance has " + std::to_string(p.capacitance.size()) + " entries for " + std::to_string(n) + " nodes");
  }
  bool any_shunt = false;
  for (std::size_t v = 0; v < p.shunt.size(); ++v) {
    if (!(p.shunt[v] >= 0.0) || !std::isfinite(p.shunt[v]))
      physics_fail(p.step, "shunt", "node " + std::to_string(v) + " has shunt " + std::to_string(p.shunt[v]));
    any_shunt = any_shunt || p.shunt[v] > 0.0;
  }
  return any_shunt;
}

/// The Dirichlet group of every node (-1: none), with the count of Dirichlet nodes and the sum
/// of their values; throws on a non-finite value, a node out of range or in two groups.
struct DirichletNodes {
  std::vector<std::int32_t> group_of;
  std::size_t count = 0;
  double sum = 0.0;
};
DirichletNodes dirichlet_nodes(const LaplacianProblem& p) {
  DirichletNodes d;
  d.group_of.assign(p.nodes, -1);
  for (std::size_t k = 0; k < p.dirichlet.size(); ++k) {
    const auto& gr = p.dirichlet[k];
    if (!std::isfinite(gr.value)) physics_fail(p.step, "Dirichlet value", "group " + std::to_string(k) + " has a non-finite value");
    for (const Index v : gr.nodes) {
      if (v < 0 || static_cast<std::size_t>(v) >= p.nodes)
        throw SetupError("Laplacian: Dirichlet group " + std::to_string(k) + " names node " + std::to_string(v) + " outside 0.." +
                         std::to_string(p.nodes) + "-1");
      if (d.group_of[v] >= 0)
        throw SetupError("Laplacian: node " + std::to_string(v) + " is in Dirichlet group " + std::to_string(d.group_of[v]) +
                         (d.group_of[v] == static_cast<std::int32_t>(k) ? " twice" : " and in group " + std::to_string(k)));
      d.group_of[v] = static_cast<std::int32_t>(k);
      ++d.count;
      d.sum += gr.value;
    }
  }
  return d;
}

/// The pattern of the reduced matrix (free unknowns only, both triangles, compressed column-major,
/// rows sorted in each column) and the value slot each free node's diagonal and each edge between
/// two free nodes adds into (slot_ab: row a, column b; slot_ba: row b, column a; -1 otherwise).
/// Edges joining the same two nodes share their slots. Built by counting, without triplets or
/// searches: O(entries x log(entries per column)).
struct ReducedPattern {
  SpMat A;
  std::vector<Eigen::SparseMatrix<double>::StorageIndex> slot_diag, slot_ab, slot_ba;  // the matrix's own index type
};
ReducedPattern reduced_pattern(std::size_t m, std::span<const Index> a, std::span<const Index> b, const std::vector<char>& active,
                               const std::vector<std::int32_t>& role) {
  const std::size_t ne = a.size();
  if (ne >= static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()))
    throw SetupError("Laplacian: " + std::to_string(ne) + " edges; at most 2^31 - 2 are supported");
  // Column f lists the diagonal and one entry per edge to another free node: (row, edge), the
  // diagonal with edge -1; an edge's two entries are told apart by which column they sit in.
  struct Entry {
    std::int32_t row, edge;
    bool operator<(const Entry& o) const { return row < o.row || (row == o.row && edge < o.edge); }
  };
  std::vector<std::int64_t> start(m + 1, 1);
  start[0] = 0;
  for (std::size_t e = 0; e < ne; ++e)
    if (active[e] && role[a[e]] >= 0 && role[b[e]] >= 0) {
      ++start[role[a[e]] + 1];
      ++start[role[b[e]] + 1];
    }
  for (std::size_t f = 0; f < m; ++f) start[f + 1] += start[f];
  std::vector<Entry> entry(static_cast<std::size_t>(start[m]));
  std::vector<std::int64_t> fill(start.begin(), start.end() - 1);
  for (std::size_t f = 0; f < m; ++f) entry[fill[f]++] = {static_cast<std::int32_t>(f), -1};
  for (std::size_t e = 0; e < ne; ++e) {
    if (!active[e]) continue;
    const std::int32_t fa = role[a[e]], fb = role[b[e]];
    if (fa < 0 || fb < 0) continue;
    entry[fill[fb]++] = {fa, static_cast<std::int32_t>(e)};  // row a, column b
    entry[fill[fa]++] = {fb, static_cast<std::int32_t>(e)};  // row b, column a
  }
  ReducedPattern out;
  out.slot_diag.assign(m, -1);
  out.slot_ab.assign(ne, -1);
  out.slot_ba.assign(ne, -1);
  const auto mm = static_cast<Eigen::Index>(m);
  SpMat& A = out.A;
  A.resize(mm, mm);
  A.resizeNonZeros(static_cast<Eigen::Index>(entry.size()));  // an upper bound: edges joining the same nodes share a slot
  int* outer = A.outerIndexPtr();
  int* inner = A.innerIndexPtr();
  int nnz = 0;
  outer[0] = 0;
  for (std::size_t f = 0; f < m; ++f) {
    Entry* lo = entry.data() + start[f];
    Entry* hi = entry.data() + start[f + 1];
    for (Entry* it = lo + 1; it < hi; ++it)  // insertion sort: a column holds a node's few neighbours
      for (Entry* j = it; j > lo && *j < *(j - 1); --j) std::swap(*j, *(j - 1));
    for (Entry* it = lo; it != hi; ++it) {
      if (it == lo || it->row != (it - 1)->row) inner[nnz++] = it->row;
      const auto slot = static_cast<Eigen::SparseMatrix<double>::StorageIndex>(nnz - 1);  // nnz fits the matrix's index type
      if (it->edge < 0)
        out.slot_diag[f] = slot;
      else if (role[a[it->edge]] == it->row)
        out.slot_ab[it->edge] = slot;
      else
        out.slot_ba[it->edge] = slot;
    }
    outer[f + 1] = nnz;
  }
  A.resizeNonZeros(nnz);
  std::fill(A.valuePtr(), A.valuePtr() + nnz, 0.0);
  return out;
}

/// Node values (Dirichlet values, solved values, NaN on floating nodes), branch fluxes and
/// Dirichlet-group fluxes of a solved reduced system x.
void write_results(const LaplacianProblem& p, const std::vector<std::int32_t>& role, const std::vector<std::int32_t>& group_of,
                   const std::vector<char>& active, const Eigen::VectorXd& x, LaplacianResult& res) {
  const std::size_t n = p.nodes, ne = p.a.size();
  res.value.assign(n, kNaN);
  for (std::size_t v = 0; v < n; ++v) {
    if (role[v] == -1)
      res.value[v] = p.dirichlet[group_of[v]].value;
    else if (role[v] >= 0)
      res.value[v] = x[role[v]];
  }
  res.flux.assign(ne, 0.0);
  res.dirichlet_flux.assign(p.dirichlet.size(), 0.0);
  for (std::size_t e = 0; e < ne; ++e) {
    if (!active[e]) continue;
    const Index a = p.a[e], b = p.b[e];
    if (role[a] == -2) continue;  // floating component (then b is floating too)
    const double f = p.g[e] * (res.value[a] - res.value[b]);
    res.flux[e] = f;
    if (role[a] == -1) res.dirichlet_flux[group_of[a]] += f;
    if (role[b] == -1) res.dirichlet_flux[group_of[b]] -= f;
  }
}

}  // namespace

/// Numeric factorisation of the assembled reduced matrix for the chosen method (the
/// pseudo-transient method: lambda_max(C^-1 A) by Lanczos and the Gershgorin step).
void LaplacianSolver::factorize_(const LaplacianProblem& p, const std::vector<double>& cap_free, LaplacianResult& res) {
  Impl& im = *impl_;
  const auto m = static_cast<std::size_t>(im.A.rows());
  const double* val = im.A.valuePtr();
  const auto nnz = static_cast<std::size_t>(im.A.nonZeros());
  im.factor_valid = false;
  bool ok = true;
  switch (opt_.method) {
    case LaplacianMethod::Direct:
      im.ldlt.factorize(im.A);
      ok = im.ldlt.info() == Eigen::Success;
      break;
    case LaplacianMethod::CgIncompleteCholesky:
      im.cg_ic.factorize(im.A);
      ok = im.cg_ic.preconditioner().info() == Eigen::Success;
      break;
    case LaplacianMethod::CgDiagonal:
      im.cg_diag.factorize(im.A);
      break;
    case LaplacianMethod::PseudoTransient: {
      const auto& po = opt_.pseudo;
      im.pt_lambda = max_generalized_eigenvalue(im.A, cap_free, po.eigen_tolerance, po.eigen_max_iterations);
      if (!im.pt_lambda.converged || !(im.pt_lambda.value > 0.0))
        physics_fail(p.step, "pseudo-transient stability limit",
                     "lambda_max(C^-1 A) not found to the relative accuracy " + std::to_string(po.eigen_tolerance) + " in " +
                         std::to_string(im.pt_lambda.iterations) + " Lanczos steps (estimate " + std::to_string(im.pt_lambda.value) +
                         ", residual bound " + std::to_string(im.pt_lambda.residual_bound) + ")");
      im.pt_gershgorin = gershgorin_step(im.A, cap_free);
      im.pt_capacitance = cap_free;
      break;
    }
    case LaplacianMethod::Amg:
      if (!im.amg)
        im.amg = std::make_unique<HypreAmgPcg>(
            HypreAmgPcg::Settings{opt_.amg_strong_threshold, opt_.amg_aggressive_levels, opt_.amg_spread_min_rows, opt_.amg_breadth_first});
      if (opt_.amg_eliminate_low_degree) {
        im.elim.factor(im.A);
        im.amg->setup(im.elim.reduced());
      } else {
        im.amg->setup(im.A);
      }
      break;
  }
  if (!ok)
    physics_fail(p.step, "Laplacian",
                 "the factorisation of the reduced " + std::to_string(m) + " x " + std::to_string(m) + " system failed");
  ++factorizations_;
  res.factorized = true;
  im.factored_values.assign(val, val + nnz);
  im.factor_valid = true;
}

/// The iterative methods (CG with IC or Jacobi, AMG-PCG, pseudo-transient) on the reduced
/// system A x = rhs from the warm start (`fallback` where a free node has none); fills the
/// iteration count and the pseudo-transient report of res, fails when not converged.
Eigen::VectorXd LaplacianSolver::iterate_(const LaplacianProblem& p, const std::vector<Index>& free_node, const Eigen::VectorXd& rhs,
                                          double fallback, LaplacianResult& res) {
  Impl& im = *impl_;
  const std::size_t n = p.nodes, m = free_node.size();
  const bool pseudo = opt_.method == LaplacianMethod::PseudoTransient;
  Eigen::VectorXd guess(static_cast<Eigen::Index>(m));
  Eigen::VectorXd x;
  const bool use_warm = opt_.warm_start && warm_.size() == n;
  for (std::size_t f = 0; f < m; ++f) {
    const double w = use_warm ? warm_[free_node[f]] : kNaN;
    guess[f] = std::isfinite(w) ? w : fallback;
  }
  const int max_it = opt_.max_iterations > 0 ? opt_.max_iterations : pseudo ? 1000000 : static_cast<int>(2 * m);
  bool ok = false;
  const char* what = "conjugate gradients";
  if (opt_.method == LaplacianMethod::CgIncompleteCholesky) {
    im.cg_ic.setTolerance(opt_.tolerance);
    im.cg_ic.setMaxIterations(max_it);
    x = im.cg_ic.solveWithGuess(rhs, guess);
    res.iterations = static_cast<int>(im.cg_ic.iterations());
    ok = im.cg_ic.info() == Eigen::Success;
  } else if (opt_.method == LaplacianMethod::CgDiagonal) {
    im.cg_diag.setTolerance(opt_.tolerance);
    im.cg_diag.setMaxIterations(max_it);
    x = im.cg_diag.solveWithGuess(rhs, guess);
    res.iterations = static_cast<int>(im.cg_diag.iterations());
    ok = im.cg_diag.info() == Eigen::Success;
  } else if (opt_.method == LaplacianMethod::Amg) {
    what = "AMG-preconditioned conjugate gradients";
    HypreAmgPcg::Outcome out;
    if (opt_.amg_eliminate_low_degree) {
      // The reduced system's residual is the full one on the kept rows (zero on the others), so
      // ||r|| <= tolerance ||b|| of the full system is ||r2|| <= tolerance ||b|| / ||b2|| ||b2||.
      Eigen::VectorXd work;
      const Eigen::VectorXd rhs2 = im.elim.reduce_rhs(rhs, work);
      Eigen::VectorXd x2 = im.elim.restrict_to_kept(guess);
      const double b2 = rhs2.norm();
      out = im.amg->solve(rhs2, x2, b2 > 0.0 ? opt_.tolerance * rhs.norm() / b2 : opt_.tolerance, max_it);
      x = im.elim.expand(work, x2);
      res.eliminated_rows = im.elim.eliminated();
    } else {
      x = guess;
      out = im.amg->solve(rhs, x, opt_.tolerance, max_it);
    }
    res.iterations = out.iterations;
    res.amg_ranks = im.amg->ranks();
    ok = out.converged;
  } else {
    const auto& po = opt_.pseudo;
    auto& rep = res.pseudo;
    rep.lambda_max = im.pt_lambda.value;
    rep.lambda_residual_bound = im.pt_lambda.residual_bound;
    rep.eigen_iterations = im.pt_lambda.iterations;
    rep.dt_limit = 2.0 / im.pt_lambda.value;
    rep.dt_gershgorin = im.pt_gershgorin;
    rep.dt = po.dt > 0.0 ? po.dt : po.dt_fraction * rep.dt_limit;
    if (rep.dt >= rep.dt_limit && !po.allow_unstable)
      physics_fail(p.step, "pseudo-transient step",
                   "dt = " + std::to_string(rep.dt) + " s is not below the true stability limit 2/lambda_max(C^-1 K) = " +
                       std::to_string(rep.dt_limit) + " s (the Gershgorin safe step is " + std::to_string(rep.dt_gershgorin) +
                       " s); the iteration would diverge. Lower dt, or set "
                       "allow_unstable to run it anyway");
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const auto& gr : p.dirichlet)
      if (!gr.nodes.empty()) {
        lo = std::min(lo, gr.value);
        hi = std::max(hi, gr.value);
      }
    x = guess;
    const auto [iters, indicator] = pseudo_transient(im.A, rhs, im.pt_capacitance, rep.dt, po, hi > lo ? hi - lo : 0.0, max_it, x, p.step,
                                                     rep.dt_limit);
    res.iterations = iters;
    rep.change_indicator = indicator;
    ok = true;
  }
  if (!ok)
    physics_fail(p.step, "Laplacian",
                 std::string(what) + " did not reach the relative tolerance " + std::to_string(opt_.tolerance) + " in " +
                     std::to_string(res.iterations) + " iterations (" + std::to_string(m) + " unknowns)");
  return x;
}

LaplacianResult LaplacianSolver::solve(const LaplacianProblem& p) {
  const auto t0 = std::chrono::steady_clock::now();
  Impl& im = *impl_;
  const std::size_t n = p.nodes, ne = p.a.size();
  const bool any_shunt = check_problem(p, opt_);
  const bool pseudo = opt_.method == LaplacianMethod::PseudoTransient;

  const DirichletNodes dn = dirichlet_nodes(p);
  const std::vector<std::int32_t>& group_of = dn.group_of;
  const std::size_t n_dirichlet = dn.count;
  const double dirichlet_sum = dn.sum;
  if (n_dirichlet == 0 && !any_shunt)
    throw SetupError(
        "Laplacian: no Dirichlet node and no shunt: the potential is defined only up to a constant "
        "(give at least one node a prescribed value)");

  // Connected components over the edges that conduct (union-find), grounded ones solved.
  std::vector<char> active(ne, 0);
  for (std::size_t e = 0; e < ne; ++e) active[e] = p.a[e] != p.b[e] && p.g[e] != 0.0;
  const std::vector<Index> root_of = component_roots(n, p.a, p.b, p.g);
  std::vector<char> grounded(n, 0);
  for (std::size_t v = 0; v < n; ++v)
    if (group_of[v] >= 0 || (!p.shunt.empty() && p.shunt[v] > 0.0)) grounded[root_of[v]] = 1;
  std::vector<std::int32_t> role(n);
  std::vector<Index> free_node;
  LaplacianResult res;
  for (std::size_t v = 0; v < n; ++v) {
    const Index root = root_of[v];
    if (group_of[v] >= 0)
      role[v] = -1;
    else if (grounded[root]) {
      role[v] = static_cast<std::int32_t>(free_node.size());
      free_node.push_back(static_cast<Index>(v));
    } else {
      role[v] = -2;
      ++res.floating_nodes;
      if (root == static_cast<Index>(v)) ++res.floating_components;
    }
  }
  const std::size_t m = free_node.size();
  res.free_nodes = m;

  // Structure: reuse the analysis if everything that shapes the reduced matrix is unchanged.
  const bool same_structure = im.structure_valid && im.n == n && im.role == role && im.active == active &&
                              std::equal(p.a.begin(), p.a.end(), im.sa.begin(), im.sa.end()) &&
                              std::equal(p.b.begin(), p.b.end(), im.sb.begin(), im.sb.end());
  if (!same_structure) {
    im.structure_valid = false;
    im.factor_valid = false;
    ReducedPattern pat = reduced_pattern(m, p.a, p.b, active, role);
    im.A = std::move(pat.A);
    im.slot_diag = std::move(pat.slot_diag);
    im.slot_ab = std::move(pat.slot_ab);
    im.slot_ba = std::move(pat.slot_ba);
    if (m > 0) {
      switch (opt_.method) {
        case LaplacianMethod::Direct:
          im.ldlt.analyzePattern(im.A);
          break;
        case LaplacianMethod::CgIncompleteCholesky:
          im.cg_ic.analyzePattern(im.A);
          break;
        case LaplacianMethod::CgDiagonal:
          im.cg_diag.analyzePattern(im.A);
          break;
        case LaplacianMethod::PseudoTransient:
          break;  // nothing symbolic
        case LaplacianMethod::Amg:
          break;  // hypre copies the matrix at setup
      }
    }
    ++analyses_;
    res.analyzed = true;
    im.n = n;
    im.sa.assign(p.a.begin(), p.a.end());
    im.sb.assign(p.b.begin(), p.b.end());
    im.active = active;
    im.role = role;
    im.structure_valid = true;
  }

  // Values, summed in edge order into fixed slots; then the shunts.
  double* val = im.A.valuePtr();
  const auto nnz = static_cast<std::size_t>(im.A.nonZeros());
  std::fill(val, val + nnz, 0.0);
  for (std::size_t e = 0; e < ne; ++e) {
    if (!active[e]) continue;
    const double ge = p.g[e];
    const std::int32_t fa = role[p.a[e]], fb = role[p.b[e]];
    if (fa >= 0) val[im.slot_diag[fa]] += ge;
    if (fb >= 0) val[im.slot_diag[fb]] += ge;
    if (im.slot_ab[e] >= 0) {
      val[im.slot_ab[e]] -= ge;
      val[im.slot_ba[e]] -= ge;
    }
  }
  if (!p.shunt.empty())
    for (std::size_t f = 0; f < m; ++f) val[im.slot_diag[f]] += p.shunt[free_node[f]];
  bool same_values = im.factor_valid && im.factored_values.size() == nnz && std::equal(val, val + nnz, im.factored_values.begin());
  std::vector<double> cap_free;
  if (pseudo) {
    cap_free.resize(m);
    for (std::size_t f = 0; f < m; ++f) cap_free[f] = p.capacitance[free_node[f]];
    same_values = same_values && cap_free == im.pt_capacitance;
  }
  if (!same_values && m > 0) factorize_(p, cap_free, res);

  // Right-hand side: sources, then the Dirichlet neighbours in edge order.
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(m));
  if (!p.source.empty())
    for (std::size_t f = 0; f < m; ++f) rhs[f] = p.source[free_node[f]];
  for (std::size_t e = 0; e < ne; ++e) {
    if (!active[e]) continue;
    const Index a = p.a[e], b = p.b[e];
    if (role[a] >= 0 && role[b] == -1) rhs[role[a]] += p.g[e] * p.dirichlet[group_of[b]].value;
    if (role[b] >= 0 && role[a] == -1) rhs[role[b]] += p.g[e] * p.dirichlet[group_of[a]].value;
  }

  // Solve.
  Eigen::VectorXd x = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(m));
  if (m > 0) {
    if (opt_.method == LaplacianMethod::Direct)
      x = im.ldlt.solve(rhs);
    else
      x = iterate_(p, free_node, rhs, n_dirichlet > 0 ? dirichlet_sum / static_cast<double>(n_dirichlet) : 0.0, res);
    const double rn = rhs.norm();
    res.residual_norm = (im.A * x - rhs).norm();
    res.relative_residual = rn > 0.0 ? res.residual_norm / rn : res.residual_norm;
  }

  write_results(p, role, group_of, active, x, res);
  warm_ = res.value;
  res.solve_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return res;
}

}  // namespace sparkdem
