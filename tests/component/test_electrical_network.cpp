// The electrical_network module (issue 4) on small sphere assemblies, through a zero-step stage
// (its event clock solves once on the initial state).
//
// Closed forms: a chain of N spheres with Holm contacts has R = (N - 1) / (2 a kappa),
// a = sqrt(R* delta); two chains in parallel halve it; a simple cubic lattice of n x n columns of
// m spheres with the transmission surface held at 4 r^2 has R = rho l / A, l = (m - 1) d,
// A = (2 r n)^2 (cohesive-joule-torsion.md §3.4). Invariants: electrode currents equal and
// opposite, sum I^2 R = V I, all solvers agree; no spanning path gives G = 0 and R = +inf.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <random>

#include "engine/simulation.hpp"
#include "engine/state/particle_set.hpp"
#include "physics/contact/hertz_mindlin.hpp"
#include "physics/electrical/electrical_network.hpp"
#include "tests/support/scene.hpp"
#include "tests/support/tolerance.hpp"

namespace test_electrical_network {

using namespace sparkdem;
using namespace sparkdem::physics;

namespace {

constexpr double kR = 1e-3;
constexpr double kKappa = 1e6;

void box_set(State& s, const std::string& name, const Vec3& lo, const Vec3& hi) {
  SetSelector sel;
  sel.kind = SetSelector::Kind::Box;
  sel.lo = lo;
  sel.hi = hi;
  assign_set(s, name, sel);
}

/// Solve once (zero-step stage) and return the module's result.
ElectricalNetwork::Result solve(State& s, ElectricalNetwork::Params p) {
  ContactModelT<HertzMindlin> law{HertzMindlin::Params{}};
  ElectricalNetwork net(p);
  Simulation sim(s, law);
  sim.add_module(&net);
  test::NullObserver obs;
  StageConfig c = test::stage(1e-9, 0);
  sim.run_stage(c, obs);
  return net.result();
}

/// A straight chain of n spheres along z at centre distance 2r - delta, starting at x0.
void chain(State& s, int n, double delta, const Vec3& x0 = Vec3::Zero()) {
  for (int k = 0; k < n; ++k) test::add_sphere(s, x0 + Vec3(0, 0, k * (2 * kR - delta)), kR, 2500.0);
}

/// n random spheres (radius kR (r0 + dr U)) in a cube of edge L, placed one by one and kept only if
/// no overlap exceeds 5 % of the smaller radius, then all radii grown by 1.35 so that many pairs
/// overlap; electrode sets "bottom" / "top" are the slabs within 1.5 kR of the two z faces.
void random_packing(State& s, std::size_t n, std::uint64_t seed, double r0, double dr, double L, double growth = 1.35) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  while (s.particles.size() < n) {
    const double r = kR * (r0 + dr * U(rng));
    const Vec3 x(L * U(rng), L * U(rng), L * U(rng));
    bool ok = true;
    for (std::size_t i = 0; i < s.particles.size() && ok; ++i)
      ok = s.particles.radius[i] + r - (s.particles.position[i] - x).norm() < 0.05 * std::min(r, s.particles.radius[i]);
    if (ok) test::add_sphere(s, x, r, 2500.0);
  }
  for (auto& r : s.particles.radius) r *= growth;
  box_set(s, "bottom", Vec3(-1, -1, -1), Vec3(1, 1, 1.5 * kR));
  box_set(s, "top", Vec3(-1, -1, L - 1.5 * kR), Vec3(1, 1, 1));
}

ElectricalNetwork::Params holm_params() {
  ElectricalNetwork::Params p;
  p.model = "holm";
  p.conductivity = kKappa;
  p.high = "top";
  p.low = "bottom";
  p.voltage = 2.0;
  return p;
}

}  // namespace

namespace {
/// A chain of n spheres along z with overlap delta, and the sets "bottom" / "top" on its ends.
void electroded_chain(State& s, int n, double delta) {
  chain(s, n, delta);
  box_set(s, "bottom", Vec3(-1, -1, -0.5 * kR), Vec3(1, 1, 0.5 * kR));
  box_set(s, "top", Vec3(-1, -1, (n - 1) * (2 * kR - delta) - 0.5 * kR), Vec3(1, 1, 1));
}
}  // namespace

