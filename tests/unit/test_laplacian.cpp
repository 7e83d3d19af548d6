// The shared graph-Laplacian assembly and solve (engine/graph/laplacian.hpp), against closed forms
// of resistor networks (series chain, parallel paths, the L x L x L cubic lattice between two
// opposite faces), an independent dense pseudo-inverse oracle (two-point resistance
// R_ab = L+_aa + L+_bb - 2 L+_ab), and invariants: Kirchhoff's current law at every free node,
// global current balance, floating clusters, a rigorous CG error bound ||x - x*|| <= ||r|| /
// lambda_min, factorisation reuse, bit-identical checkpoint restart of the warm start, and the
// matrix-free operator against the assembled matrix.
#include <catch2/catch.hpp>

#include <Eigen/Dense>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <vector>

#include "engine/core/error.hpp"
#include "engine/graph/laplacian.hpp"
#include "io/restart/hdf5_archive.hpp"
#include "tests/support/scratch.hpp"
#include "tests/support/tolerance.hpp"

namespace test_laplacian {

using namespace sparkdem;
using test::relative_error;

namespace {

/// An edge list with conductances.
struct Net {
  std::size_t nodes = 0;
  std::vector<Index> a, b;
  std::vector<double> g;
  void add(Index i, Index j, double gij) {
    a.push_back(i);
    b.push_back(j);
    g.push_back(gij);
  }
  LaplacianProblem problem(std::vector<DirichletGroup> d) const {
    LaplacianProblem p;
    p.nodes = nodes;
    p.a = a;
    p.b = b;
    p.g = g;
    p.dirichlet = std::move(d);
    return p;
  }
};

/// L x L x L simple cubic lattice, node (i, j, k) -> i + L (j + L k), bond conductance from gen().
template <class Gen>
Net cubic_lattice(int L, Gen gen) {
  Net n;
  n.nodes = static_cast<std::size_t>(L) * L * L;
  auto id = [L](int i, int j, int k) { return static_cast<Index>(i + L * (j + L * k)); };
  for (int k = 0; k < L; ++k)
    for (int j = 0; j < L; ++j)
      for (int i = 0; i < L; ++i) {
        if (i + 1 < L) n.add(id(i, j, k), id(i + 1, j, k), gen());
        if (j + 1 < L) n.add(id(i, j, k), id(i, j + 1, k), gen());
        if (k + 1 < L) n.add(id(i, j, k), id(i, j, k + 1), gen());
      }
  return n;
}

/// Nodes of the face i = i0 of the lattice.
std::vector<Index> face(int L, int i0) {
  std::vector<Index> f;
  for (int k = 0; k < L; ++k)
    for (int j = 0; j < L; ++j) f.push_back(static_cast<Index>(i0 + L * (j + L * k)));
  return f;
}

/// A connected random graph: a random spanning tree plus `extra` random edges, log-uniform
/// conductances in [1e-2, 1e2].
Net random_graph(std::size_t n, std::size_t extra, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  auto gen = [&] { return std::pow(10.0, -2.0 + 4.0 * u(rng)); };
  Net net;
  net.nodes = n;
  for (std::size_t v = 1; v < n; ++v)
    net.add(static_cast<Index>(std::uniform_int_distribution<std::size_t>(0, v - 1)(rng)), static_cast<Index>(v), gen());
  for (std::size_t k = 0; k < extra; ++k) {
    const auto i = static_cast<Index>(std::uniform_int_distribution<std::size_t>(0, n - 1)(rng));
    const auto j = static_cast<Index>(std::uniform_int_distribution<std::size_t>(0, n - 1)(rng));
    if (i != j) net.add(i, j, gen());
  }
  return net;
}

// The pseudo-transient method needs a capacitance per node: tests/unit/test_laplacian_solvers.cpp.
const LaplacianMethod kMethods[] = {LaplacianMethod::Direct, LaplacianMethod::CgIncompleteCholesky, LaplacianMethod::CgDiagonal,
                                    LaplacianMethod::Amg};

LaplacianOptions with(LaplacianMethod m, double tol = 1e-13) {
  LaplacianOptions o;
  o.method = m;
  o.tolerance = tol;
  return o;
}

/// Net flux leaving each node through its edges.
std::vector<double> node_outflow(const Net& net, const std::vector<double>& flux) {
  std::vector<double> out(net.nodes, 0.0);
  for (std::size_t e = 0; e < net.a.size(); ++e) {
    out[net.a[e]] += flux[e];
    out[net.b[e]] -= flux[e];
  }
  return out;
}

}  // namespace

TEST_CASE("Laplacian: series chain of N resistors carries V / sum R", "[graph][laplacian]") {
  // Closed form: I = V / sum_k (1 / g_k); u_k = V - I sum_{m<k} 1/g_m. Unit resistors: I = V / N.
  const int N = 40;
  const double V = 3.0;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0.5, 2.0);
  for (bool unit : {true, false}) {
    Net net;
    net.nodes = N + 1;
    for (int k = 0; k < N; ++k) net.add(k, k + 1, unit ? 1.0 : u(rng));
    double R = 0.0;
    for (double gk : net.g) R += 1.0 / gk;
    const double I = V / R;
    for (LaplacianMethod m : kMethods) {
      INFO("unit " << unit << " method " << static_cast<int>(m));
      LaplacianSolver solver(with(m));
      const auto res = solver.solve(net.problem({{{0}, V}, {{N}, 0.0}}));
      REQUIRE(res.free_nodes == static_cast<std::size_t>(N - 1));
      CHECK(res.floating_nodes == 0);
      // Direct: rounding only; CG at tolerance 1e-13 on a 39-unknown chain: well inside 1e-12.
      CHECK(relative_error(res.dirichlet_flux[0], I) < 1e-12);
      CHECK(relative_error(-res.dirichlet_flux[1], I) < 1e-12);
      double drop = 0.0;
      for (int k = 0; k < N; ++k) {
        CHECK(relative_error(res.flux[k], I) < 1e-12);
        CHECK(std::abs(res.value[k] - (V - I * drop)) < 1e-12 * V);
        drop += 1.0 / net.g[k];
      }
    }
  }
}

