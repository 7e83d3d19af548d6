// contact_percolation (seed 002 connectivity) with electrical_network (model touching) on
// hand-built sphere chains between the faces x = 0 and x = L of a box, through a zero-step
// frozen stage (both event clocks evaluate once on the initial state).
//
// Closed forms: a chain of n touching spheres between the electrodes is n - 1 unit conductances
// in series, R = (n - 1) / g; two separate chains of n1 and n2 spheres are in parallel,
// R = 1 / (g/(n1 - 1) + g/(n2 - 1)), and the paper's arithmetic mean over the spanning clusters
// is ((n1 - 1) + (n2 - 1)) / (2 g); a chain with an added branch that closes a loop of two
// parallel paths halves the middle section. Spanning: a chain from face to face spans; a chain
// broken by one gap larger than the tolerance does not (R = +inf, sigma = 0); a chain touching
// only one face does not. Z = 2 E / N and the largest-cluster fraction are counted by hand.
#include <catch2/catch.hpp>

#include <cmath>
#include <map>
#include <string>

#include "engine/simulation.hpp"
#include "engine/state/particle_set.hpp"
#include "physics/contact/hertz_mindlin.hpp"
#include "physics/electrical/contact_percolation.hpp"
#include "physics/electrical/electrical_network.hpp"
#include "tests/support/scene.hpp"
#include "tests/support/tolerance.hpp"