TEST_CASE("electrical_network: a chain and two parallel chains of Holm contacts", "[electrical]") {
  const int n = 6;
  const double delta = 1e-5;
  const double a = std::sqrt(0.5 * kR * delta);
  const double R_chain = (n - 1) / (2.0 * a * kKappa);
  SECTION("one chain") {
    State s;
    electroded_chain(s, n, delta);
    const auto r = solve(s, holm_params());
    CHECK(test::relative_error(r.resistance, R_chain) < 1e-12);
    CHECK(r.current_mismatch < 1e-12);
    CHECK(r.power_mismatch < 1e-12);
    CHECK(r.floating == 0.0);
    // The potential falls linearly along the chain.
    const auto& u = s.particles.fields.data("electric_potential");
    for (int k = 0; k < n; ++k) CHECK(u[k] == Approx(2.0 * k / (n - 1)).margin(1e-12));
  }
  SECTION("one chain evaluated at 393.15 K with a linear resistivity law") {
    State s;
    electroded_chain(s, n, delta);
    ElectricalNetwork::Params p = holm_params();
    p.temperature = 393.15;
    p.resistivity_coefficient = 0.004;  // rho(T) = rho_ref (1 + 0.004 x 100 K) = 1.4 rho_ref
    CHECK(test::relative_error(solve(s, p).resistance, 1.4 * R_chain) < 1e-12);
  }
  SECTION("one chain evaluated at 393.15 K with a tabulated conductivity") {
    State s;
    electroded_chain(s, n, delta);
    ElectricalNetwork::Params p = holm_params();
    p.temperature = 393.15;
    // kappa falls linearly from kKappa at 293.15 K to kKappa / 2 at 493.15 K: at 393.15 K it is
    // 0.75 kKappa, so R = R_chain / 0.75. The `conductivity` parameter is ignored.
    p.conductivity = 123.0;
    p.conductivity_table_temperature = {293.15, 493.15};
    p.conductivity_table_values = {kKappa, 0.5 * kKappa};
    CHECK(test::relative_error(solve(s, p).resistance, R_chain / 0.75) < 1e-12);
    p.conductivity_table_values = {kKappa};
    CHECK_THROWS_AS(solve(s, p), ConfigError);
  }
  SECTION("one chain driven by an injected current: V = I R, the same R") {
    State s;
    electroded_chain(s, n, delta);
    ElectricalNetwork::Params p = holm_params();
    p.current = 3.0;
    const auto r = solve(s, p);
    CHECK(test::relative_error(r.resistance, R_chain) < 1e-12);
    CHECK(test::relative_error(r.voltage, 3.0 * R_chain) < 1e-12);
    CHECK(r.current_mismatch < 1e-12);
    CHECK(r.power_mismatch < 1e-12);
  }
  SECTION("two chains in parallel, and a particle touching nothing") {
    State s;
    chain(s, n, delta);
    chain(s, n, delta, Vec3(5 * kR, 0, 0));
    test::add_sphere(s, Vec3(20 * kR, 0, 3 * kR), kR, 2500.0);  // floating
    box_set(s, "bottom", Vec3(-1, -1, -0.5 * kR), Vec3(1, 1, 0.5 * kR));
    box_set(s, "top", Vec3(-1, -1, (n - 1) * (2 * kR - delta) - 0.5 * kR), Vec3(1, 1, 1));
    const auto r = solve(s, holm_params());
    CHECK(test::relative_error(r.resistance, 0.5 * R_chain) < 1e-12);
    CHECK(r.floating == 1.0);
    CHECK(std::isnan(s.particles.fields.data("electric_potential").back()));
  }
}