TEST_CASE("Laplacian: two parallel paths add their conductances", "[graph][laplacian]") {
  // Path A: 0 -g1- 2 -g1- 1 (R_A = 2/g1); path B: 0 -g2- 3 -g2- 4 -g2- 1 (R_B = 3/g2).
  // I = V (1/R_A + 1/R_B); the current splits as I_A = V/R_A, I_B = V/R_B.
  const double g1 = 2.5, g2 = 0.7, V = 1.5;
  Net net;
  net.nodes = 5;
  net.add(0, 2, g1);
  net.add(2, 1, g1);
  net.add(0, 3, g2);
  net.add(3, 4, g2);
  net.add(4, 1, g2);
  const double IA = V / (2.0 / g1), IB = V / (3.0 / g2);
  for (LaplacianMethod m : kMethods) {
    LaplacianSolver solver(with(m));
    const auto res = solver.solve(net.problem({{{0}, V}, {{1}, 0.0}}));
    CHECK(relative_error(res.dirichlet_flux[0], IA + IB) < 1e-12);
    CHECK(relative_error(res.dirichlet_flux[1], -(IA + IB)) < 1e-12);
    CHECK(relative_error(res.flux[0], IA) < 1e-12);
    CHECK(relative_error(res.flux[2], IB) < 1e-12);
    CHECK(relative_error(res.value[2], V / 2.0) < 1e-12);
    CHECK(relative_error(res.value[3], 2.0 * V / 3.0) < 1e-12);
  }
}

