// Extreme network cases (issue 9; docs/extreme_cases.md): the electrical resistor network and the
// heat network, both on the shared Laplacian machinery (engine/graph) and the heat_conduction
// module.
//
//  E1 conductance contrast 1e12 on a 3-D lattice network: every solver against an extended-
//     precision dense reference (and a series-parallel closed form).
//  E2 floating clusters: reported (counted, NaN potential, zero current), the spanning part exact.
//  E3 no spanning path: G = 0 exactly and R = +inf for every solver; no NaN where a value exists.
//  T1 the explicit heat scheme at and above its stable step on a cluster with size ratio 50:
//     at the step its own recurrence to 1e-9, the discrete maximum principle, energy to 1e-12;
//     above it refused, and with the override the blow-up caught; the true limit by bisection.
//  T2 the implicit heat scheme at 1e3 x the explicit stable step on the same cluster: its own
//     recurrence, the maximum principle, energy, and the error against the exact solution within
//     the backward-Euler bound.
#include <catch2/catch.hpp>

#include <Eigen/Dense>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include "engine/core/error.hpp"
#include "engine/graph/effective_resistance.hpp"
#include "engine/graph/laplacian.hpp"
#include "engine/simulation.hpp"
#include "physics/contact/hertz_mindlin.hpp"
#include "physics/thermal/heat_conduction.hpp"
#include "tests/extreme/extreme_figures.hpp"
#include "tests/support/scene.hpp"
#include "tests/support/thermal_network.hpp"

namespace test_extreme_networks {

using namespace sparkdem;

namespace {

const std::vector<LaplacianMethod> kMethods = {LaplacianMethod::Direct, LaplacianMethod::CgIncompleteCholesky, LaplacianMethod::CgDiagonal,
                                               LaplacianMethod::Amg};

struct Net {
  std::size_t nodes = 0;
  std::vector<Index> a, b;
  std::vector<double> g;
  std::vector<Index> high, low;
  void edge(Index x, Index y, double c) {
    a.push_back(x);
    b.push_back(y);
    g.push_back(c);
  }
  LaplacianProblem problem() const {
    LaplacianProblem p;
    p.nodes = nodes;
    p.a = a;
    p.b = b;
    p.g = g;
    return p;
  }
};

/// Effective conductance between `high` (1 V) and `low` (0 V) by dense Gaussian elimination with
/// partial pivoting in long double on the reduced Laplacian (the independent reference).
long double reference_conductance(const Net& n) {
  std::vector<int> role(n.nodes, 0);  // 0 free, 1 high, 2 low
  for (Index v : n.high) role[static_cast<std::size_t>(v)] = 1;
  for (Index v : n.low) role[static_cast<std::size_t>(v)] = 2;
  std::vector<int> idx(n.nodes, -1);
  int m = 0;
  for (std::size_t v = 0; v < n.nodes; ++v)
    if (role[v] == 0) idx[v] = m++;
  std::vector<std::vector<long double>> A(static_cast<std::size_t>(m), std::vector<long double>(static_cast<std::size_t>(m) + 1, 0.0L));
  for (std::size_t e = 0; e < n.g.size(); ++e) {
    const auto x = static_cast<std::size_t>(n.a[e]), y = static_cast<std::size_t>(n.b[e]);
    const long double c = n.g[e];
    for (auto [p, q] : {std::pair{x, y}, std::pair{y, x}}) {
      if (role[p] != 0) continue;
      auto& row = A[static_cast<std::size_t>(idx[p])];
      row[static_cast<std::size_t>(idx[p])] += c;
      if (role[q] == 0)
        row[static_cast<std::size_t>(idx[q])] -= c;
      else if (role[q] == 1)
        row[static_cast<std::size_t>(m)] += c;  // u_q = 1
    }
  }
  for (int k = 0; k < m; ++k) {
    int piv = k;
    for (int i = k + 1; i < m; ++i)
      if (std::fabs(A[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)]) >
          std::fabs(A[static_cast<std::size_t>(piv)][static_cast<std::size_t>(k)]))
        piv = i;
    std::swap(A[static_cast<std::size_t>(k)], A[static_cast<std::size_t>(piv)]);
    for (int i = k + 1; i < m; ++i) {
      const long double f = A[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)] /
                            A[static_cast<std::size_t>(k)][static_cast<std::size_t>(k)];
      if (f == 0.0L) continue;
      for (int j = k; j <= m; ++j)
        A[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)] -= f * A[static_cast<std::size_t>(k)][static_cast<std::size_t>(j)];
    }
  }
  std::vector<long double> u(static_cast<std::size_t>(m));
  for (int i = m - 1; i >= 0; --i) {
    long double s = A[static_cast<std::size_t>(i)][static_cast<std::size_t>(m)];
    for (int j = i + 1; j < m; ++j) s -= A[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)] * u[static_cast<std::size_t>(j)];
    u[static_cast<std::size_t>(i)] = s / A[static_cast<std::size_t>(i)][static_cast<std::size_t>(i)];
  }
  // Current leaving the high electrode.
  long double I = 0.0L;
  for (std::size_t e = 0; e < n.g.size(); ++e) {
    const auto x = static_cast<std::size_t>(n.a[e]), y = static_cast<std::size_t>(n.b[e]);
    auto val = [&](std::size_t v) -> long double {
      return role[v] == 1 ? 1.0L : role[v] == 2 ? 0.0L : u[static_cast<std::size_t>(idx[v])];
    };
    if (role[x] == 1 && role[y] != 1) I += n.g[e] * (1.0L - val(y));
    if (role[y] == 1 && role[x] != 1) I += n.g[e] * (1.0L - val(x));
  }
  return I;
}

