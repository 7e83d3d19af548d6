#include "engine/graph/laplacian.hpp"

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>

#include "engine/core/error.hpp"
#include "engine/graph/interaction_graph.hpp"

namespace sparkdem {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

void check_endpoints(std::size_t nodes, std::span<const Index> a, std::span<const Index> b) {
  if (a.size() != b.size())
    throw SetupError("Laplacian: edge lists have different lengths (a " + std::to_string(a.size()) + ", b " +
                     std::to_string(b.size()) + ")");
  for (std::size_t e = 0; e < a.size(); ++e)
    if (a[e] < 0 || b[e] < 0 || static_cast<std::size_t>(a[e]) >= nodes || static_cast<std::size_t>(b[e]) >= nodes)
      throw SetupError("Laplacian: edge " + std::to_string(e) + " (" + std::to_string(a[e]) + ", " +
                       std::to_string(b[e]) + ") refers to a node outside 0.." + std::to_string(nodes) + "-1");
}

void check_edges(std::size_t nodes, std::span<const Index> a, std::span<const Index> b, std::span<const double> g) {
  check_endpoints(nodes, a, b);
  if (g.size() != a.size())
    throw SetupError("Laplacian: " + std::to_string(g.size()) + " conductances for " + std::to_string(a.size()) + " edges");
}

/// Index of entry (row, col) in a compressed column-major matrix (must exist).
std::int64_t slot_of(const Eigen::SparseMatrix<double>& A, int row, int col) {
  const int* inner = A.innerIndexPtr();
  const int* lo = inner + A.outerIndexPtr()[col];
  const int* hi = inner + A.outerIndexPtr()[col + 1];
  const int* it = std::lower_bound(lo, hi, row);
  return static_cast<std::int64_t>(it - inner);
}

/// Throw a PhysicsError (out of line: keeps the message formatting out of solve()).
[[noreturn, gnu::noinline]] void physics_fail(Step step, const char* quantity, const std::string& what) {
  throw PhysicsError(step, {}, quantity, what);
}

Index find_root(std::vector<Index>& parent, Index v) {
  while (parent[v] != v) {
    parent[v] = parent[parent[v]];  // path halving
    v = parent[v];
  }
  return v;
}

}  // namespace

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
    throw SetupError("laplacian_apply: x has " + std::to_string(x.size()) + " and y " + std::to_string(y.size()) +
                     " entries for " + std::to_string(n) + " nodes");
  if (g.size() != inc.edges)
    throw SetupError("laplacian_apply: " + std::to_string(g.size()) + " conductances for " + std::to_string(inc.edges) + " edges");
  const auto nn = static_cast<std::int64_t>(n);
#pragma omp parallel for schedule(static)
  for (std::int64_t v = 0; v < nn; ++v) {
    double s = 0.0;
    for (std::int64_t k = inc.start[v]; k < inc.start[v + 1]; ++k) {
      const double ge = g[inc.edge[k]];
      if (ge != 0.0) s += ge * (x[v] - x[inc.other[k]]);
    }
    y[v] = s;
  }
}

void laplacian_apply(std::size_t nodes, std::span<const Index> a, std::span<const Index> b, std::span<const double> g,
                     std::span<const double> x, std::span<double> y) {
  check_edges(nodes, a, b, g);
  EdgeIncidence inc;
  inc.build(nodes, a, b);
  laplacian_apply(inc, g, x, y);
}

std::vector<double> laplacian_diagonal(std::size_t nodes, std::span<const Index> a, std::span<const Index> b,
                                       std::span<const double> g) {
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
  std::vector<std::int64_t> slot_diag;             // per free unknown
  std::vector<std::int64_t> slot_ab, slot_ba;      // per edge (-1 unless both ends free)
  std::vector<double> factored_values;             // matrix values of the current factorisation
  bool factor_valid = false;

  Eigen::SimplicialLDLT<SpMat, Eigen::Lower, Eigen::AMDOrdering<int>> ldlt;
  Eigen::ConjugateGradient<SpMat, Eigen::Lower | Eigen::Upper, IC> cg_ic;
  Eigen::ConjugateGradient<SpMat, Eigen::Lower | Eigen::Upper, Eigen::DiagonalPreconditioner<double>> cg_diag;
};