TEST_CASE("electrical_network: no spanning path gives zero current and infinite resistance", "[electrical]") {
  State s;
  chain(s, 3, 1e-5);
  chain(s, 3, 1e-5, Vec3(0, 0, 3 * (2 * kR) + 1e-4));  // a gap of 1e-4 m between the two halves
  box_set(s, "bottom", Vec3(-1, -1, -0.5 * kR), Vec3(1, 1, 0.5 * kR));
  box_set(s, "top", Vec3(-1, -1, 10 * kR), Vec3(1, 1, 1));
  const auto r = solve(s, holm_params());
  CHECK(r.current == 0.0);
  CHECK(std::isinf(r.resistance));
  CHECK(r.power == 0.0);
  CHECK(r.floating == 0.0);  // each half touches one electrode: equipotential, not floating
}

TEST_CASE("electrical_network: simple cubic lattice with the transmission surface", "[electrical]") {
  const int n = 3, m = 5;
  const double d = 2 * kR * (1 - 1e-9);  // touching (an overlap of 2e-12 m makes them graph edges)
  State s;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < m; ++k) test::add_sphere(s, Vec3(i * d, j * d, k * d), kR, 2500.0);
  box_set(s, "bottom", Vec3(-1, -1, -0.5 * kR), Vec3(1, 1, 0.5 * kR));
  box_set(s, "top", Vec3(-1, -1, (m - 1) * d - 0.5 * kR), Vec3(1, 1, 1));
  ElectricalNetwork::Params p = holm_params();
  p.model = "transmission_surface";
  const double rho = 1.0 / kKappa, l = (m - 1) * d, A = std::pow(2 * kR * n, 2);
  SECTION("S = 4 r^2 for every element: R = rho l / A exactly") {
    p.alpha_constant = 4.0;
    const auto r = solve(s, p);
    CHECK(test::relative_error(r.resistance, rho * l / A) < 1e-12);
    CHECK(test::relative_error(r.length, l) < 1e-12);
  }
  SECTION("length_mode sample_height (Eq. 28 as written): L = the lattice's height m d + 2 r - d, kappa_eff with it") {
    p.alpha_constant = 4.0;
    p.area = A;
    p.length_mode = "sample_height";
    const auto r = solve(s, p);
    const double H = (m - 1) * d + 2 * kR;
    CHECK(test::relative_error(r.length, H) < 1e-12);
    CHECK(test::relative_error(r.conductivity_eff, H / (rho * l / A) / A) < 1e-10);
  }
  SECTION("the full alpha(n), f(e) model: the boundary elements change it (reported)") {
    const auto r = solve(s, p);
    const double err = r.resistance / (rho * l / A) - 1.0;
    WARN("transmission surface alpha(n), f(e) on a " << n << "x" << n << "x" << m << " lattice: R / (rho l / A) - 1 = " << err);
    CHECK(std::isfinite(err));
    CHECK(std::abs(err) > 1e-3);  // the face, edge and corner elements do change it
  }
}

TEST_CASE("electrical_network: Kirchhoff and power balance on a random polydisperse packing; solvers agree", "[electrical]") {
  State s;
  random_packing(s, 400, 7, 0.5, 1.0, 12 * kR);
  ElectricalNetwork::Params p = holm_params();
  State s1 = s;
  const auto direct = solve(s1, p);
  INFO("direct: R = " << direct.resistance << " Ohm, floating " << direct.floating);
  REQUIRE(std::isfinite(direct.resistance));
  CHECK(direct.current_mismatch < 1e-10);
  CHECK(direct.power_mismatch < 1e-10);
  for (const char* method : {"cg_ic", "cg_jacobi", "amg"}) {
    State s2 = s;
    p.solver = method;
    p.tolerance = 1e-12;
    const auto cg = solve(s2, p);
    INFO(method);
    CHECK(test::relative_error(cg.resistance, direct.resistance) < 1e-8);
    CHECK(cg.iterations > 0);
  }
  // Seed 000's pseudo-transient iteration (C_i = m_i c, 0.9 of the true limit), run to a tight
  // change indicator: the same resistance, after many more iterations.
  State s3 = s;
  p.solver = "pseudo_transient";
  p.beta = 1e-13;
  const auto pt = solve(s3, p);
  CHECK(test::relative_error(pt.resistance, direct.resistance) < 1e-6);
  CHECK(pt.iterations > 100);
}