/// k x k x k lattice, electrodes on the x faces, each bond 1e6 or 1e-6 S at random (contrast 1e12).
Net contrast_lattice(int k, std::uint64_t seed) {
  Net n;
  n.nodes = static_cast<std::size_t>(k * k * k);
  auto id = [k](int x, int y, int z) { return static_cast<Index>(x + k * (y + k * z)); };
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int z = 0; z < k; ++z)
    for (int y = 0; y < k; ++y)
      for (int x = 0; x < k; ++x) {
        if (x + 1 < k) n.edge(id(x, y, z), id(x + 1, y, z), u(rng) < 0.5 ? 1e6 : 1e-6);
        if (y + 1 < k) n.edge(id(x, y, z), id(x, y + 1, z), u(rng) < 0.5 ? 1e6 : 1e-6);
        if (z + 1 < k) n.edge(id(x, y, z), id(x, y, z + 1), u(rng) < 0.5 ? 1e6 : 1e-6);
        if (x == 0) n.high.push_back(id(x, y, z));
        if (x == k - 1) n.low.push_back(id(x, y, z));
      }
  return n;
}

}  // namespace

TEST_CASE("extreme E1: conductance contrast 1e12 - every solver against an extended-precision reference", "[extreme][electrical]") {
  // Expectation: the direct solver within 1e-9 of the long-double reference; the iterative ones
  // (PCG with IC / Jacobi, AMG-PCG) stop on a relative residual of 1e-10 of the reduced system,
  // which bounds the error of R by about cond x 1e-10: they are checked within 1e-6 and their
  // actual error reported. A series-parallel case (a chain alternating 1e6 / 1e-6 S beside a
  // chain of 1 S) against its closed form within 1e-8 (direct; LDL^T at condition ~1e12).
  const Net n = contrast_lattice(7, 21);
  const double ref = static_cast<double>(reference_conductance(n));
  REQUIRE(ref > 0.0);
  for (LaplacianMethod m : kMethods) {
    LaplacianOptions o;
    o.method = m;
    LaplacianSolver solver(o);
    const EffectiveResistance r = effective_resistance(solver, n.problem(), n.high, n.low, 1.0);
    const double err = std::abs(r.conductance - ref) / ref;
    INFO(laplacian_method_name(m) << ": G = " << r.conductance << " S, reference " << ref << " S, error " << err << ", iterations "
                                  << r.solve.iterations);
    CHECK(std::isfinite(r.resistance));
    CHECK(std::abs(r.current + r.current_low) <= 1e-6 * std::abs(r.current));
    CHECK(err < (m == LaplacianMethod::Direct ? 1e-9 : 1e-6));
    EXTREME_FIGURE("E1 contrast 1e12", std::string("relative error of G, ") + laplacian_method_name(m), err, "");
  }
  // Series-parallel closed form.
  Net sp;
  sp.nodes = 2 + 9 + 9;
  sp.high = {0};
  sp.low = {1};
  double r_a = 0.0;
  Index prev = 0;
  for (int k = 0; k < 10; ++k) {
    const Index next = k == 9 ? 1 : static_cast<Index>(2 + k);
    const double g = k % 2 ? 1e-6 : 1e6;
    sp.edge(prev, next, g);
    r_a += 1.0 / g;
    prev = next;
  }
  prev = 0;
  for (int k = 0; k < 10; ++k) {
    const Index next = k == 9 ? 1 : static_cast<Index>(11 + k);
    sp.edge(prev, next, 1.0);
    prev = next;
  }
  const double g_exact = 1.0 / r_a + 1.0 / 10.0;
  LaplacianSolver direct;
  const EffectiveResistance r = effective_resistance(direct, sp.problem(), sp.high, sp.low, 1.0);
  CHECK(std::abs(r.conductance - g_exact) <= 1e-8 * g_exact);  // cond ~ 1e12: eps x 1e12 / a few
  EXTREME_FIGURE("E1 contrast 1e12", "series-parallel closed form error (direct)", std::abs(r.conductance - g_exact) / g_exact, "");
}