TEST_CASE("Laplacian: L^3 cubic lattice between opposite faces has R = (L-1)/L^2", "[graph][laplacian]") {
  // Faces i = 0 (potential V) and i = L-1 (0): by symmetry no current crosses the transverse
  // bonds, so the lattice is L^2 parallel chains of L-1 unit resistors: R = (L-1)/L^2.
  for (int L : {2, 5, 9}) {
    const Net net = cubic_lattice(L, [] { return 1.0; });
    const double V = 2.0, I = V * L * L / (L - 1.0);
    for (LaplacianMethod m : kMethods) {
      INFO("L " << L << " method " << static_cast<int>(m));
      LaplacianSolver solver(with(m));
      const auto res = solver.solve(net.problem({{face(L, 0), V}, {face(L, L - 1), 0.0}}));
      CHECK(res.free_nodes == static_cast<std::size_t>(L * L * (L - 2)));
      CHECK(relative_error(res.dirichlet_flux[0], I) < 1e-12);
      CHECK(relative_error(res.dirichlet_flux[1], -I) < 1e-12);
      // Tellegen / power identity: V I = sum_e g_e (u_a - u_b)^2.
      double P = 0.0;
      for (std::size_t e = 0; e < net.a.size(); ++e) P += res.flux[e] * res.flux[e] / net.g[e];
      CHECK(relative_error(P, V * I) < 1e-12);
      // Maximum principle.
      for (double v : res.value) {
        CHECK(v >= -1e-12 * V);
        CHECK(v <= V * (1.0 + 1e-12));
      }
    }
  }
}

TEST_CASE("Laplacian: two-point resistance equals the dense pseudo-inverse formula", "[graph][laplacian]") {
  // Independent oracle: R_st = L+_ss + L+_tt - 2 L+_st (Moore-Penrose pseudo-inverse of the
  // full Laplacian of a connected graph, dense). With u_s = 1, u_t = 0 the current is 1 / R_st.
  const Net net = random_graph(60, 90, 11);
  const Eigen::MatrixXd Ld = Eigen::MatrixXd(assemble_laplacian(net.nodes, net.a, net.b, net.g));
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(Ld);
  // Pseudo-inverse from the eigen-decomposition, dropping the one zero eigenvalue (connected).
  const Eigen::VectorXd lam = eig.eigenvalues();
  REQUIRE(std::abs(lam[0]) < 1e-10 * lam[lam.size() - 1]);
  REQUIRE(lam[1] > 1e-8 * lam[lam.size() - 1]);
  Eigen::VectorXd inv = Eigen::VectorXd::Zero(lam.size());
  for (Eigen::Index k = 1; k < lam.size(); ++k) inv[k] = 1.0 / lam[k];
  const Eigen::MatrixXd Lp = eig.eigenvectors() * inv.asDiagonal() * eig.eigenvectors().transpose();
  for (auto [s, t] : {std::pair<Index, Index>{0, 59}, {3, 17}, {42, 7}}) {
    const double R = Lp(s, s) + Lp(t, t) - 2.0 * Lp(s, t);
    LaplacianSolver solver;
    const auto res = solver.solve(net.problem({{{s}, 1.0}, {{t}, 0.0}}));
    // Dense eigen-decomposition error ~ cond * eps with cond <= 1e6 here: 1e-8 is generous.
    CHECK(relative_error(res.dirichlet_flux[0], 1.0 / R) < 1e-8);
  }
}