namespace test_contact_percolation {

using namespace sparkdem;
using namespace sparkdem::physics;

namespace {
constexpr double kR = 1.0;     // [m] lengths in units of R, as in the paper's configs
constexpr double kTol = 2e-3;  // [m] touch tolerance 0.1 % of D

/// Sphere chain along x from x = kR (touching the face x = 0) with centre spacing `spacing`,
/// at height (y, z) = (y, 0).
void chain(State& s, int n, double spacing, double y = 0.0, double x0 = kR) {
  for (int k = 0; k < n; ++k) test::add_sphere(s, Vec3(x0 + k * spacing, y, 0), kR, 1000.0);
}
/// Faces x = 0 and x = L as walls, electrode sets "x_lo", "x_hi": spheres reaching the face.
void faces(State& s, double L) {
  s.walls.push_back(test::plane_wall("xlo", Vec3(0, 0, 0), Vec3(1, 0, 0)));
  s.walls.push_back(test::plane_wall("xhi", Vec3(L, 0, 0), Vec3(-1, 0, 0)));
  for (const auto& [set, wall] : std::map<std::string, std::string>{{"x_lo", "xlo"}, {"x_hi", "xhi"}}) {
    SetSelector sel;
    sel.kind = SetSelector::Kind::TouchingWall;
    sel.wall = wall;
    sel.tolerance = 1e-9;  // [m] rounding of the hand-built positions
    assign_set(s, set, sel);
  }
}
/// Columns of contact_percolation after one evaluation, by name.
std::map<std::string, double> evaluate(State& s, double L, bool clusters = true, double tol = kTol) {
  ContactModelT<HertzMindlin> law{HertzMindlin::Params{}};
  ElectricalNetwork::Params ep;
  ep.model = "touching";
  ep.high = "x_lo";
  ep.low = "x_hi";
  ep.unit_conductance = 1.0;
  ep.touch_tolerance = tol;
  ep.empty_electrode = "open";
  ElectricalNetwork net(ep);
  ContactPercolation::Params cp;
  cp.touch_gap_rel = tol / (2.0 * kR);  // equal spheres: the same set as the network's absolute tolerance
  cp.length = L;
  cp.cluster_resistances = clusters;
  ContactPercolation perc(cp);
  Simulation sim(s, law);
  sim.add_module(&net);
  sim.add_module(&perc);
  test::NullObserver obs;
  StageConfig c = test::frozen_stage(1.0, 0);
  sim.run_stage(c, obs);
  std::map<std::string, double> out;
  const auto names = perc.columns();
  const auto values = perc.column_values(s);
  for (std::size_t k = 0; k < names.size(); ++k) out[names[k].substr(std::string("contact_percolation_").size())] = values[k];
  return out;
}
}  // namespace

TEST_CASE("contact_percolation: spanning of hand-built chains", "[cpc][electrical]") {
  const int n = 6;
  const double spacing = 2 * kR * (1 - 5e-4);   // overlapping by 0.05 % of D
  const double L = 2 * kR + (n - 1) * spacing;  // last sphere reaches the face x = L
  SECTION("a straight chain from face to face spans: R = (n - 1) / g") {
    State s;
    chain(s, n, spacing);
    faces(s, L);
    auto c = evaluate(s, L);
    CHECK(c["spanning"] == 1.0);
    CHECK(c["spanning_clusters"] == 1.0);
    CHECK(c["largest_cluster_fraction"] == 1.0);
    CHECK(c["touching_pairs"] == n - 1);
    CHECK(c["coordination"] == Approx(2.0 * (n - 1) / n).epsilon(1e-15));
    CHECK(test::relative_error(c["resistance"], n - 1.0) < 1e-12);
    CHECK(test::relative_error(c["resistivity"], (n - 1.0) * L) < 1e-12);
    CHECK(test::relative_error(c["conductivity"], 1.0 / ((n - 1.0) * L)) < 1e-12);
    CHECK(test::relative_error(c["resistance_cluster_mean"], n - 1.0) < 1e-12);
    CHECK(test::relative_error(c["resistance_parallel"], n - 1.0) < 1e-12);
  }
  SECTION("gaps below the touch tolerance still conduct; above it they do not") {
    const double gapped = 2 * kR + 1e-3;  // gap 1e-3 R < tolerance 2e-3 R
    State s;
    chain(s, n, gapped);
    faces(s, 2 * kR + (n - 1) * gapped);
    CHECK(evaluate(s, L)["spanning"] == 1.0);
    CHECK(evaluate(s, L, false, 0.0)["spanning"] == 0.0);
  }
  SECTION("a chain broken by one gap does not span") {
    State s;
    chain(s, 3, spacing);
    chain(s, 3, spacing, 0.0, kR + 2 * spacing + 2 * kR + 0.01);  // gap 0.01 R > tolerance
    const double Lb = 2 * kR + 4 * spacing + 2 * kR + 0.01;
    faces(s, Lb);
    auto c = evaluate(s, Lb);
    CHECK(c["spanning"] == 0.0);
    CHECK(c["spanning_clusters"] == 0.0);
    CHECK(c["largest_cluster_fraction"] == Approx(0.5).epsilon(1e-15));
    CHECK(c["touching_pairs"] == 4.0);
    CHECK(std::isinf(c["resistance"]));
    CHECK(c["conductivity"] == 0.0);
    CHECK(std::isinf(c["resistance_cluster_mean"]));
  }
  SECTION("a chain touching only one face does not span") {
    State s;
    chain(s, n, spacing);
    const double Lf = L + 0.5 * kR;  // the far face is 0.5 R beyond the last sphere
    // x_hi must hold some particle for electrical_network: a lone sphere at the far face.
    test::add_sphere(s, Vec3(Lf - kR, 10 * kR, 0), kR, 1000.0);
    faces(s, Lf);
    auto c = evaluate(s, Lf);
    CHECK(c["spanning"] == 0.0);
    CHECK(c["largest_cluster_fraction"] == Approx(double(n) / (n + 1)).epsilon(1e-15));
    CHECK(std::isinf(c["resistance"]));
  }
  SECTION("no particle reaches the far face: an open circuit with empty_electrode = open") {
    State s;
    chain(s, n, spacing);
    const double Lf = L + 0.5 * kR;
    faces(s, Lf);
    REQUIRE(s.particles.fields.data("set/x_hi") == std::vector<double>(n, 0.0));
    auto c = evaluate(s, Lf);
    CHECK(c["spanning"] == 0.0);
    CHECK(c["largest_cluster_fraction"] == 1.0);
    CHECK(std::isinf(c["resistance"]));
    CHECK(c["conductivity"] == 0.0);
  }
}

TEST_CASE("contact_percolation: series-parallel networks of unit conductances", "[cpc][electrical]") {
  const double spacing = 2 * kR * (1 - 5e-4);
  SECTION("two separate chains: parallel 1/R = 1/(n1-1) + 1/(n2-1); the paper's mean is the arithmetic mean") {
    // Chain 1: 5 spheres straight. Chain 2, 10 R away: a zig-zag of 7 spheres (consecutive
    // centres `spacing` apart, next-but-one 1.33 spacing apart: no contact) between the same faces.
    const int n1 = 5;
    const double L = 2 * kR + (n1 - 1) * spacing;
    State s;
    chain(s, n1, spacing);
    // Zig-zag: 7 spheres, consecutive centres at distance `spacing`, x step (n1-1) spacing / 6.
    const double dx = (n1 - 1) * spacing / 6.0, dy = std::sqrt(spacing * spacing - dx * dx);
    for (int k = 0; k < 7; ++k) test::add_sphere(s, Vec3(kR + k * dx, 10 * kR + (k % 2) * dy, 0), kR, 1000.0);
    faces(s, L);
    auto c = evaluate(s, L);
    CHECK(c["spanning"] == 1.0);
    CHECK(c["spanning_clusters"] == 2.0);
    const double R1 = n1 - 1.0, R2 = 6.0;
    CHECK(test::relative_error(c["resistance"], 1.0 / (1.0 / R1 + 1.0 / R2)) < 1e-12);
    CHECK(test::relative_error(c["resistance_parallel"], 1.0 / (1.0 / R1 + 1.0 / R2)) < 1e-12);
    CHECK(test::relative_error(c["resistance_cluster_mean"], 0.5 * (R1 + R2)) < 1e-12);
    CHECK(c["touching_pairs"] == (n1 - 1) + 6);
  }
  SECTION("a loop: two parallel paths between two chain segments") {
    // A - B, then B-C-E and B-D-E (a square of side d, diagonals sqrt(2) d: no contact), then
    // E - F. The two 2-conductance paths in parallel give 1: R = 1 + 1 + 1 = 3.
    const double d = spacing, q = d / std::sqrt(2.0);
    State s;
    test::add_sphere(s, Vec3(kR, 0, 0), kR, 1000.0);                  // A
    test::add_sphere(s, Vec3(kR + d, 0, 0), kR, 1000.0);              // B
    test::add_sphere(s, Vec3(kR + d + q, q, 0), kR, 1000.0);          // C
    test::add_sphere(s, Vec3(kR + d + q, -q, 0), kR, 1000.0);         // D
    test::add_sphere(s, Vec3(kR + d + 2 * q, 0, 0), kR, 1000.0);      // E
    test::add_sphere(s, Vec3(kR + 2 * d + 2 * q, 0, 0), kR, 1000.0);  // F
    const double L = 2 * kR + 2 * d + 2 * q;
    faces(s, L);
    auto c = evaluate(s, L);
    CHECK(c["touching_pairs"] == 6.0);  // AB, BC, BD, CE, DE, EF
    CHECK(test::relative_error(c["resistance"], 3.0) < 1e-12);
    CHECK(test::relative_error(c["resistance_cluster_mean"], 3.0) < 1e-12);
    CHECK(c["coordination"] == Approx(2.0).epsilon(1e-15));
  }
}

TEST_CASE("contact_percolation: pure metrics on an explicit graph", "[cpc]") {
  // 7 nodes: 0-1-2 (high 0, low 2), 3-4 (high 3 only), 5, 6 isolated; edge 1-0 repeated, self loop 5-5.
  const std::vector<Index> a = {0, 1, 1, 3, 5}, b = {1, 2, 0, 4, 5}, high = {0, 3}, low = {2, 6};
  const auto m = percolation::metrics(7, a, b, high, low);
  CHECK(m.spanning);
  CHECK(m.spanning_clusters == 1);
  CHECK(m.touching_pairs == 3);
  CHECK(m.coordination == Approx(6.0 / 7.0).epsilon(1e-15));
  CHECK(m.largest_cluster_fraction == Approx(3.0 / 7.0).epsilon(1e-15));
}

}  // namespace test_contact_percolation
