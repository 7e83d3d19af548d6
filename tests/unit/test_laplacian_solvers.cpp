// The five LaplacianSolver methods against each other on a random polydisperse network, the
// pseudo-transient iteration of seed 000 and its stability limit (sintering-electrical.md §2.3,
// §2.10: converges below 2 / lambda_max(C^-1 K), diverges above, refused above unless allowed),
// the limit against a dense eigen-solve and the two-node closed form Eq. 43, and the effective
// resistance by sparse static condensation (cpc-and-networks.md §2.5): floating and
// single-electrode clusters excluded, G = 0 and R = +inf without a spanning path.
#include <catch2/catch.hpp>

#include <Eigen/Dense>
#include <Eigen/SparseCholesky>

#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "engine/core/error.hpp"
#include "engine/graph/effective_resistance.hpp"
#include "engine/graph/laplacian.hpp"
#include "tests/support/tolerance.hpp"

namespace test_laplacian_solvers {

using namespace sparkdem;
using test::relative_error;

namespace {

/// A random geometric network of polydisperse spheres: n centres uniform in the unit cube, radii
/// uniform in [1, 3] r0, an edge wherever two spheres overlap (|x_i - x_j| < r_i + r_j), mean
/// degree about 6 (r0 chosen for it). Conductances log-uniform over three decades (contrast 1e3);
/// capacitance C_i = m_i c with m_i ~ r_i^3 (the seed's C_i = m_i c_i, c = 1 per unit volume).
/// Electrodes: centres with x < 0.08 (high) and x > 0.92 (low). At this degree the network has
/// isolated spheres and small clusters: floating nodes, and clusters touching one electrode only.
struct RandomNetwork {
  std::size_t nodes = 0;
  std::vector<Index> a, b;
  std::vector<double> g, cap;
  std::vector<Index> high, low;

  LaplacianProblem network() const {
    LaplacianProblem p;
    p.nodes = nodes;
    p.a = a;
    p.b = b;
    p.g = g;
    p.capacitance = cap;
    return p;
  }
  LaplacianProblem problem(double v_high = 1.0) const {
    LaplacianProblem p = network();
    p.dirichlet = {{high, v_high}, {low, 0.0}};
    return p;
  }
};

RandomNetwork random_network(std::size_t n, std::uint64_t seed, double degree = 6.0) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  RandomNetwork net;
  net.nodes = n;
  std::vector<Eigen::Vector3d> x(n);
  std::vector<double> r(n);
  for (std::size_t i = 0; i < n; ++i) {
    x[i] = Eigen::Vector3d(u(rng), u(rng), u(rng));
    r[i] = 1.0 + 2.0 * u(rng);
  }
  // Expected degree n (4/3) pi r0^3 E[(r_i + r_j)^3], E[(r_i + r_j)^3] = 68 for r ~ U[1, 3].
  const double r0 = std::cbrt(degree / (static_cast<double>(n) * 4.0 / 3.0 * M_PI * 68.0));
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j)
      if ((x[i] - x[j]).norm() < r0 * (r[i] + r[j])) {
        net.a.push_back(static_cast<Index>(i));
        net.b.push_back(static_cast<Index>(j));
        net.g.push_back(std::pow(10.0, 3.0 * u(rng)));
      }
  for (std::size_t i = 0; i < n; ++i) {
    net.cap.push_back(r[i] * r[i] * r[i]);
    if (x[i][0] < 0.08) net.high.push_back(static_cast<Index>(i));
    if (x[i][0] > 0.92) net.low.push_back(static_cast<Index>(i));
  }
  return net;
}

