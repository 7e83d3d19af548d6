// Exact elimination of the rows with at most two off-diagonal entries before the AMG solve
// (engine/graph/low_degree_elimination.hpp): against closed forms (series resistors, a dead-end
// branch) and against the direct solve of the whole system, with sources and shunts.
#include <catch2/catch.hpp>

#include <Eigen/SparseCholesky>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "engine/graph/laplacian.hpp"
#include "engine/graph/low_degree_elimination.hpp"

namespace test_low_degree_elimination {

using namespace sparkdem;
using SpMat = Eigen::SparseMatrix<double>;

namespace {

/// A random sparse graph with many low-degree nodes: a 3-regular-ish core (each node i < core
/// joined to three random core nodes) plus chains and dead-end trees hung on it; conductances
/// log-uniform over three decades. Returns the edge lists.
struct Graph {
  std::size_t nodes = 0;
  std::vector<Index> a, b;
  std::vector<double> g;
};
Graph mixed_graph(std::size_t core, std::size_t extra, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Graph gr;
  gr.nodes = core + extra;
  auto edge = [&](std::size_t i, std::size_t j) {
    gr.a.push_back(static_cast<Index>(i));
    gr.b.push_back(static_cast<Index>(j));
    gr.g.push_back(std::pow(10.0, 3.0 * u(rng) - 1.5));
  };
  for (std::size_t i = 1; i < core; ++i) {
    edge(i, static_cast<std::size_t>(u(rng) * static_cast<double>(i)));  // a spanning tree of the core
    for (int k = 0; k < 2; ++k) {
      const auto j = static_cast<std::size_t>(u(rng) * static_cast<double>(core));
      if (j != i) edge(i, j);
    }
  }
  for (std::size_t i = core; i < core + extra; ++i) {  // chains and dead ends: one or two links back
    edge(i, static_cast<std::size_t>(u(rng) * static_cast<double>(i)));
    if (u(rng) < 0.5) edge(i, static_cast<std::size_t>(u(rng) * static_cast<double>(i)));
  }
  return gr;
}

/// L + diag(shunt), both triangles, compressed.
SpMat system_matrix(const Graph& gr, const std::vector<double>& shunt) {
  std::vector<Eigen::Triplet<double>> t;
  for (std::size_t e = 0; e < gr.a.size(); ++e) {
    if (gr.a[e] == gr.b[e]) continue;
    t.emplace_back(gr.a[e], gr.a[e], gr.g[e]);
    t.emplace_back(gr.b[e], gr.b[e], gr.g[e]);
    t.emplace_back(gr.a[e], gr.b[e], -gr.g[e]);
    t.emplace_back(gr.b[e], gr.a[e], -gr.g[e]);
  }
  for (std::size_t v = 0; v < gr.nodes; ++v) t.emplace_back(static_cast<int>(v), static_cast<int>(v), shunt[v]);
  SpMat A(static_cast<Eigen::Index>(gr.nodes), static_cast<Eigen::Index>(gr.nodes));
  A.setFromTriplets(t.begin(), t.end());
  A.makeCompressed();
  return A;
}

}  // namespace

TEST_CASE("LowDegreeElimination: expand(solve(reduced)) is the direct solution, with sources and shunts",
          "[graph][laplacian][elimination]") {
  // Exact Gaussian elimination: the only difference from the direct solve is rounding.
  const Graph gr = mixed_graph(400, 600, 11);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<double> shunt(gr.nodes);
  for (double& s : shunt) s = u(rng) < 0.05 ? std::pow(10.0, 2.0 * u(rng) - 1.0) : 0.0;
  shunt[0] = 1.0;  // at least one: the system is positive definite
  const SpMat A = system_matrix(gr, shunt);
  Eigen::VectorXd b(A.rows());
  for (Eigen::Index i = 0; i < b.size(); ++i) b[i] = 2.0 * u(rng) - 1.0;

  LowDegreeElimination el;
  el.factor(A);
  INFO("eliminated " << el.eliminated() << " of " << A.rows());
  REQUIRE(el.eliminated() > 300);  // the chains and dead ends, and core nodes they leave with <= 2 links
  REQUIRE(el.eliminated() < static_cast<std::size_t>(A.rows()));
  const SpMat& S = el.reduced();
  REQUIRE(S.rows() == A.rows() - static_cast<Eigen::Index>(el.eliminated()));
  // Invariants of the reduced matrix: symmetric, and every row keeps >= 3 off-diagonal entries.
  CHECK((SpMat(S.transpose()) - S).norm() <= 1e-14 * S.norm());
  for (Eigen::Index c = 0; c < S.cols(); ++c) CHECK(S.outerIndexPtr()[c + 1] - S.outerIndexPtr()[c] - 1 >= 3);

  Eigen::SimplicialLDLT<SpMat> full(A), part(S);
  REQUIRE(full.info() == Eigen::Success);
  REQUIRE(part.info() == Eigen::Success);
  const Eigen::VectorXd x_ref = full.solve(b);
  Eigen::VectorXd work;
  const Eigen::VectorXd b2 = el.reduce_rhs(b, work);
  const Eigen::VectorXd x = el.expand(work, part.solve(b2));
  const double err = (x - x_ref).lpNorm<Eigen::Infinity>() / x_ref.lpNorm<Eigen::Infinity>();
  INFO("max relative difference " << err);
  CHECK(err < 1e-10);
  // The residual of the full system is the reduced one's (here: rounding only).
  CHECK((A * x - b).norm() <= 1e-10 * b.norm());
}

TEST_CASE("LowDegreeElimination: series resistors and a dead-end branch are solved without an AMG iteration",
          "[graph][laplacian][elimination]") {
  // Chain 0 - 1 - ... - 9 with conductances g_k, node 0 at 1 V and node 9 at 0 V, plus a dead-end
  // branch 4 - 10 - 11. Closed form: the chain current I = 1 / sum(1/g_k), V_j = 1 - I sum_{k<j} 1/g_k;
  // the branch carries nothing, so V_10 = V_11 = V_4. Every free node has <= 2 links: all go.
  const std::vector<double> gk = {1.0, 2.0, 0.5, 4.0, 1.5, 3.0, 0.25, 2.5, 1.0};
  std::vector<Index> a, b;
  std::vector<double> g;
  for (std::size_t k = 0; k < gk.size(); ++k) {
    a.push_back(static_cast<Index>(k));
    b.push_back(static_cast<Index>(k + 1));
    g.push_back(gk[k]);
  }
  a.insert(a.end(), {4, 10});
  b.insert(b.end(), {10, 11});
  g.insert(g.end(), {0.7, 0.3});
  LaplacianProblem p;
  p.nodes = 12;
  p.a = a;
  p.b = b;
  p.g = g;
  p.dirichlet = {{{0}, 1.0}, {{9}, 0.0}};
  LaplacianOptions o;
  o.method = LaplacianMethod::Amg;
  o.tolerance = 1e-12;
  LaplacianSolver solver(o);
  const auto res = solver.solve(p);
  CHECK(res.free_nodes == 10);
  CHECK(res.eliminated_rows == 10);
  CHECK(res.iterations == 0);
  double rsum = 0.0;
  for (std::size_t k = 0; k < gk.size(); ++k) rsum += 1.0 / gk[k];
  const double I = 1.0 / rsum;
  double drop = 0.0;
  for (std::size_t j = 0; j < 10; ++j) {
    CHECK(res.value[j] == Approx(1.0 - I * drop).margin(1e-14));
    if (j < gk.size()) drop += 1.0 / gk[j];
  }
  CHECK(res.value[10] == Approx(res.value[4]).margin(1e-15));
  CHECK(res.value[11] == Approx(res.value[4]).margin(1e-15));
  CHECK(res.dirichlet_flux[0] == Approx(I).epsilon(1e-13));
  CHECK(res.flux[gk.size()] == 0.0);  // the dead-end branch carries exactly nothing
}

TEST_CASE("LowDegreeElimination: AMG with and without it agree with the direct solve (sources, shunts, Dirichlet nodes)",
          "[graph][laplacian][elimination]") {
  // A Joule-heating-like problem: sources everywhere, a few shunts, two Dirichlet groups. Both AMG
  // variants must reach the relative residual 1e-10 of the full system, and their potentials must
  // agree with the direct solve to 1e-7 of the largest value and their electrode fluxes to 1e-6.
  const Graph gr = mixed_graph(3000, 3000, 21);
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<double> source(gr.nodes), shunt(gr.nodes, 0.0);
  for (double& q : source) q = u(rng);
  for (std::size_t v = 0; v < gr.nodes; v += 97) shunt[v] = 0.5;
  LaplacianProblem p;
  p.nodes = gr.nodes;
  p.a = gr.a;
  p.b = gr.b;
  p.g = gr.g;
  p.source = source;
  p.shunt = shunt;
  p.dirichlet = {{{0, 1, 2}, 300.0}, {{3, 4}, 290.0}};
  LaplacianSolver direct;
  const auto ref = direct.solve(p);
  double vmax = 0.0;
  for (double v : ref.value) vmax = std::max(vmax, std::abs(v));
  for (const bool elim : {true, false}) {
    INFO("elimination " << elim);
    LaplacianOptions o;
    o.method = LaplacianMethod::Amg;
    o.tolerance = 1e-10;
    o.amg_eliminate_low_degree = elim;
    LaplacianSolver solver(o);
    const auto res = solver.solve(p);
    CHECK(res.relative_residual <= 1e-10 * 1.01);
    CHECK((res.eliminated_rows > 1000) == elim);
    double d = 0.0;
    for (std::size_t v = 0; v < gr.nodes; ++v) d = std::max(d, std::abs(res.value[v] - ref.value[v]));
    INFO("max difference " << d << " of " << vmax);
    CHECK(d <= 1e-7 * vmax);
    for (std::size_t k = 0; k < 2; ++k) CHECK(res.dirichlet_flux[k] == Approx(ref.dirichlet_flux[k]).epsilon(1e-6));
  }
}

}  // namespace test_low_degree_elimination