TEST_CASE("extreme E2: floating clusters are reported and carry no current, the spanning part is exact", "[extreme][electrical]") {
  // Network: a spanning chain high(0) - 2 - 3 - low(1) of 1 S each; a floating triangle 4-5-6
  // (no electrode); a pair 7-8 hanging on node 10, a second node of the high electrode, and
  // touching nothing else (a cluster on one electrode only); an isolated node 9.
  // Expectation, every solver: G = 1/3 S (1e-9; 1e-12 direct), spanning; 4 floating nodes in 2
  // components (triangle + isolated node) with NaN potential and zero flux; the dangling pair at
  // the high electrode's potential (1 V), 3 single-electrode nodes (with 10); current conserved. The plain
  // Dirichlet solve: the floating nodes NaN and counted, no exception.
  Net n;
  n.nodes = 11;
  n.high = {0, 10};
  n.low = {1};
  n.edge(0, 2, 1.0);
  n.edge(2, 3, 1.0);
  n.edge(3, 1, 1.0);
  n.edge(4, 5, 1.0);
  n.edge(5, 6, 2.0);
  n.edge(6, 4, 3.0);
  n.edge(10, 7, 1.0);
  n.edge(7, 8, 1.0);
  for (LaplacianMethod m : kMethods) {
    LaplacianOptions o;
    o.method = m;
    LaplacianSolver solver(o);
    const EffectiveResistance r = effective_resistance(solver, n.problem(), n.high, n.low, 1.0);
    INFO(laplacian_method_name(m));
    CHECK(r.spanning);
    CHECK(std::abs(r.conductance - 1.0 / 3.0) <= (m == LaplacianMethod::Direct ? 1e-12 : 1e-9));
    CHECK(r.floating_nodes == 4);
    CHECK(r.floating_components == 2);
    CHECK(r.single_electrode_nodes == 3);  // 7, 8 and the electrode node 10 of their component
    for (int v : {4, 5, 6, 9}) CHECK(std::isnan(r.value[static_cast<std::size_t>(v)]));
    for (int v : {7, 8}) CHECK(r.value[static_cast<std::size_t>(v)] == 1.0);  // the electrode's value, exactly
    for (std::size_t e = 3; e < 8; ++e) CHECK(r.flux[e] == 0.0);
    CHECK(std::abs(r.current + r.current_low) <= 1e-9);
  }
  LaplacianProblem p = n.problem();
  p.dirichlet = {DirichletGroup{{0, 10}, 1.0}, DirichletGroup{{1}, 0.0}};
  LaplacianSolver solver;
  const LaplacianResult res = solver.solve(p);
  CHECK(res.floating_nodes == 4);
  CHECK(res.floating_components == 2);
  CHECK(std::abs(res.value[2] - 2.0 / 3.0) < 1e-12);
  CHECK(res.value[7] == Approx(1.0).epsilon(1e-12));
  CHECK(std::abs(res.dirichlet_flux[0] - 1.0 / 3.0) < 1e-12);
  EXTREME_FIGURE("E2 floating clusters", "floating nodes reported", static_cast<double>(res.floating_nodes), "of 4");
  EXTREME_FIGURE("E2 floating clusters", "error of G (direct)", std::abs(res.dirichlet_flux[0] - 1.0 / 3.0) * 3.0, "");
}