/// The reduced matrix A = K_uu on the nodes a solve left free (finite value, not an electrode),
/// in ascending node order, and that list.
Eigen::SparseMatrix<double> reduced_matrix(const RandomNetwork& net, const LaplacianResult& ref, std::vector<Index>& free_nodes) {
  std::vector<char> fixed(net.nodes, 0);
  for (Index v : net.high) fixed[v] = 1;
  for (Index v : net.low) fixed[v] = 1;
  std::vector<int> id(net.nodes, -1);
  free_nodes.clear();
  for (std::size_t v = 0; v < net.nodes; ++v)
    if (!fixed[v] && std::isfinite(ref.value[v])) {
      id[v] = static_cast<int>(free_nodes.size());
      free_nodes.push_back(static_cast<Index>(v));
    }
  const Eigen::SparseMatrix<double> L = assemble_laplacian(net.nodes, net.a, net.b, net.g);
  std::vector<Eigen::Triplet<double>> t;
  for (int c = 0; c < L.outerSize(); ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(L, c); it; ++it)
      if (id[it.row()] >= 0 && id[c] >= 0) t.emplace_back(id[it.row()], id[c], it.value());
  Eigen::SparseMatrix<double> A(static_cast<Eigen::Index>(free_nodes.size()), static_cast<Eigen::Index>(free_nodes.size()));
  A.setFromTriplets(t.begin(), t.end());
  A.makeCompressed();
  return A;
}

/// Estimate of lambda_min(A) by inverse iteration (60 steps, sparse Cholesky). The Rayleigh
/// quotient mu of A^-1 is <= 1 / lambda_min, so 1 / mu >= lambda_min: an error bound
/// ||r|| / (1 / mu) is never looser than the rigorous ||r|| / lambda_min.
double lambda_min_estimate(const Eigen::SparseMatrix<double>& A) {
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(A);
  REQUIRE(ldlt.info() == Eigen::Success);
  Eigen::VectorXd y = Eigen::VectorXd::Ones(A.rows()).normalized(), z;
  double mu = 0.0;
  for (int k = 0; k < 60; ++k) {
    z = ldlt.solve(y);
    mu = y.dot(z);
    y = z.normalized();
  }
  return 1.0 / mu;
}

LaplacianOptions with(LaplacianMethod m, double tol = 1e-10) {
  LaplacianOptions o;
  o.method = m;
  o.tolerance = tol;
  return o;
}

}  // namespace

TEST_CASE("Laplacian solvers: all five methods agree within their tolerances on a random polydisperse network",
          "[graph][laplacian][solvers]") {
  // 2500 spheres (contrast 1e3 in g, 27 in C). Direct is the reference (exact up to rounding).
  // For every other method x with true residual r (recomputed by the solver), the rigorous bound
  // ||x - x*|| <= ||r|| / lambda_min(A) must hold against the direct answer (both residuals
  // counted), with lambda_min estimated from above (see lambda_min_estimate: a stricter check).
  const RandomNetwork net = random_network(2500, 7);
  const auto prob = net.problem();
  LaplacianSolver direct;
  const auto ref = direct.solve(prob);
  REQUIRE(ref.floating_nodes > 0);  // the network has isolated spheres / clusters
  REQUIRE(ref.free_nodes > 1500);
  REQUIRE(ref.dirichlet_flux[0] > 0.0);
  std::vector<Index> freev;
  const auto A = reduced_matrix(net, ref, freev);
  REQUIRE(static_cast<std::size_t>(A.rows()) == ref.free_nodes);
  const double lmin = lambda_min_estimate(A);
  REQUIRE(lmin > 0.0);

  struct Case {
    LaplacianMethod m;
    double tol;
  };
  for (const Case c : {Case{LaplacianMethod::CgIncompleteCholesky, 1e-10}, Case{LaplacianMethod::CgDiagonal, 1e-10},
                       Case{LaplacianMethod::Amg, 1e-10}, Case{LaplacianMethod::PseudoTransient, 0.0}}) {
    INFO("method " << laplacian_method_name(c.m));
    LaplacianOptions o = with(c.m, c.tol);
    // Pseudo-transient: at 0.95 of the true limit, indicator normalised by the electrode
    // spread (§7.6) down to 1e-12.
    o.pseudo.dt_fraction = 0.95;
    o.pseudo.indicator = ChangeIndicator::Range;
    o.pseudo.beta = 1e-12;
    LaplacianSolver solver(o);
    const auto res = solver.solve(prob);
    CHECK(res.floating_nodes == ref.floating_nodes);
    CHECK(res.free_nodes == ref.free_nodes);
    if (c.m != LaplacianMethod::PseudoTransient)
      CHECK(res.relative_residual <= c.tol * 1.1 + 1e-14);
    else
      CHECK(res.pseudo.change_indicator < 1e-12);
    double err2 = 0.0;
    for (Index v : freev) err2 += std::pow(res.value[v] - ref.value[v], 2);
    const double bound = (res.residual_norm + ref.residual_norm) / lmin;
    CHECK(std::sqrt(err2) <= bound * 1.01 + 1e-14);
    // The electrode current I = sum over the high electrode's edges g_e (V - x_other), so
    // |dI| <= (sum of those g_e) max|dx| <= (sum of those g_e) ||dx||_2.
    std::vector<char> is_high(net.nodes, 0);
    for (Index v : net.high) is_high[v] = 1;
    double dI = 0.0;
    for (std::size_t e = 0; e < net.a.size(); ++e)
      if (is_high[net.a[e]] != is_high[net.b[e]]) dI += net.g[e] * std::sqrt(err2);
    CHECK(std::abs(res.dirichlet_flux[0] - ref.dirichlet_flux[0]) <= dI + 1e-12 * ref.dirichlet_flux[0]);
    // And in absolute terms: every method gets the current to 1e-6 here.
    CHECK(relative_error(res.dirichlet_flux[0], ref.dirichlet_flux[0]) < 1e-6);
    INFO("iterations " << res.iterations << " relative residual " << res.relative_residual << " error " << std::sqrt(err2) << " bound "
                       << bound << " seconds " << res.solve_seconds);
    CHECK(res.iterations > 0);
  }
}