TEST_CASE("Laplacian: Kirchhoff's current law at every free node, global balance", "[graph][laplacian]") {
  // Random graph, random injected currents, three electrodes: at every free node the branch
  // currents leaving it sum to the injected current; all sources and electrode currents balance.
  Net net = random_graph(400, 800, 23);
  net.add(5, 5, 3.0);  // a self-loop: ignored
  net.add(6, 9, 0.0);  // a zero-conductance edge: ignored
  std::mt19937_64 rng(3);
  std::normal_distribution<double> nd(0.0, 1.0);
  std::vector<double> q(net.nodes);
  for (double& v : q) v = nd(rng);
  for (LaplacianMethod m : kMethods) {
    INFO("method " << static_cast<int>(m));
    LaplacianSolver solver(with(m, 1e-14));
    auto p = net.problem({{{0, 1, 2}, 1.0}, {{10, 11}, -0.5}, {{399}, 0.25}});
    p.source = q;
    const auto res = solver.solve(p);
    const auto out = node_outflow(net, res.flux);
    double worst = 0.0;
    std::size_t nan_count = 0;
    for (std::size_t v = 0; v < net.nodes; ++v) {
      if (std::isnan(res.value[v])) ++nan_count;  // none expected: the graph is connected
      bool dir = false;
      for (const auto& gr : p.dirichlet) dir = dir || std::find(gr.nodes.begin(), gr.nodes.end(), static_cast<Index>(v)) != gr.nodes.end();
      if (dir) continue;
      double scale = std::abs(q[v]);
      for (std::size_t e = 0; e < net.a.size(); ++e)
        if (net.a[e] == static_cast<Index>(v) || net.b[e] == static_cast<Index>(v)) scale += std::abs(res.flux[e]);
      worst = std::max(worst, std::abs(out[v] - q[v]) / scale);
    }
    CHECK(nan_count == 0);
    CHECK(worst < 1e-10);
    // Conservation: what the electrodes supply plus what is injected at free nodes sums to zero
    // (a source at a Dirichlet node is ignored: the prescribed value wins).
    double sum = 0.0, scale = 0.0;
    for (double f : res.dirichlet_flux) {
      sum += f;
      scale += std::abs(f);
    }
    for (Index v : {0, 1, 2, 10, 11, 399}) CHECK(std::abs(res.value[v] - (v < 3 ? 1.0 : v < 12 ? -0.5 : 0.25)) == 0.0);
    for (std::size_t v = 3; v < net.nodes; ++v)
      if (v != 10 && v != 11 && v != 399) {
        sum += q[v];
        scale += std::abs(q[v]);
      }
    CHECK(std::abs(sum) < 1e-10 * scale);
    CHECK(res.flux[net.a.size() - 1] == 0.0);  // g = 0 edge
  }
}

TEST_CASE("Laplacian: floating clusters are excluded and NaN, never singular", "[graph][laplacian]") {
  // 0 -1- 2 -1- 3 -1- 1 between electrodes; triangle {4,5,6} and isolated node 7 float; node 8
  // hangs off electrode 0 only (grounded, carries no current); {9,10} is attached to the chain
  // by a g = 0 edge only (floating).
  Net net;
  net.nodes = 11;
  net.add(0, 2, 1.0);
  net.add(2, 3, 1.0);
  net.add(3, 1, 1.0);
  net.add(4, 5, 2.0);
  net.add(5, 6, 2.0);
  net.add(6, 4, 2.0);
  net.add(0, 8, 4.0);
  net.add(9, 10, 1.0);
  net.add(3, 9, 0.0);
  std::vector<double> q(net.nodes, 0.0);
  q[5] = 7.0;  // a source on a floating node is ignored
  for (LaplacianMethod m : kMethods) {
    LaplacianSolver solver(with(m));
    auto p = net.problem({{{0}, 3.0}, {{1}, 0.0}});
    p.source = q;
    const auto res = solver.solve(p);
    CHECK(res.floating_nodes == 6);  // 4, 5, 6, 7, 9, 10
    CHECK(res.floating_components == 3);
    CHECK(res.free_nodes == 3);  // 2, 3, 8
    for (Index v : {4, 5, 6, 7, 9, 10}) CHECK(std::isnan(res.value[v]));
    for (std::size_t e : {3u, 4u, 5u, 7u, 8u}) CHECK(res.flux[e] == 0.0);
    CHECK(relative_error(res.dirichlet_flux[0], 1.0) < 1e-12);
    CHECK(relative_error(res.value[8], 3.0) < 1e-12);
    CHECK(std::abs(res.flux[6]) < 1e-12);
  }
  // Everything floating but the electrode: a valid answer, zero current.
  LaplacianSolver solver;
  const auto res = solver.solve(net.problem({{{7}, 1.0}}));
  CHECK(res.free_nodes == 0);
  CHECK(res.floating_nodes == 10);
  CHECK(res.dirichlet_flux[0] == 0.0);
}