TEST_CASE("extreme E3: no spanning path - G = 0 exactly and R = +inf with every solver, no NaN where a value exists",
          "[extreme][electrical]") {
  // Two chains, one on each electrode, not joined (a cut through a packing); plus the same with
  // every conductance of the joining edge 0 (an open contact).
  for (bool open_edge : {false, true}) {
    Net n;
    n.nodes = 6;
    n.high = {0};
    n.low = {1};
    n.edge(0, 2, 1.0);
    n.edge(2, 3, 1.0);
    n.edge(1, 4, 1.0);
    n.edge(4, 5, 1.0);
    if (open_edge) n.edge(3, 5, 0.0);
    for (LaplacianMethod m : kMethods) {
      LaplacianOptions o;
      o.method = m;
      LaplacianSolver solver(o);
      const EffectiveResistance r = effective_resistance(solver, n.problem(), n.high, n.low, 1.0);
      INFO(laplacian_method_name(m) << (open_edge ? " with an open edge" : ""));
      CHECK_FALSE(r.spanning);
      CHECK(r.conductance == 0.0);
      CHECK(std::isinf(r.resistance));
      CHECK(r.current == 0.0);
      for (double v : r.value) CHECK(std::isfinite(v));  // each part sits at its electrode's value
      CHECK(r.value[3] == 1.0);
      CHECK(r.value[5] == 0.0);
      for (double f : r.flux) CHECK(f == 0.0);
    }
  }
  EXTREME_FIGURE("E3 no spanning path", "G with every solver", 0.0, "S");
}