TEST_CASE("Laplacian solvers: pseudo-transient converges at 0.95 of the true limit, diverges at 1.05",
          "[graph][laplacian][solvers][pseudo_transient]") {
  const RandomNetwork net = random_network(2000, 11);
  const auto prob = net.problem();
  LaplacianSolver direct;
  const auto ref = direct.solve(prob);

  LaplacianOptions o = with(LaplacianMethod::PseudoTransient);
  o.pseudo.indicator = ChangeIndicator::Range;
  o.pseudo.beta = 1e-9;
  o.pseudo.dt_fraction = 0.95;
  LaplacianSolver stable(o);
  const auto res = stable.solve(prob);
  const auto& rep = res.pseudo;
  CHECK(rep.dt == Approx(0.95 * rep.dt_limit).epsilon(1e-15));
  CHECK(rep.dt_limit == Approx(2.0 / rep.lambda_max).epsilon(1e-15));
  CHECK(rep.lambda_residual_bound <= 1e-6 * rep.lambda_max);
  CHECK(rep.eigen_iterations <= 100);
  // The cheap Gershgorin step is safe (below the true limit) and, on this network, far below it.
  CHECK(rep.dt_gershgorin <= rep.dt_limit);
  CHECK(rep.dt_gershgorin < 0.9 * rep.dt_limit);
  CHECK(rep.change_indicator < 1e-9);
  CHECK(res.iterations > 10);
  double worst = 0.0;
  for (std::size_t v = 0; v < net.nodes; ++v)
    if (std::isfinite(ref.value[v])) worst = std::max(worst, std::abs(res.value[v] - ref.value[v]));
  CHECK(worst < 1e-3);  // converged to the solution (the indicator is not the error: see below)
  INFO("iterations " << res.iterations << " worst node error " << worst << " indicator " << rep.change_indicator);

  // 1.05 x the limit: refused by default, before iterating...
  o.pseudo.dt_fraction = 1.05;
  LaplacianSolver refuse(o);
  try {
    refuse.solve(prob);
    FAIL("a step above the limit was accepted");
  } catch (const PhysicsError& e) { CHECK(std::string(e.what()).find("not below the true stability limit") != std::string::npos); }
  // ... and with allow_unstable it runs, and the divergence is detected and reported (no NaN
  // returned): well before the iteration cap.
  o.pseudo.allow_unstable = true;
  o.max_iterations = 200000;
  LaplacianSolver unstable(o);
  try {
    unstable.solve(prob);
    FAIL("the iteration at 1.05 x the limit did not diverge");
  } catch (const PhysicsError& e) {
    const std::string msg = e.what();
    CHECK(msg.find("diverges") != std::string::npos);
    INFO(msg);
    CHECK(msg.find("dt / true limit = 1.05") != std::string::npos);
  }
  // An absolute dt above the limit is refused the same way; exactly at the limit too (the
  // iteration only converges strictly below it).
  LaplacianOptions od = with(LaplacianMethod::PseudoTransient);
  od.pseudo.dt = 1.0001 * rep.dt_limit;
  CHECK_THROWS_AS(LaplacianSolver(od).solve(prob), PhysicsError);
  od.pseudo.dt = rep.dt_limit;
  CHECK_THROWS_AS(LaplacianSolver(od).solve(prob), PhysicsError);
}