TEST_CASE("Laplacian: ill-posed or malformed problems throw typed errors", "[graph][laplacian]") {
  Net net;
  net.nodes = 3;
  net.add(0, 1, 1.0);
  net.add(1, 2, 1.0);
  LaplacianSolver solver;
  CHECK_THROWS_AS(solver.solve(net.problem({})), SetupError);                        // no Dirichlet at all
  CHECK_THROWS_AS(solver.solve(net.problem({{{}, 1.0}})), SetupError);               // only empty groups
  CHECK_THROWS_AS(solver.solve(net.problem({{{0}, 1.0}, {{0}, 2.0}})), SetupError);  // node in two groups
  CHECK_THROWS_AS(solver.solve(net.problem({{{3}, 1.0}})), SetupError);              // node out of range
  Net bad = net;
  bad.g[1] = -1.0;
  CHECK_THROWS_AS(solver.solve(bad.problem({{{0}, 1.0}})), PhysicsError);
  bad.g[1] = std::nan("");
  CHECK_THROWS_AS(solver.solve(bad.problem({{{0}, 1.0}})), PhysicsError);
  auto p = net.problem({{{0}, 1.0}});
  p.g = std::span<const double>(net.g.data(), 1);  // one conductance for two edges
  CHECK_THROWS_AS(solver.solve(p), SetupError);
  // A CG that cannot reach its tolerance in the allowed iterations is an error, not a silent answer.
  const Net big = cubic_lattice(6, [] { return 1.0; });
  LaplacianOptions o = with(LaplacianMethod::CgDiagonal, 1e-14);
  o.max_iterations = 2;
  LaplacianSolver capped(o);
  CHECK_THROWS_AS(capped.solve(big.problem({{face(6, 0), 1.0}, {face(6, 5), 0.0}})), PhysicsError);
}

TEST_CASE("Laplacian: a shunt grounds a component without a Dirichlet node", "[graph][laplacian]") {
  // (L u)_v + s_v u_v = q_v. Nodes 0 -g- 1, shunt s on node 1, source q at node 0:
  // u_1 = q / s, u_0 = u_1 + q / g. A third, unshunted isolated node floats.
  const double g = 2.0, s = 0.5, q = 3.0;
  Net net;
  net.nodes = 3;
  net.add(0, 1, g);
  std::vector<double> shunt{0.0, s, 0.0}, src{q, 0.0, 0.0};
  for (LaplacianMethod m : kMethods) {
    LaplacianSolver solver(with(m));
    auto p = net.problem({});
    p.shunt = shunt;
    p.source = src;
    const auto res = solver.solve(p);
    CHECK(relative_error(res.value[1], q / s) < 1e-12);
    CHECK(relative_error(res.value[0], q / s + q / g) < 1e-12);
    CHECK(relative_error(res.flux[0], q) < 1e-12);
    CHECK(std::isnan(res.value[2]));
  }
}

TEST_CASE("Laplacian: CG agrees with the direct solve within its rigorous error bound", "[graph][laplacian]") {
  // For the SPD reduced system A x = b, the error of an approximate x with residual r obeys
  // ||x - x*||_2 <= ||r||_2 / lambda_min(A). lambda_min from a dense eigen-solve of A.
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const int L = 7;
  const Net net = cubic_lattice(L, [&] { return std::pow(10.0, -1.0 + 2.0 * u(rng)); });
  const auto prob = net.problem({{face(L, 0), 1.0}, {face(L, L - 1), 0.0}});
  LaplacianSolver direct;
  const auto ref = direct.solve(prob);
  // Reduced matrix: full Laplacian without the Dirichlet rows and columns.
  const Eigen::MatrixXd Lfull = Eigen::MatrixXd(assemble_laplacian(net.nodes, net.a, net.b, net.g));
  std::vector<Eigen::Index> freev;
  for (int k = 0; k < L; ++k)
    for (int j = 0; j < L; ++j)
      for (int i = 1; i < L - 1; ++i) freev.push_back(i + L * (j + L * k));
  std::sort(freev.begin(), freev.end());
  Eigen::MatrixXd A(freev.size(), freev.size());
  for (std::size_t r = 0; r < freev.size(); ++r)
    for (std::size_t c = 0; c < freev.size(); ++c) A(r, c) = Lfull(freev[r], freev[c]);
  const double lmin = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(A, Eigen::EigenvaluesOnly).eigenvalues()[0];
  REQUIRE(lmin > 0.0);
  for (LaplacianMethod m : {LaplacianMethod::CgIncompleteCholesky, LaplacianMethod::CgDiagonal, LaplacianMethod::Amg}) {
    for (double tol : {1e-6, 1e-10}) {
      INFO("method " << static_cast<int>(m) << " tol " << tol);
      LaplacianSolver cg(with(m, tol));
      const auto res = cg.solve(prob);
      CHECK(res.iterations > 0);
      // The solver's own stopping test (relative residual of the reduced system); the residual
      // is recomputed after the solve, so allow for its rounding.
      CHECK(res.relative_residual <= tol * 1.1 + 1e-13);
      double err2 = 0.0;
      for (auto v : freev) err2 += std::pow(res.value[v] - ref.value[v], 2);
      // Bound on the CG error plus the (tiny) direct-solve error, same bound with its residual.
      CHECK(std::sqrt(err2) <= (res.residual_norm + ref.residual_norm) / lmin * 1.01 + 1e-12);
    }
  }
}