// ---------------------------------------------------------------------------------------------
// Heat: a cluster with size ratio 50.
// ---------------------------------------------------------------------------------------------
namespace {

constexpr double kLam = 15.0, kRhoT = 7900.0, kC = 500.0;

/// A large sphere (R = 0.5 mm) carrying 6 medium ones (r = 150 um, on the axes) and 10 small
/// ones (10 um), each medium one carrying 4 small ones; every satellite overlaps its host by
/// 1 % of its own radius (no other overlaps); a second large sphere touches the first by 1 nm.
/// Temperatures: large 300 K and 600 K, medium 400 K, small 500 K on the large sphere and
/// 350 K on the medium ones.
void cluster(State& s) {
  const double R = 5e-4, rm = 1.5e-4, rs = 1e-5;
  std::mt19937_64 rng(17);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<double> T;
  test::add_sphere(s, Vec3::Zero(), R, kRhoT);
  T.push_back(300.0);
  auto free_at = [&](const Vec3& c, double r, Index host) {
    for (std::size_t k = 0; k < s.particles.size(); ++k) {
      if (static_cast<Index>(k) == host) continue;
      if ((s.particles.position[k] - c).norm() < s.particles.radius[k] + r + 1e-3 * rs) return false;
    }
    return true;
  };
  for (int d = 0; d < 6; ++d) {
    Vec3 e = Vec3::Zero();
    e[d / 2] = d % 2 ? -1.0 : 1.0;
    test::add_sphere(s, (R + rm - 0.01 * rm) * e, rm, kRhoT);
    T.push_back(400.0);
  }
  // A second large sphere at 600 K barely touching the first along the diagonal (overlap 1 nm:
  // G = 2 lambda sqrt(R/2 x 1 nm) = 1.5e-5 W/K on C = 2.1e-3 J/K): the slow mode, 1.2e5 times
  // slower than the fastest one (a small satellite on its host).
  test::add_sphere(s, (2 * R - 1e-9) * Vec3(1, 1, 1).normalized(), R, kRhoT);
  T.push_back(600.0);
  auto satellites = [&](Index host, int count, double temp) {
    for (int k = 0; k < count;) {
      const Vec3 dir = Vec3(g(rng), g(rng), g(rng)).normalized();
      const Vec3 c = s.particles.position[static_cast<std::size_t>(host)] +
                     (s.particles.radius[static_cast<std::size_t>(host)] + rs - 0.01 * rs) * dir;
      if (!free_at(c, rs, host)) continue;
      test::add_sphere(s, c, rs, kRhoT);
      T.push_back(temp);
      ++k;
    }
  };
  satellites(0, 10, 500.0);
  for (Index h = 1; h <= 6; ++h) satellites(h, 4, 350.0);
  s.particles.fields.declare({"temperature", 1, "K", 0.0, true}, s.particles.size());
  s.particles.fields.data("temperature") = T;
}

physics::HeatConduction::Params heat_params(const std::string& scheme) {
  physics::HeatConduction::Params p;
  p.model = "batchelor_obrien";
  p.contact_radius = "hertz";
  p.conductivity = kLam;
  p.density = kRhoT;
  p.specific_heat = kC;
  p.scheme = scheme;
  return p;
}

/// L and C from the geometry, independently of the module: G = 2 lambda sqrt(R* delta)
/// (Batchelor-O'Brien, one material), C = rho c 4/3 pi r^3.
void network(const State& s, Eigen::MatrixXd& L, Eigen::VectorXd& C, Eigen::VectorXd& T0) {
  const auto& p = s.particles;
  const auto n = static_cast<Eigen::Index>(p.size());
  L = Eigen::MatrixXd::Zero(n, n);
  C.resize(n);
  T0.resize(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto ui = static_cast<std::size_t>(i);
    C[i] = kRhoT * kC * 4.0 / 3.0 * std::numbers::pi * std::pow(p.radius[ui], 3);
    T0[i] = p.fields.data("temperature")[ui];
    for (Eigen::Index j = i + 1; j < n; ++j) {
      const auto uj = static_cast<std::size_t>(j);
      const double d = p.radius[ui] + p.radius[uj] - (p.position[ui] - p.position[uj]).norm();
      if (d <= 0.0) continue;
      const double g = 2.0 * kLam * std::sqrt(p.radius[ui] * p.radius[uj] / (p.radius[ui] + p.radius[uj]) * d);
      L(i, i) += g;
      L(j, j) += g;
      L(i, j) -= g;
      L(j, i) -= g;
    }
  }
}

struct HeatRun {
  Eigen::VectorXd T;
  double stable = 0.0;
  double tmin = 1e300, tmax = -1e300;  // over every step
  bool failed = false;
  Step fail_step = -1;
  std::vector<Id> fail_ids;
};

HeatRun run_heat(const std::string& scheme, double dt, Step steps, bool fixed_clock, bool allow_unstable) {
  State s;
  cluster(s);
  physics::HeatConduction heat(heat_params(scheme));
  if (fixed_clock) {
    Clock one;
    one.kind = Clock::Kind::EveryStep;
    heat.set_clock(one);
  }
  ContactModelT<physics::HertzMindlin> law{physics::HertzMindlin::Params{}};
  Simulation sim(s, law);
  sim.add_module(&heat);
  test::NullObserver none;
  sim.run_stage(test::frozen_stage(1e-9, 0), none);
  HeatRun r;
  r.stable = heat.stable_dt(s);
  test::StepObserver obs([&](const State& st, Step) {
    for (double t : st.particles.fields.data("temperature")) {
      r.tmin = std::min(r.tmin, t);
      r.tmax = std::max(r.tmax, t);
    }
  });
  StageConfig c = test::frozen_stage(dt, steps);
  c.allow_unstable_dt = allow_unstable;
  try {
    sim.run_stage(c, obs);
  } catch (const PhysicsError& e) {
    r.failed = true;
    r.fail_step = e.step();
    r.fail_ids = e.ids();
  }
  const auto& T = s.particles.fields.data("temperature");
  r.T = Eigen::Map<const Eigen::VectorXd>(T.data(), static_cast<Eigen::Index>(T.size()));
  return r;
}

}  // namespace