TEST_CASE("Laplacian solvers: pseudo-transient stops on its indicator, not on the error", "[graph][laplacian][solvers][pseudo_transient]") {
  // The paper's set-up: Eq. 14 per node, beta = 2e-4, at the cheap Gershgorin step (electrodes at
  // 2 V and 1 V, so no node sits near 0 V). Near convergence the change per iteration is
  // (1 - rho) x the error with rho -> 1, so the iteration stops with an error far above beta:
  // the reported true residual shows it.
  const RandomNetwork net = random_network(2000, 11);
  auto prob = net.problem(2.0);
  prob.dirichlet[1].value = 1.0;
  LaplacianOptions o = with(LaplacianMethod::PseudoTransient);
  LaplacianSolver probe(o);
  const double dt_g = probe.solve(prob).pseudo.dt_gershgorin;
  o.pseudo.dt = dt_g;
  LaplacianSolver paper(o);
  const auto res = paper.solve(prob);
  CHECK(res.pseudo.change_indicator < 2e-4);
  CHECK(res.pseudo.dt == dt_g);
  LaplacianSolver direct;
  const auto ref = direct.solve(prob);
  double worst = 0.0;
  for (std::size_t v = 0; v < net.nodes; ++v)
    if (std::isfinite(ref.value[v])) worst = std::max(worst, std::abs(res.value[v] - ref.value[v]) / ref.value[v]);
  const double err_I = relative_error(res.dirichlet_flux[0], ref.dirichlet_flux[0]);
  INFO("iterations " << res.iterations << " indicator " << res.pseudo.change_indicator << " worst relative node error " << worst
                     << " current error " << err_I << " relative residual " << res.relative_residual);
  CHECK(worst > 10.0 * res.pseudo.change_indicator);
  CHECK(err_I > 2e-4);
  CHECK(res.relative_residual > 1e-3);
}

TEST_CASE("Laplacian solvers: lambda_max agrees with a dense eigen-solve, Gershgorin bounds it",
          "[graph][laplacian][solvers][pseudo_transient]") {
  const RandomNetwork net = random_network(500, 3, 8.0);
  LaplacianSolver direct;
  const auto ref = direct.solve(net.problem());
  std::vector<Index> freev;
  const auto A = reduced_matrix(net, ref, freev);
  std::vector<double> C;
  for (Index v : freev) C.push_back(net.cap[v]);
  // B = C^-1/2 A C^-1/2 (same spectrum as C^-1 A), dense.
  Eigen::MatrixXd B = Eigen::MatrixXd(A);
  for (Eigen::Index i = 0; i < B.rows(); ++i)
    for (Eigen::Index j = 0; j < B.cols(); ++j) B(i, j) /= std::sqrt(C[i] * C[j]);
  const Eigen::VectorXd ev = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(B, Eigen::EigenvaluesOnly).eigenvalues();
  const double lmax = ev[ev.size() - 1];
  const auto est = max_generalized_eigenvalue(A, C, 1e-8, 300);
  CHECK(est.converged);
  // Stated accuracy: within the residual bound of an eigenvalue, and a Ritz value: <= lambda_max.
  CHECK(std::abs(est.value - lmax) <= est.residual_bound + 1e-12 * lmax);
  CHECK(est.value <= lmax * (1.0 + 1e-12));
  CHECK(relative_error(est.value, lmax) < 1e-8);
  // Gershgorin: every eigenvalue <= max_v 2 A_vv / C_v, so min_v C_v / A_vv <= 2 / lambda_max.
  const double dt_g = gershgorin_step(A, C);
  CHECK(dt_g <= 2.0 / lmax);
  double dmax = 0.0;
  for (Eigen::Index i = 0; i < A.rows(); ++i) dmax = std::max(dmax, A.coeff(i, i) / C[i]);
  CHECK(dt_g == 1.0 / dmax);
  // The solver reports the same numbers (default tolerance 1e-6).
  LaplacianOptions o = with(LaplacianMethod::PseudoTransient);
  o.pseudo.indicator = ChangeIndicator::Range;
  LaplacianSolver pt(o);
  const auto res = pt.solve(net.problem());
  CHECK(relative_error(res.pseudo.lambda_max, lmax) < 1e-6);
  CHECK(res.pseudo.dt_gershgorin == dt_g);
  // Deterministic: the same estimate bit for bit on a second run.
  CHECK(max_generalized_eigenvalue(A, C, 1e-8, 300).value == est.value);
}