TEST_CASE("Laplacian: analysis and factorisation are reused while unchanged", "[graph][laplacian]") {
  std::mt19937_64 rng(29);
  std::uniform_real_distribution<double> u(0.5, 1.5);
  const int L = 6;
  Net net = cubic_lattice(L, [&] { return u(rng); });
  const std::vector<DirichletGroup> d{{face(L, 0), 1.0}, {face(L, L - 1), 0.0}};
  for (LaplacianMethod m : kMethods) {
    INFO("method " << static_cast<int>(m));
    LaplacianSolver solver(with(m, 1e-12));
    Net cur = net;
    const auto r1 = solver.solve(cur.problem(d));
    CHECK((r1.analyzed && r1.factorized));
    // Same problem again: nothing recomputed, same answer (bit for bit for the direct method; CG
    // restarts from the solution, so it stops at once within the tolerance).
    const auto r2 = solver.solve(cur.problem(d));
    CHECK((!r2.analyzed && !r2.factorized));
    CHECK(solver.analyses() == 1);
    CHECK(solver.factorizations() == 1);
    for (std::size_t v = 0; v < cur.nodes; ++v) CHECK(std::abs(r2.value[v] - r1.value[v]) <= 1e-9);
    if (m == LaplacianMethod::Direct) CHECK(r2.value == r1.value);
    // New conductances, same topology: factorize only; equals a fresh solver's answer.
    for (double& gk : cur.g) gk *= u(rng);
    const auto r3 = solver.solve(cur.problem(d));
    CHECK((!r3.analyzed && r3.factorized));
    CHECK(solver.analyses() == 1);
    CHECK(solver.factorizations() == 2);
    LaplacianSolver fresh(with(LaplacianMethod::Direct));
    const auto r3f = fresh.solve(cur.problem(d));
    for (std::size_t v = 0; v < cur.nodes; ++v) CHECK(std::abs(r3.value[v] - r3f.value[v]) <= 1e-9);
    if (m == LaplacianMethod::Direct) CHECK(r3.value == r3f.value);
    // New Dirichlet values only: right-hand side only.
    auto d2 = d;
    d2[0].value = 5.0;
    const auto r4 = solver.solve(cur.problem(d2));
    CHECK((!r4.analyzed && !r4.factorized));
    CHECK(relative_error(r4.dirichlet_flux[0], 5.0 * r3.dirichlet_flux[0]) < 1e-9);
    // A conductance set to 0 changes the structure; so does a different Dirichlet set.
    cur.g[3] = 0.0;
    CHECK(solver.solve(cur.problem(d2)).analyzed);
    auto d3 = d2;
    d3[1].nodes.pop_back();
    CHECK(solver.solve(cur.problem(d3)).analyzed);
    CHECK(solver.analyses() == 3);
  }
}