LaplacianSolver::LaplacianSolver(LaplacianOptions opt) : opt_(opt), impl_(std::make_unique<Impl>()) {}
LaplacianSolver::~LaplacianSolver() = default;
LaplacianSolver::LaplacianSolver(LaplacianSolver&&) noexcept = default;
LaplacianSolver& LaplacianSolver::operator=(LaplacianSolver&&) noexcept = default;

void LaplacianSolver::set_options(const LaplacianOptions& opt) {
  if (opt.method != opt_.method) invalidate();
  opt_ = opt;
}

void LaplacianSolver::invalidate() { impl_ = std::make_unique<Impl>(); }

void LaplacianSolver::permute_warm_start(const std::vector<Index>& perm, std::size_t old_particle_nodes) {
  if (warm_.empty()) return;
  if (old_particle_nodes > warm_.size()) { warm_.clear(); return; }
  std::vector<double> w;
  w.reserve(perm.size() + warm_.size() - old_particle_nodes);
  for (const Index i : perm) w.push_back(static_cast<std::size_t>(i) < old_particle_nodes ? warm_[i] : kNaN);
  w.insert(w.end(), warm_.begin() + static_cast<std::ptrdiff_t>(old_particle_nodes), warm_.end());
  warm_.swap(w);
}

void LaplacianSolver::visit(Archive& ar, const std::string& prefix) {
  if (!ar.reading() || ar.has(prefix + "/warm_start")) ar.visit(prefix + "/warm_start", warm_);
}