TEST_CASE("Laplacian solvers: two nodes, the pseudo-transient limit is Eq. 43 exactly", "[graph][laplacian][solvers][pseudo_transient]") {
  // Free node i (capacitance C) joined by K to node j at V: C dV_i/dt + K V_i = K V_j (Eq. 39),
  // here with a source q at i (solution V + q / K, so the start, the electrode value V, is not
  // it). Forward Euler is stable iff dt < 2 C / K (Eq. 43). The Gershgorin step is C / K; at it
  // the relaxation factor dt K / C is 1 and one step lands exactly on the solution (Eq. 40).
  const double K = 2.0, C = 0.5, V = 2.0, q = 3.0;  // exact binary fractions
  const std::vector<Index> a{0}, b{1};
  const std::vector<double> g{K}, cap{C, 7.0}, src{q, 0.0};
  LaplacianProblem p;
  p.nodes = 2;
  p.a = a;
  p.b = b;
  p.g = g;
  p.capacitance = cap;
  p.source = src;
  p.dirichlet = {{{1}, V}};
  LaplacianOptions o = with(LaplacianMethod::PseudoTransient);
  o.pseudo.dt_fraction = 0.95;
  const auto r95 = LaplacianSolver(o).solve(p);
  CHECK(r95.pseudo.lambda_max == Approx(K / C).epsilon(1e-15));
  CHECK(r95.pseudo.dt_limit == Approx(2.0 * C / K).epsilon(1e-15));
  CHECK(r95.pseudo.dt_gershgorin == C / K);
  CHECK(r95.pseudo.eigen_iterations == 1);
  CHECK(std::abs(r95.value[0] - (V + q / K)) < 1e-3);
  o.pseudo.dt = C / K;
  LaplacianSolver exact(o);
  p.capacitance = cap;
  const auto r1 = exact.solve(p);
  CHECK(r1.value[0] == V + q / K);
  CHECK(r1.iterations == 2);  // lands on the solution, then a zero change
  // Just above 2 C / K the amplification factor |1 - dt K / C| exceeds 1: refused, or detected.
  o.pseudo.dt = 1.01 * 2.0 * C / K;
  CHECK_THROWS_AS(LaplacianSolver(o).solve(p), PhysicsError);
  o.pseudo.allow_unstable = true;
  CHECK_THROWS_WITH(LaplacianSolver(o).solve(p), Catch::Contains("diverges"));
  // Just below it converges (slowly: factor 0.98 per step).
  o.pseudo.dt = 0.99 * 2.0 * C / K;
  o.pseudo.allow_unstable = false;
  o.pseudo.beta = 1e-12;
  CHECK(std::abs(LaplacianSolver(o).solve(p).value[0] - (V + q / K)) < 1e-9);
}