TEST_CASE("extreme T1: explicit heat at and above its stable step on a cluster with size ratio 50", "[extreme][thermal]") {
  // Expectation: the module's stable step equals 0.9 min_i C_i / D_ii of the independent
  // Laplacian (1e-12); at exactly that step (fixed clock) 2000 steps equal the forward-Euler
  // recurrence (1e-9 of the 300 K range), stay within the initial [300, 600] K (the discrete
  // maximum principle holds for dt <= min C/D) and conserve sum C T (1e-12). At 1.5 x the step:
  // refused before step 0 (SetupError naming the module). With the override at 2.5 x: a
  // PhysicsError on 'temperature' naming particle ids. The true limit 2 / lambda_max(C^-1 L),
  // measured by bisection on the module (bounded over 4000 steps), lies above the step and
  // within 5e-3 of 2 / lambda_max (growth over 4000 steps resolves the limit to ~1e-3).
  State s;
  cluster(s);
  Eigen::MatrixXd L;
  Eigen::VectorXd C, T0;
  network(s, L, C, T0);
  double gersh = 1e300;
  for (Eigen::Index i = 0; i < C.size(); ++i) gersh = std::min(gersh, C[i] / L(i, i));
  const test::ModalSolution modal(L, C);
  const double lambda_max = modal.rates().maxCoeff();
  const double stable = 0.9 * gersh;
  const double n = 2000;
  const double h = stable * (1.0 - 1e-12);  // at the step (within round-off of the module's own value)
  const HeatRun at = run_heat("explicit", h, 2000, true, false);
  CHECK(std::abs(at.stable - stable) <= 1e-12 * stable);
  const Eigen::VectorXd fe = modal.forward_euler(T0, h, n);
  CHECK((at.T - fe).cwiseAbs().maxCoeff() <= 1e-9 * 300.0);
  CHECK(at.tmin >= 300.0 - 1e-9);
  CHECK(at.tmax <= 600.0 + 1e-9);
  CHECK(std::abs(C.dot(at.T) - C.dot(T0)) <= 1e-12 * C.dot(T0));
  // Above: refused.
  {
    State t;
    cluster(t);
    physics::HeatConduction heat(heat_params("explicit"));
    Clock one;
    one.kind = Clock::Kind::EveryStep;
    heat.set_clock(one);
    ContactModelT<physics::HertzMindlin> law{physics::HertzMindlin::Params{}};
    Simulation sim(t, law);
    sim.add_module(&heat);
    test::NullObserver none;
    sim.run_stage(test::frozen_stage(1e-9, 0), none);
    try {
      sim.run_stage(test::frozen_stage(1.5 * stable, 10), none);
      FAIL("explicit heat above its stable step was accepted");
    } catch (const SetupError& e) {
      INFO(e.what());
      CHECK(std::string(e.what()).find("heat_conduction") != std::string::npos);
    }
  }
  const HeatRun over = run_heat("explicit", 2.5 * stable, 4000, true, true);
  CHECK(over.failed);
  CHECK(over.fail_step > 0);
  CHECK(!over.fail_ids.empty());
  // Bisection of the true limit on the module: bounded = no blow-up and every temperature within
  // (0, 1000) K over 4000 steps (between min C/D and 2/lambda_max forward Euler is stable but not
  // monotone: it overshoots by at most the initial 300 K spread; above, the top mode grows).
  auto bounded = [&](double dt) {
    const HeatRun r = run_heat("explicit", dt, 4000, true, true);
    return !r.failed && r.tmin > 0.0 && r.tmax < 1000.0;
  };
  double lo = stable, hi = 3.0 * stable;
  REQUIRE(bounded(lo));
  REQUIRE_FALSE(bounded(hi));
  for (int it = 0; it < 25; ++it) {
    const double mid = 0.5 * (lo + hi);
    (bounded(mid) ? lo : hi) = mid;
  }
  const double limit = 2.0 / lambda_max;
  INFO("stable " << stable << " s, bisected limit " << lo << " s, 2/lambda_max " << limit << " s");
  CHECK(lo > stable);
  CHECK(std::abs(lo - limit) <= 5e-3 * limit);
  EXTREME_FIGURE("T1 explicit heat, size ratio 50", "stable step", stable, "s");
  EXTREME_FIGURE("T1 explicit heat, size ratio 50", "bisected limit / stable step", lo / stable, "");
  EXTREME_FIGURE("T1 explicit heat, size ratio 50", "max deviation from FE recurrence at the step", (at.T - fe).cwiseAbs().maxCoeff(), "K");
  EXTREME_FIGURE("T1 explicit heat, size ratio 50", "energy drift at the step", std::abs(C.dot(at.T) - C.dot(T0)) / C.dot(T0), "");
  EXTREME_FIGURE("T1 explicit heat, size ratio 50", "blow-up caught at step (2.5 x)", static_cast<double>(over.fail_step), "");
}