LaplacianResult LaplacianSolver::solve(const LaplacianProblem& p) {
  const auto t0 = std::chrono::steady_clock::now();
  Impl& im = *impl_;
  const std::size_t n = p.nodes, ne = p.a.size();
  check_edges(n, p.a, p.b, p.g);
  if (!p.source.empty() && p.source.size() != n)
    throw SetupError("Laplacian: source has " + std::to_string(p.source.size()) + " entries for " + std::to_string(n) + " nodes");
  if (!p.shunt.empty() && p.shunt.size() != n)
    throw SetupError("Laplacian: shunt has " + std::to_string(p.shunt.size()) + " entries for " + std::to_string(n) + " nodes");
  for (std::size_t e = 0; e < ne; ++e)
    if (!(p.g[e] >= 0.0) || !std::isfinite(p.g[e]))
      physics_fail(p.step, "conductance",
                         "edge " + std::to_string(e) + " (nodes " + std::to_string(p.a[e]) + ", " + std::to_string(p.b[e]) +
                             ") has g = " + std::to_string(p.g[e]) + "; conductances must be finite and >= 0");
  for (std::size_t v = 0; v < p.source.size(); ++v)
    if (!std::isfinite(p.source[v]))
      physics_fail(p.step, "source", "node " + std::to_string(v) + " has a non-finite source");
  bool any_shunt = false;
  for (std::size_t v = 0; v < p.shunt.size(); ++v) {
    if (!(p.shunt[v] >= 0.0) || !std::isfinite(p.shunt[v]))
      physics_fail(p.step, "shunt", "node " + std::to_string(v) + " has shunt " + std::to_string(p.shunt[v]));
    any_shunt = any_shunt || p.shunt[v] > 0.0;
  }

  // Dirichlet nodes.
  std::vector<std::int32_t> group_of(n, -1);
  std::size_t n_dirichlet = 0;
  double dirichlet_sum = 0.0;
  for (std::size_t k = 0; k < p.dirichlet.size(); ++k) {
    const auto& gr = p.dirichlet[k];
    if (!std::isfinite(gr.value))
      physics_fail(p.step, "Dirichlet value", "group " + std::to_string(k) + " has a non-finite value");
    for (const Index v : gr.nodes) {
      if (v < 0 || static_cast<std::size_t>(v) >= n)
        throw SetupError("Laplacian: Dirichlet group " + std::to_string(k) + " names node " + std::to_string(v) +
                         " outside 0.." + std::to_string(n) + "-1");
      if (group_of[v] >= 0)
        throw SetupError("Laplacian: node " + std::to_string(v) + " is in Dirichlet group " + std::to_string(group_of[v]) +
                         (group_of[v] == static_cast<std::int32_t>(k) ? " twice" : " and in group " + std::to_string(k)));
      group_of[v] = static_cast<std::int32_t>(k);
      ++n_dirichlet;
      dirichlet_sum += gr.value;
    }
  }
  if (n_dirichlet == 0 && !any_shunt)
    throw SetupError("Laplacian: no Dirichlet node and no shunt: the potential is defined only up to a constant "
                     "(give at least one node a prescribed value)");

  // Connected components over the edges that conduct (union-find), grounded ones solved.
  std::vector<char> active(ne, 0);
  std::vector<Index> parent(n);
  std::iota(parent.begin(), parent.end(), Index{0});
  for (std::size_t e = 0; e < ne; ++e) {
    if (p.a[e] == p.b[e] || p.g[e] == 0.0) continue;
    active[e] = 1;
    const Index ra = find_root(parent, p.a[e]), rb = find_root(parent, p.b[e]);
    if (ra != rb) parent[std::max(ra, rb)] = std::min(ra, rb);
  }
  std::vector<char> grounded(n, 0);
  for (std::size_t v = 0; v < n; ++v)
    if (group_of[v] >= 0 || (!p.shunt.empty() && p.shunt[v] > 0.0)) grounded[find_root(parent, static_cast<Index>(v))] = 1;
  std::vector<std::int32_t> role(n);
  std::vector<Index> free_node;
  LaplacianResult res;
  for (std::size_t v = 0; v < n; ++v) {
    const Index root = find_root(parent, static_cast<Index>(v));
    if (group_of[v] >= 0) role[v] = -1;
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
    std::vector<Eigen::Triplet<double>> t;
    t.reserve(m + 2 * ne);
    for (std::size_t f = 0; f < m; ++f) t.emplace_back(static_cast<int>(f), static_cast<int>(f), 1.0);
    for (std::size_t e = 0; e < ne; ++e) {
      if (!active[e]) continue;
      const std::int32_t fa = role[p.a[e]], fb = role[p.b[e]];
      if (fa >= 0 && fb >= 0) { t.emplace_back(fa, fb, 1.0); t.emplace_back(fb, fa, 1.0); }
    }
    im.A.resize(static_cast<Eigen::Index>(m), static_cast<Eigen::Index>(m));
    im.A.setFromTriplets(t.begin(), t.end());
    im.A.makeCompressed();
    im.slot_diag.resize(m);
    for (std::size_t f = 0; f < m; ++f) im.slot_diag[f] = slot_of(im.A, static_cast<int>(f), static_cast<int>(f));
    im.slot_ab.assign(ne, -1);
    im.slot_ba.assign(ne, -1);
    for (std::size_t e = 0; e < ne; ++e) {
      if (!active[e]) continue;
      const std::int32_t fa = role[p.a[e]], fb = role[p.b[e]];
      if (fa >= 0 && fb >= 0) { im.slot_ab[e] = slot_of(im.A, fa, fb); im.slot_ba[e] = slot_of(im.A, fb, fa); }
    }
    if (m > 0) {
      switch (opt_.method) {
        case LaplacianMethod::Direct: im.ldlt.analyzePattern(im.A); break;
        case LaplacianMethod::CgIncompleteCholesky: im.cg_ic.analyzePattern(im.A); break;
        case LaplacianMethod::CgDiagonal: im.cg_diag.analyzePattern(im.A); break;
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
    if (im.slot_ab[e] >= 0) { val[im.slot_ab[e]] -= ge; val[im.slot_ba[e]] -= ge; }
  }
  if (!p.shunt.empty())
    for (std::size_t f = 0; f < m; ++f) val[im.slot_diag[f]] += p.shunt[free_node[f]];
  const bool same_values = im.factor_valid && im.factored_values.size() == nnz && std::equal(val, val + nnz, im.factored_values.begin());
  if (!same_values && m > 0) {
    im.factor_valid = false;
    bool ok = true;
    switch (opt_.method) {
      case LaplacianMethod::Direct: im.ldlt.factorize(im.A); ok = im.ldlt.info() == Eigen::Success; break;
      case LaplacianMethod::CgIncompleteCholesky:
        im.cg_ic.factorize(im.A);
        ok = im.cg_ic.preconditioner().info() == Eigen::Success;
        break;
      case LaplacianMethod::CgDiagonal: im.cg_diag.factorize(im.A); break;
    }
    if (!ok)
      physics_fail(p.step, "Laplacian", "the factorisation of the reduced " + std::to_string(m) + " x " +
                                                      std::to_string(m) + " system failed");
    ++factorizations_;
    res.factorized = true;
    im.factored_values.assign(val, val + nnz);
    im.factor_valid = true;
  }

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
    if (opt_.method == LaplacianMethod::Direct) {
      x = im.ldlt.solve(rhs);
    } else {
      Eigen::VectorXd guess(static_cast<Eigen::Index>(m));
      const double fallback = n_dirichlet > 0 ? dirichlet_sum / static_cast<double>(n_dirichlet) : 0.0;
      const bool use_warm = opt_.warm_start && warm_.size() == n;
      for (std::size_t f = 0; f < m; ++f) {
        const double w = use_warm ? warm_[free_node[f]] : kNaN;
        guess[f] = std::isfinite(w) ? w : fallback;
      }
      const int max_it = opt_.max_iterations > 0 ? opt_.max_iterations : static_cast<int>(2 * m);
      bool ok = false;
      if (opt_.method == LaplacianMethod::CgIncompleteCholesky) {
        im.cg_ic.setTolerance(opt_.tolerance);
        im.cg_ic.setMaxIterations(max_it);
        x = im.cg_ic.solveWithGuess(rhs, guess);
        res.iterations = static_cast<int>(im.cg_ic.iterations());
        ok = im.cg_ic.info() == Eigen::Success;
      } else {
        im.cg_diag.setTolerance(opt_.tolerance);
        im.cg_diag.setMaxIterations(max_it);
        x = im.cg_diag.solveWithGuess(rhs, guess);
        res.iterations = static_cast<int>(im.cg_diag.iterations());
        ok = im.cg_diag.info() == Eigen::Success;
      }
      if (!ok)
        physics_fail(p.step, "Laplacian",
                           "conjugate gradients did not reach the relative tolerance " + std::to_string(opt_.tolerance) +
                               " in " + std::to_string(res.iterations) + " iterations (" + std::to_string(m) + " unknowns)");
    }
    const double rn = rhs.norm();
    res.residual_norm = (im.A * x - rhs).norm();
    res.relative_residual = rn > 0.0 ? res.residual_norm / rn : res.residual_norm;
  }

  // Node values, branch fluxes, Dirichlet-group fluxes.
  res.value.assign(n, kNaN);
  for (std::size_t v = 0; v < n; ++v) {
    if (role[v] == -1) res.value[v] = p.dirichlet[group_of[v]].value;
    else if (role[v] >= 0) res.value[v] = x[role[v]];
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
  warm_ = res.value;
  res.solve_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return res;
}

}  // namespace sparkdem