TEST_CASE("Laplacian solvers: pseudo-transient input checks, floating clusters, warm start",
          "[graph][laplacian][solvers][pseudo_transient]") {
  // Chain 0 - 2 - 3 - 1 between electrodes, floating triangle {4, 5, 6}, isolated 7.
  const std::vector<Index> a{0, 2, 3, 4, 5, 6}, b{2, 3, 1, 5, 6, 4};
  const std::vector<double> g{1.0, 2.0, 1.0, 5.0, 5.0, 5.0};
  std::vector<double> cap(8, 1.0);
  LaplacianProblem p;
  p.nodes = 8;
  p.a = a;
  p.b = b;
  p.g = g;
  p.dirichlet = {{{0}, 1.0}, {{1}, 0.0}};
  LaplacianOptions o = with(LaplacianMethod::PseudoTransient);
  o.pseudo.indicator = ChangeIndicator::Range;
  o.pseudo.beta = 1e-13;
  CHECK_THROWS_AS(LaplacianSolver(o).solve(p), SetupError);  // no capacitance
  p.capacitance = cap;
  cap[3] = 0.0;
  CHECK_THROWS_AS(LaplacianSolver(o).solve(p), PhysicsError);  // C <= 0
  cap[3] = 1.0;
  LaplacianOptions bad = o;
  bad.pseudo.dt = -1.0;
  CHECK_THROWS_AS(LaplacianSolver(bad).solve(p), SetupError);
  LaplacianSolver solver(o);
  const auto res = solver.solve(p);
  CHECK(res.floating_nodes == 4);
  CHECK(res.floating_components == 2);
  for (Index v : {4, 5, 6, 7}) CHECK(std::isnan(res.value[v]));
  // Series: R = 1 + 1/2 + 1 = 2.5, I = 0.4.
  CHECK(relative_error(res.dirichlet_flux[0], 0.4) < 1e-11);
  CHECK(res.factorized);
  // Warm start: the same problem again stops after one iteration, without a new eigen-solve; a
  // new capacitance (same matrix) recomputes the limit.
  const auto again = solver.solve(p);
  CHECK(again.iterations == 1);
  CHECK(!again.factorized);
  std::vector<double> cap2 = cap;
  cap2[2] = 4.0;
  p.capacitance = cap2;
  const auto r3 = solver.solve(p);
  CHECK(r3.factorized);
  CHECK(r3.pseudo.lambda_max != res.pseudo.lambda_max);
  // A non-converging run (cap too low) is an error, not a silent answer.
  o.max_iterations = 3;
  solver.set_options(o);
  solver.reset_warm_start();
  CHECK_THROWS_WITH(solver.solve(p), Catch::Contains("still above beta"));
}

TEST_CASE("Effective resistance: no spanning path gives G = 0 and R = inf, never NaN", "[graph][laplacian][solvers][resistance]") {
  // High electrode {0}, low electrode {1}. Component X = {0, 2, 3} touches high only, Y = {1, 4}
  // low only, Z = {5, 6, 7} floats, 8 is isolated; a g = 0 edge joins 3 and 4.
  const std::vector<Index> a{0, 2, 1, 5, 6, 3}, b{2, 3, 4, 6, 7, 4};
  const std::vector<double> g{1.0, 1.0, 2.0, 1.0, 1.0, 0.0};
  LaplacianProblem net;
  net.nodes = 9;
  net.a = a;
  net.b = b;
  net.g = g;
  const std::vector<Index> high{0}, low{1};
  for (LaplacianMethod m : {LaplacianMethod::Direct, LaplacianMethod::CgDiagonal, LaplacianMethod::Amg}) {
    LaplacianSolver solver(with(m));
    const auto r = effective_resistance(solver, net, high, low, 2.0);
    CHECK(!r.spanning);
    CHECK(r.conductance == 0.0);
    CHECK(std::isinf(r.resistance));
    CHECK(r.resistance > 0.0);
    CHECK(r.current == 0.0);
    CHECK(r.spanning_nodes == 0);
    CHECK(r.single_electrode_nodes == 5);
    CHECK(r.floating_nodes == 4);
    CHECK(r.floating_components == 2);
    for (Index v : {0, 2, 3}) CHECK(r.value[v] == 2.0);
    for (Index v : {1, 4}) CHECK(r.value[v] == 0.0);
    for (Index v : {5, 6, 7, 8}) CHECK(std::isnan(r.value[v]));
    for (double f : r.flux) CHECK(f == 0.0);
  }
  // An empty electrode: no path either.
  LaplacianSolver solver;
  const auto r = effective_resistance(solver, net, high, {}, 1.0);
  CHECK(r.conductance == 0.0);
  CHECK(std::isinf(r.resistance));
  // Malformed: a node in both electrodes, a zero voltage, a network with its own Dirichlet groups.
  CHECK_THROWS_AS(effective_resistance(solver, net, high, high), SetupError);
  CHECK_THROWS_AS(effective_resistance(solver, net, high, low, 0.0), SetupError);
  LaplacianProblem withd = net;
  withd.dirichlet = {{{0}, 1.0}};
  CHECK_THROWS_AS(effective_resistance(solver, withd, high, low), SetupError);
}