TEST_CASE("electrical_network: the contact-centred topology against the particle-centred one", "[electrical]") {
  const double delta = 1e-5;
  const double a = std::sqrt(0.5 * kR * delta);  // Hertz radius of every contact below
  SECTION("a straight chain: both topologies give the same resistance") {
    State s;
    chain(s, 6, delta);
    box_set(s, "bottom", Vec3(-1, -1, -0.5 * kR), Vec3(1, 1, 0.5 * kR));
    box_set(s, "top", Vec3(-1, -1, 5 * (2 * kR - delta) - 0.5 * kR), Vec3(1, 1, 1));
    State s2 = s;
    ElectricalNetwork::Params p = holm_params();
    const double R_pc = solve(s, p).resistance;
    p.topology = "contact_centred";
    const auto cc = solve(s2, p);
    CHECK(test::relative_error(cc.resistance, R_pc) < 1e-12);
    CHECK(cc.power_mismatch < 1e-12);
  }
  SECTION("current turning by 90 degrees inside a particle: the chord halves the way by sqrt 2") {
    // A (bottom electrode) and C (top electrode) touch B at contact directions 90 degrees apart;
    // A and C do not touch. Each Holm half is 1/(4 a kappa). Particle-centred: 4 halves in series,
    // R = 1/(a kappa). Contact-centred: B's two halves scaled by chord/(2 arm) = sin 45 deg,
    // R = (2 + sqrt 2) / (4 a kappa), 14.6 % lower.
    State s;
    const double d = 2 * kR - delta;
    test::add_sphere(s, Vec3(0, 0, 0), kR, 2500.0);   // B
    test::add_sphere(s, Vec3(-d, 0, 0), kR, 2500.0);  // A
    test::add_sphere(s, Vec3(0, 0, d), kR, 2500.0);   // C
    box_set(s, "bottom", Vec3(-1.5 * d, -1, -0.5 * kR), Vec3(-0.5 * d, 1, 0.5 * kR));
    box_set(s, "top", Vec3(-0.5 * kR, -1, 0.5 * d), Vec3(0.5 * kR, 1, 1.5 * d));
    State s2 = s;
    ElectricalNetwork::Params p = holm_params();
    CHECK(test::relative_error(solve(s, p).resistance, 1.0 / (a * kKappa)) < 1e-12);
    p.topology = "contact_centred";
    CHECK(test::relative_error(solve(s2, p).resistance, (2.0 + std::sqrt(2.0)) / (4.0 * a * kKappa)) < 1e-12);
  }
  SECTION("random packing: without the chord factor the star-mesh network is the particle-centred one") {
    State s;
    random_packing(s, 250, 11, 0.6, 0.8, 10 * kR);
    State s2 = s, s3 = s;
    ElectricalNetwork::Params p = holm_params();
    const auto pc = solve(s, p);
    REQUIRE(std::isfinite(pc.resistance));
    p.topology = "contact_centred";
    p.chord_scaling = false;
    const auto star = solve(s2, p);
    CHECK(test::relative_error(star.resistance, pc.resistance) < 1e-9);
    // Same centre potentials (reconstructed from the contacts) wherever both are defined.
    const auto& u1 = s.particles.fields.data("electric_potential");
    const auto& u2 = s2.particles.fields.data("electric_potential");
    for (std::size_t i = 0; i < u1.size(); ++i)
      if (std::isfinite(u1[i])) CHECK(u2[i] == Approx(u1[i]).margin(1e-9 * p.voltage));
    p.chord_scaling = true;
    const auto cc = solve(s3, p);
    CHECK(cc.resistance < pc.resistance);  // Rayleigh monotonicity: every mesh conductance grew
    CHECK(cc.power_mismatch < 1e-10);
    WARN("random packing of 250 spheres: contact-centred / particle-centred resistance = " << cc.resistance / pc.resistance);
  }
}