TEST_CASE("extreme T2: implicit heat at 1e3 x the explicit stable step on a cluster with size ratio 50", "[extreme][thermal]") {
  // Expectation: 30 steps of H = 1000 x the explicit stable step (t = 15 s, 0.2 of the slow
  // mode's time) equal the backward-Euler recurrence (1e-9 of the range), stay within
  // [300, 600] K (BE is monotone), conserve sum C T (1e-12), and differ from the exact solution
  // by at most the backward-Euler mode bound E_30 x the modal amplitude per particle.
  State s;
  cluster(s);
  Eigen::MatrixXd L;
  Eigen::VectorXd C, T0;
  network(s, L, C, T0);
  double gersh = 1e300;
  for (Eigen::Index i = 0; i < C.size(); ++i) gersh = std::min(gersh, C[i] / L(i, i));
  const double H = 1000.0 * 0.9 * gersh;
  const Step M = 30;
  const HeatRun im = run_heat("implicit", H, M, true, false);
  const test::ModalSolution modal(L, C);
  const Eigen::VectorXd be = modal.backward_euler(T0, H, static_cast<double>(M));
  const Eigen::VectorXd ex = modal.exact(T0, H * static_cast<double>(M));
  CHECK((im.T - be).cwiseAbs().maxCoeff() <= 1e-9 * 300.0);
  CHECK(im.tmin >= 300.0 - 1e-9);
  CHECK(im.tmax <= 600.0 + 1e-9);
  CHECK(std::abs(C.dot(im.T) - C.dot(T0)) <= 1e-12 * C.dot(T0));
  const double E = test::be_mode_error_bound(static_cast<double>(M));
  const Eigen::VectorXd amp = modal.modal_amplitude(T0);
  double worst = 0.0, worst_ratio = 0.0;
  for (Eigen::Index i = 0; i < C.size(); ++i) {
    const double err = std::abs(im.T[i] - ex[i]);
    CHECK(err <= E * amp[i] + 1e-9);
    worst = std::max(worst, err);
    if (amp[i] > 0.0) worst_ratio = std::max(worst_ratio, err / (E * amp[i]));
  }
  EXTREME_FIGURE("T2 implicit heat at 1e3 x", "max error vs exact", worst, "K");
  EXTREME_FIGURE("T2 implicit heat at 1e3 x", "error / BE bound (worst particle)", worst_ratio, "");
  EXTREME_FIGURE("T2 implicit heat at 1e3 x", "stiffness lambda_max / lambda_min(>0)",
                 modal.rates().maxCoeff() / modal.rates().tail(modal.rates().size() - 1).minCoeff(), "");
}

}  // namespace test_extreme_networks