TEST_CASE("Effective resistance: only components touching both electrodes are solved", "[graph][laplacian][solvers][resistance]") {
  // Electrodes H = {0, 10}, L = {1, 11, 15}. Two spanning components, in parallel through the
  // electrodes: the chain 0 -1- 2 -2- 1 (R = 1.5) with a dead-end branch 0 -3- 3 -3- 4 (same
  // component, no current, at the high potential), and 10 -4- 11 (R = 0.25): G = 1/1.5 + 4.
  // Excluded: 15 -1- 16 touches L only (single-electrode, at 0 V); 12 -1- 13 touches nothing and
  // 5..9, 14 are isolated (floating).
  const std::vector<Index> a{0, 2, 0, 3, 10, 12, 15}, b{2, 1, 3, 4, 11, 13, 16};
  const std::vector<double> g{1.0, 2.0, 3.0, 3.0, 4.0, 1.0, 1.0};
  LaplacianProblem net;
  net.nodes = 17;
  net.a = a;
  net.b = b;
  net.g = g;
  const std::vector<Index> high{0, 10}, low{1, 11, 15};
  const double G = 1.0 / 1.5 + 4.0;
  for (LaplacianMethod m : {LaplacianMethod::Direct, LaplacianMethod::CgIncompleteCholesky, LaplacianMethod::Amg}) {
    INFO("method " << laplacian_method_name(m));
    LaplacianSolver solver(with(m, 1e-13));
    const auto r = effective_resistance(solver, net, high, low, 3.0);
    CHECK(r.spanning);
    CHECK(r.spanning_components == 2);
    CHECK(r.spanning_nodes == 7);          // 0, 1, 2, 3, 4, 10, 11
    CHECK(r.single_electrode_nodes == 2);  // 15, 16
    CHECK(r.floating_nodes == 8);          // 5..9, 12, 13, 14
    CHECK(r.floating_components == 7);
    CHECK(relative_error(r.conductance, G) < 1e-12);
    CHECK(relative_error(r.resistance, 1.0 / G) < 1e-12);
    CHECK(relative_error(r.current, 3.0 * G) < 1e-12);
    CHECK(relative_error(-r.current_low, 3.0 * G) < 1e-12);
    CHECK(relative_error(r.value[2], 3.0 * (1.0 - 1.0 / 1.5)) < 1e-12);
    CHECK(relative_error(r.value[4], 3.0) < 1e-12);  // dead end at the high potential
    CHECK(r.value[16] == 0.0);
    CHECK(std::isnan(r.value[12]));
    CHECK(relative_error(r.flux[4], 12.0) < 1e-12);
    CHECK(std::abs(r.flux[2]) < 1e-12);
    CHECK(r.flux[6] == 0.0);
  }
}