TEST_CASE("Laplacian: laplacian_apply and the diagonal equal the assembled matrix", "[graph][laplacian]") {
  Net net = random_graph(300, 700, 41);
  net.add(4, 4, 2.0);   // self-loop
  net.add(7, 8, 0.0);   // zero conductance
  net.add(7, 8, 1.25);  // parallel edges
  net.add(8, 7, 0.5);
  std::mt19937_64 rng(2);
  std::normal_distribution<double> nd(0.0, 1.0);
  std::vector<double> x(net.nodes);
  for (double& v : x) v = nd(rng);
  const Eigen::SparseMatrix<double> Lm = assemble_laplacian(net.nodes, net.a, net.b, net.g);
  const Eigen::VectorXd ref = Lm * Eigen::Map<const Eigen::VectorXd>(x.data(), static_cast<Eigen::Index>(x.size()));
  std::vector<double> y(net.nodes);
  laplacian_apply(net.nodes, net.a, net.b, net.g, x, y);
  const auto diag = laplacian_diagonal(net.nodes, net.a, net.b, net.g);
  double worst = 0.0, worst_d = 0.0;
  for (std::size_t v = 0; v < net.nodes; ++v) {
    // Same terms summed in another order: relative to the sum of |terms| <= 2 D_v max|x|.
    double scale = 0.0;
    for (std::size_t e = 0; e < net.a.size(); ++e)
      if (net.a[e] != net.b[e] && (net.a[e] == static_cast<Index>(v) || net.b[e] == static_cast<Index>(v)))
        scale += net.g[e] * (std::abs(x[net.a[e]]) + std::abs(x[net.b[e]]));
    worst = std::max(worst, std::abs(y[v] - ref[v]) / scale);
    worst_d = std::max(worst_d, relative_error(diag[v], Lm.coeff(v, v)));
  }
  CHECK(worst < 1e-14);
  CHECK(worst_d < 1e-14);
  // Bit-identical for 1 and 2 threads (fixed per-node summation order).
  EdgeIncidence inc;
  inc.build(net.nodes, net.a, net.b);
  std::vector<double> y1(net.nodes), y2(net.nodes);
  const int before = omp_get_max_threads();
  omp_set_num_threads(1);
  laplacian_apply(inc, net.g, x, y1);
  omp_set_num_threads(2);
  laplacian_apply(inc, net.g, x, y2);
  omp_set_num_threads(before);
  CHECK(y1 == y2);
  CHECK(y1 == y);
}

TEST_CASE("Laplacian: the CG warm start goes through a checkpoint bit for bit", "[graph][laplacian][restart]") {
  // Solver A solves P1 then P2; solver B is restored from A's checkpoint after P1 and solves P2:
  // same iterations and bit-identical values. Without the restore the iterates differ.
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> u(0.5, 1.5);
  const int L = 7;
  Net net = cubic_lattice(L, [&] { return u(rng); });
  const std::vector<DirichletGroup> d{{face(L, 0), 1.0}, {face(L, L - 1), 0.0}};
  const LaplacianOptions o = with(LaplacianMethod::CgIncompleteCholesky, 1e-8);
  LaplacianSolver A(o);
  A.solve(net.problem(d));
  test::ScratchDir dir("sparkdem_laplacian");
  const auto path = dir.path / "ck.h5";
  {
    auto out = io::Hdf5Archive::for_writing(path);
    A.visit(out, "modules/electrical/solver");
    out.commit();
  }
  Net net2 = net;
  for (double& gk : net2.g) gk *= u(rng);
  const auto ra = A.solve(net2.problem(d));
  LaplacianSolver B(o);
  {
    auto in = io::Hdf5Archive::for_reading(path);
    B.visit(in, "modules/electrical/solver");
  }
  const auto rb = B.solve(net2.problem(d));
  CHECK(rb.iterations == ra.iterations);
  CHECK(rb.value == ra.value);
  LaplacianSolver C(o);
  const auto rc = C.solve(net2.problem(d));
  CHECK(rc.value != ra.value);
  // A renumbering of the nodes carries the warm start along (new[i] = old[perm[i]]).
  LaplacianSolver P(o);
  P.solve(net.problem(d));
  const std::vector<double> before = P.warm_start();
  std::vector<Index> perm(net.nodes);
  std::iota(perm.rbegin(), perm.rend(), Index{0});
  P.permute_warm_start(perm, net.nodes);
  for (std::size_t i = 0; i < net.nodes; ++i) CHECK(P.warm_start()[i] == before[perm[i]]);
}

}  // namespace test_laplacian