namespace {
/// Mass porosity of the slab z in [z0, z1] of the particles' lateral extent (the square
/// [min(x - r), max(x + r)] in x and y): 1 - (sphere volume inside, overlaps counted as often as
/// covered) / (slab volume), by counting cell centres of an n^3 grid. Returns the square's area.
double slab_mass_porosity(const State& s, double z0, double z1, int n, double& area) {
  const auto& P = s.particles;
  double lo = 1e300, hi = -1e300;
  for (std::size_t i = 0; i < P.size(); ++i)
    for (int d = 0; d < 2; ++d) {
      lo = std::min(lo, P.position[i][d] - P.radius[i]);
      hi = std::max(hi, P.position[i][d] + P.radius[i]);
    }
  area = (hi - lo) * (hi - lo);
  const double hx = (hi - lo) / n, hz = (z1 - z0) / n;
  double covered = 0.0;
  for (std::size_t i = 0; i < P.size(); ++i) {
    const Vec3& c = P.position[i];
    const double r = P.radius[i];
    for (int k = 0; k < n; ++k) {
      const double z = z0 + (k + 0.5) * hz - c.z();
      if (std::abs(z) > r) continue;
      for (int j = 0; j < n; ++j) {
        const double y = lo + (j + 0.5) * hx - c.y();
        if (y * y + z * z > r * r) continue;
        for (int q = 0; q < n; ++q) {
          const double x = lo + (q + 0.5) * hx - c.x();
          if (x * x + y * y + z * z <= r * r) covered += 1.0;
        }
      }
    }
  }
  return 1.0 - covered / (static_cast<double>(n) * n * n);
}

double set_centroid_z(const State& s, const std::string& set) {
  const auto& f = s.particles.fields.data("set/" + set);
  double z = 0.0, k = 0.0;
  for (std::size_t i = 0; i < f.size(); ++i)
    if (f[i] > 0.5) {
      z += s.particles.position[i].z();
      k += 1.0;
    }
  return z / k;
}
}  // namespace

TEST_CASE("electrical_network: the sphere-element topology stays below the Hashin-Shtrikman bound", "[electrical][sphere_element]") {
  // Random polydisperse packings grown by 1.2 / 1.35 / 1.5 (deeper overlaps, larger constant-
  // volume necks): kappa_eff = L / (R A) between the electrode centroid planes over the slab's
  // area, against kappa 2 (1 - p) / (2 + p) at the slab's mass porosity p (the network's
  // constant-volume necks keep the spheres' mass). The seed's particle-centred network (a
  // hemisphere per neck) exceeds the bound on these packings (issue 21); printed, not asserted.
  // Also: monotone in neck size (growth), Kirchhoff and power balance with the signed element
  // conductances.
  double previous = 0.0;
  for (double growth : {1.2, 1.35, 1.5}) {
    State s;
    random_packing(s, 300, 17, 0.6, 0.8, 10 * kR, growth);
    State s2 = s;
    ElectricalNetwork::Params p;
    p.model = "sintered_neck";
    p.neck = "cv";
    p.hemisphere = "fe_table";
    p.gbf_correction = true;
    p.conductivity = kKappa;
    p.high = "top";
    p.low = "bottom";
    p.voltage = 1.0;
    p.topology = "sphere_element";
    const double z0 = set_centroid_z(s, "bottom"), z1 = set_centroid_z(s, "top");
    double area = 0.0;
    const double porosity = slab_mass_porosity(s, z0, z1, 80, area);
    p.length = z1 - z0;
    p.area = area;
    const auto se = solve(s, p);
    p.topology = "particle_centred";
    const auto pc = solve(s2, p);
    const double hs = kKappa * 2.0 * (1.0 - porosity) / (2.0 + porosity);
    WARN("growth " << growth << ": mass porosity " << porosity << ", kappa / HS bound: sphere element " << se.conductivity_eff / hs
                   << ", particle-centred " << pc.conductivity_eff / hs << ", negative share " << se.negative_share);
    REQUIRE(std::isfinite(se.conductivity_eff));
    CHECK(se.conductivity_eff < hs);
    CHECK(se.conductivity_eff > previous);
    CHECK(se.current_mismatch < 1e-8);
    CHECK(se.power_mismatch < 1e-8);
    previous = se.conductivity_eff;
  }
}

}  // namespace test_electrical_network