TEST_CASE("Effective resistance: random network, all methods, the full solve and the power identity",
          "[graph][laplacian][solvers][resistance]") {
  // The condensed solve on the spanning part equals the solve of the whole network (which keeps
  // the single-electrode clusters) and satisfies V I = sum_e g_e dV_e^2 (Tellegen); every method
  // gives the same G within its tolerance; Rayleigh monotonicity: raising one g never lowers G.
  const RandomNetwork net = random_network(1500, 5);
  LaplacianSolver whole;
  const auto full = whole.solve(net.problem(1.0));
  LaplacianSolver direct;
  const auto r = effective_resistance(direct, net.network(), net.high, net.low, 1.0);
  REQUIRE(r.spanning);
  CHECK(r.floating_nodes == full.floating_nodes);
  CHECK(r.floating_nodes + r.single_electrode_nodes + r.spanning_nodes == net.nodes);
  CHECK(relative_error(r.current, full.dirichlet_flux[0]) < 1e-12);
  CHECK(relative_error(r.resistance, 1.0 / r.conductance) < 1e-15);
  double P = 0.0;
  for (std::size_t e = 0; e < net.a.size(); ++e) P += r.flux[e] * r.flux[e] / net.g[e];
  CHECK(relative_error(P, r.current) < 1e-10);
  for (LaplacianMethod m :
       {LaplacianMethod::CgIncompleteCholesky, LaplacianMethod::CgDiagonal, LaplacianMethod::Amg, LaplacianMethod::PseudoTransient}) {
    INFO("method " << laplacian_method_name(m));
    LaplacianOptions o = with(m, 1e-12);
    o.pseudo.indicator = ChangeIndicator::Range;
    o.pseudo.beta = 1e-12;
    o.pseudo.dt_fraction = 0.95;
    LaplacianSolver solver(o);
    const auto rm = effective_resistance(solver, net.network(), net.high, net.low, 1.0);
    CHECK(relative_error(rm.conductance, r.conductance) < 1e-6);
  }
  RandomNetwork up = net;
  std::size_t e_mid = 0;
  for (std::size_t e = 0; e < up.a.size(); ++e)
    if (std::isfinite(r.value[up.a[e]]) && r.value[up.a[e]] > 0.2 && r.value[up.a[e]] < 0.8 && std::abs(r.flux[e]) > 0.0) {
      e_mid = e;
      break;
    }
  up.g[e_mid] *= 10.0;
  const auto ru = effective_resistance(direct, up.network(), up.high, up.low, 1.0);
  CHECK(ru.conductance > r.conductance);
}

TEST_CASE("Laplacian solvers: pseudo-transient and its limit are bit-identical for 1 and 2 threads",
          "[graph][laplacian][solvers][pseudo_transient]") {
  // Block-wise partial sums in a fixed order: the thread count changes neither lambda_max nor any
  // iterate. 18^3 lattice (several blocks of rows), random conductances and capacitances.
  // (A loose beta: a few hundred iterations are enough to compare.)
  const int L = 18;
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  RandomNetwork net;
  net.nodes = static_cast<std::size_t>(L) * L * L;
  auto id = [L](int i, int j, int k) { return static_cast<Index>(i + L * (j + L * k)); };
  for (int k = 0; k < L; ++k)
    for (int j = 0; j < L; ++j)
      for (int i = 0; i < L; ++i) {
        for (auto [di, dj, dk] : {std::array<int, 3>{1, 0, 0}, {0, 1, 0}, {0, 0, 1}})
          if (i + di < L && j + dj < L && k + dk < L) {
            net.a.push_back(id(i, j, k));
            net.b.push_back(id(i + di, j + dj, k + dk));
            net.g.push_back(0.5 + u(rng));
          }
        net.cap.push_back(1.0 + u(rng));
        if (i == 0) net.high.push_back(id(i, j, k));
        if (i == L - 1) net.low.push_back(id(i, j, k));
      }
  LaplacianOptions o = with(LaplacianMethod::PseudoTransient);
  o.pseudo.indicator = ChangeIndicator::Range;
  o.pseudo.beta = 1e-3;
  o.pseudo.dt_fraction = 0.95;
  const int before = omp_get_max_threads();
  omp_set_num_threads(1);
  const auto r1 = LaplacianSolver(o).solve(net.problem());
  omp_set_num_threads(2);
  const auto r2 = LaplacianSolver(o).solve(net.problem());
  omp_set_num_threads(before);
  REQUIRE(r1.free_nodes > 4096);
  CHECK(r1.iterations > 10);
  INFO("iterations " << r1.iterations);
  CHECK(r1.iterations == r2.iterations);
  CHECK(r1.pseudo.lambda_max == r2.pseudo.lambda_max);
  CHECK(r1.pseudo.change_indicator == r2.pseudo.change_indicator);
  CHECK(r1.value == r2.value);
}

}  // namespace test_laplacian_solvers
