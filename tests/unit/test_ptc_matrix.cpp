// ptc_matrix: the thermoelastic bonded-network matrix of seed 002 (rigid fillers, axial polymer
// springs with eigen-elongation eps0 h_ij, stiffness E_m A / max(h, h_min)) and the contact
// network as a function of eps0.
//
// Closed forms:
//  (a) a 1-D chain 0 -(h1)- 1 =touching= 2 -(h3)- 3 along x with both ends held: the springs
//      are in series, the free elongation eps0 (h1 + h3) is taken up by a tension
//      T = -eps0 (h1 + h3) E_m A / (h1 + h_min + h3) (compressive), so the touching contact opens
//      by T / k_c = -eps0 (h1 + h3) h_min / (h1 + h_min + h3) (it closes), and u1 = eps0 h1 + T h1 / (E_m A).
//      With only one end held the chain expands freely: the contact opening is 0 and the far
//      end moves by eps0 (h1 + h3).
//  (b) a simple cubic lattice, spacing a = 2R + h, springs to the 6 nearest neighbours only
//      (cut-off below the diagonal gap sqrt(2) a - 2R), no filler held: the affine field
//      u = (h / a) x makes every spring exactly stress-free, so it is THE solution (up to rigid
//      modes, invisible in openings): every unit opening equals h, and u_j - u_i = (h/a)(x_j - x_i).
//  (c) a hand-built contact network (chains of 3 and 2 contacts in parallel between two
//      electrodes) with prescribed unit openings: Z = 2 E / N and R_eq = series/parallel sums
//      as contacts open one by one; the exact switching strain is the break strain of the
//      contact whose opening cuts the last spanning path.
// Tolerances: the ground-spring regularisation (delta = 1e-12 x mean k) perturbs the chain
// solution by O(1e-12) relative; 1e-8 is used. The lattice solve uses delta = 1e-10: 1e-6.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <vector>

#include "engine/core/error.hpp"
#include "engine/graph/laplacian.hpp"
#include "physics/electrical/ptc_matrix.hpp"
#include "tests/support/tolerance.hpp"

namespace test_ptc_matrix {

using namespace sparkdem;
using namespace sparkdem::physics;

TEST_CASE("ptc_matrix: 1-D chain with a touching pair between held ends (series springs)", "[ptc][cpc]") {
  const double R = 1.0, h1 = 0.3, h3 = 0.5, hmin = 0.01;
  const std::vector<Vec3> x = {Vec3(0, 0, 0), Vec3(2 * R + h1, 0, 0), Vec3(4 * R + h1, 0, 0), Vec3(6 * R + h1 + h3, 0, 0)};
  const std::vector<double> r(4, R);
  ptc::MatrixParams p;
  p.matrix_modulus = 3.0;  // E_m A cancels out of the displacements
  p.bond_area = 0.7;
  p.min_gap_rel = hmin / (2 * R);
  p.cutoff_gap_rel = 0.5;  // h_max = 1: excludes 0-2 (gap 2 + h1) and 1-3
  p.touch_gap_rel = 1e-3;
  p.regularisation = 1e-12;
  const ptc::SpringNetwork net = ptc::build_network(x, r, p);
  REQUIRE(net.size() == 3);
  CHECK(net.eigen_gap[1] == 0.0);  // the touching pair holds no polymer eigenstrain
  CHECK(net.stiffness[1] == Approx(3.0 * 0.7 / hmin).epsilon(1e-14));
  SECTION("both ends held: the contact closes by (h1 + h3) h_min / (h1 + h_min + h3) per unit eps0") {
    const std::vector<Index> fixed = {0, 3};
    const ptc::UnitSolution s = ptc::solve_unit(4, net, p, fixed);
    const double T = -(h1 + h3) / (h1 + hmin + h3);  // tension / (E_m A)
    CHECK(test::relative_error(s.opening[1], T * hmin) < 1e-8);
    CHECK(test::relative_error(s.displacement[1].x(), h1 + T * h1) < 1e-8);
    CHECK(test::relative_error(s.displacement[2].x(), h1 + T * h1 + T * hmin) < 1e-8);
    CHECK(s.displacement[0].norm() == 0.0);
    CHECK(s.displacement[3].norm() == 0.0);
    CHECK(std::abs(s.displacement[1].y()) < 1e-12);
    CHECK(s.residual < 1e-10);
    // contact set and break strains: it closes, so it never breaks
    const ptc::Contacts c = ptc::candidate_contacts(net, s, p.touch_gap_rel, 0.0);
    REQUIRE(c.size() == 1);
    CHECK(std::isinf(ptc::conduction_intervals(c, p.touch_gap_rel, 0.0).hi[0]));
  }
  SECTION("one end held: free expansion, no opening, far end at eps0 (h1 + h3)") {
    const std::vector<Index> fixed = {0};
    const ptc::UnitSolution s = ptc::solve_unit(4, net, p, fixed);
    CHECK(std::abs(s.opening[1]) < 1e-8 * (h1 + h3));
    CHECK(test::relative_error(s.displacement[3].x(), h1 + h3) < 1e-8);
    CHECK(test::relative_error(s.opening[0], h1) < 1e-8);
    CHECK(test::relative_error(s.opening[2], h3) < 1e-8);
  }
}

TEST_CASE("ptc_matrix: uniform lattice expands affinely, every opening equals the gap h", "[ptc][cpc]") {
  const double R = 1.0, h = 0.2, a = 2 * R + h;
  const int m = 4;
  std::vector<Vec3> x;
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < m; ++j)
      for (int k = 0; k < m; ++k) x.emplace_back(a * i + 0.1, a * j - 3.0, a * k + 7.0);  // off-origin
  const std::vector<double> r(x.size(), R);
  ptc::MatrixParams p;
  p.min_gap_rel = 0.005;
  p.cutoff_gap_rel = 0.25;  // h_max = 0.5 R; diagonal gap sqrt(2) a - 2R = 1.11: nearest neighbours only
  p.regularisation = 1e-10;
  const ptc::SpringNetwork net = ptc::build_network(x, r, p);
  REQUIRE(net.size() == static_cast<std::size_t>(3 * m * m * (m - 1)));
  const ptc::UnitSolution s = ptc::solve_unit(x.size(), net, p);
  double worst = 0.0, worst_grad = 0.0;
  for (std::size_t e = 0; e < net.size(); ++e) {
    worst = std::max(worst, test::relative_error(s.opening[e], h));
    const Vec3 du = s.displacement[net.b[e]] - s.displacement[net.a[e]];
    const Vec3 dx = x[net.b[e]] - x[net.a[e]];
    worst_grad = std::max(worst_grad, (du - (h / a) * dx).norm() / h);
  }
  INFO("largest relative opening error " << worst << ", displacement-gradient error " << worst_grad);
  CHECK(worst < 1e-6);
  CHECK(worst_grad < 1e-6);
  // The fillers' affine fit reads the composite's expansion: tr (h / a) I per unit eps0.
  CHECK(test::relative_error(ptc::affine_volumetric_strain(x, s.displacement), 3.0 * h / a) < 1e-6);
  // No touching pairs in the lattice: empty contact set.
  CHECK(ptc::candidate_contacts(net, s, p.touch_gap_rel, 0.0).size() == 0);
}

TEST_CASE("ptc_matrix: Z, R_eq and the switching strain as contacts open one by one", "[ptc][cpc][electrical]") {
  // Chain A: 0-1-2-3 (3 contacts), chain B: 4-5-6 (2 contacts); electrodes high {0, 4}, low {3, 6}.
  ptc::Contacts c;
  c.a = {0, 1, 2, 4, 5};
  c.b = {1, 2, 3, 5, 6};
  c.gap = {-1e-3, -1e-3, -1e-3, -1e-3, -1e-3};  // overlaps of 1e-3 m
  c.opening = {0.1, -0.05, 0.05, 0.025, 0.0};   // break strains 0.01, inf, 0.02, 0.04, inf
  c.distance.assign(5, 2.0);
  c.touching.assign(5, 1);
  const ptc::Intervals iv = ptc::conduction_intervals(c, 1e-3, 0.0);
  const std::vector<double>& eb = iv.hi;
  REQUIRE(eb.size() == 5);
  CHECK(eb[0] == Approx(0.01).epsilon(1e-14));
  CHECK(std::isinf(eb[1]));
  CHECK(eb[2] == Approx(0.02).epsilon(1e-14));
  CHECK(eb[3] == Approx(0.04).epsilon(1e-14));
  CHECK(std::isinf(eb[4]));
  const std::vector<Index> high = {0, 4}, low = {3, 6};
  const std::size_t n = 7;
  LaplacianSolver solver;
  struct Expect {
    double eps0;
    bool spanning;
    std::size_t conducting;
    double R;
  };
  const Expect table[] = {
      {0.0, true, 5, 1.0 / (1.0 / 3.0 + 1.0 / 2.0)},
      {0.01, true, 5, 1.0 / (1.0 / 3.0 + 1.0 / 2.0)},  // at eps_b the gap equals the threshold: conducts
      {0.015, true, 4, 2.0},                           // chain A cut: only B (2 in series)
      {0.03, true, 3, 2.0},
      {0.04, true, 3, 2.0},
      {0.05, false, 2, std::numeric_limits<double>::infinity()},
  };
  for (const Expect& t : table) {
    INFO("eps0 = " << t.eps0);
    const ptc::StrainPoint sp = ptc::evaluate(n, c, iv, t.eps0, 1.0, high, low, solver);
    CHECK(sp.spanning == t.spanning);
    CHECK(sp.conducting == t.conducting);
    CHECK(sp.coordination == Approx(2.0 * t.conducting / n).epsilon(1e-15));
    if (std::isinf(t.R))
      CHECK(std::isinf(sp.resistance));
    else
      CHECK(test::relative_error(sp.resistance, t.R) < 1e-12);
  }
  CHECK(ptc::switching_strain(n, c, iv, high, low) == Approx(0.04).epsilon(1e-14));
  // With B's last contact never opening and A's intact forever, the network never switches.
  ptc::Intervals never = iv;
  never.hi.assign(5, std::numeric_limits<double>::infinity());
  CHECK(std::isinf(ptc::switching_strain(n, c, never, high, low)));
  // Break gap: a contact that starts at a positive gap inside the tolerance opens at once with
  // break_gap = 0, and at (break_gap - h) / delta when break_gap > h.
  ptc::Contacts g;
  g.a = {0};
  g.b = {1};
  g.gap = {1e-3};
  g.opening = {0.1};
  g.distance = {2.0};
  g.touching = {1};
  CHECK(ptc::conduction_intervals(g, 1e-3, 0.0).hi[0] == 0.0);
  CHECK(ptc::conduction_intervals(g, 1e-3, 1e-3).hi[0] == Approx(0.01).epsilon(1e-12));  // threshold 1e-3 x D = 2e-3
  // Without a spanning network at eps0 = 0 the switching strain is 0.
  CHECK(ptc::switching_strain(n, c, iv, std::vector<Index>{0}, std::vector<Index>{6}) == 0.0);
}

TEST_CASE("ptc_matrix: a closing pair joins at (touch_gap_rel D - h) / delta and can carry the network past a break", "[ptc][cpc][electrical]") {
  // 0 -touching- 1 -touching- 2, electrodes high {0}, low {2}: contact 0-1 never opens (delta 0),
  // 1-2 breaks at (1e-3 x 2 - 0) / 0.1 = 0.02. A candidate 0-2 (gap 0.02 = 1 % of D, outside the
  // touch tolerance) closes with delta < 0 and joins at (2e-3 - 0.02) / delta.
  ptc::Contacts c;
  c.a = {0, 1, 0};
  c.b = {1, 2, 2};
  c.gap = {0.0, 0.0, 0.02};
  c.distance.assign(3, 2.0);
  c.touching = {1, 1, 0};
  const std::vector<Index> high = {0}, low = {2};
  LaplacianSolver solver;
  SECTION("joins at 0.018, before the break at 0.02: the network never switches") {
    c.opening = {0.0, 0.1, -1.0};
    const ptc::Intervals iv = ptc::conduction_intervals(c, 1e-3, 1e-3);
    CHECK(iv.lo[2] == Approx(0.018).epsilon(1e-12));
    CHECK(std::isinf(iv.hi[2]));
    CHECK(iv.hi[1] == Approx(0.02).epsilon(1e-12));
    CHECK(std::isinf(ptc::switching_strain(3, c, iv, high, low)));
    CHECK(ptc::evaluate(3, c, iv, 0.017, 1.0, high, low, solver).conducting == 2);
    const ptc::StrainPoint late = ptc::evaluate(3, c, iv, 0.05, 1.0, high, low, solver);
    CHECK(late.spanning);
    CHECK(late.conducting == 2);  // 0-1 and the closed 0-2; 1-2 broke
    CHECK(test::relative_error(late.resistance, 1.0) < 1e-12);
  }
  SECTION("joins at 0.036, after the break at 0.02: switches at 0.02 and reconnects") {
    c.opening = {0.0, 0.1, -0.5};
    const ptc::Intervals iv = ptc::conduction_intervals(c, 1e-3, 1e-3);
    CHECK(iv.lo[2] == Approx(0.036).epsilon(1e-12));
    CHECK(ptc::switching_strain(3, c, iv, high, low) == Approx(0.02).epsilon(1e-12));
    CHECK_FALSE(ptc::evaluate(3, c, iv, 0.03, 1.0, high, low, solver).spanning);
    CHECK(ptc::evaluate(3, c, iv, 0.04, 1.0, high, low, solver).spanning);
  }
  SECTION("a candidate that neither opens nor closes never conducts; a malformed set is a typed error") {
    c.opening = {0.0, 0.1, 0.0};
    const ptc::Intervals iv = ptc::conduction_intervals(c, 1e-3, 1e-3);
    CHECK(iv.lo[2] > iv.hi[2]);  // empty
    CHECK(ptc::evaluate(3, c, iv, 0.0, 1.0, high, low, solver).conducting == 2);
    CHECK(ptc::switching_strain(3, c, iv, high, low) == Approx(0.02).epsilon(1e-12));
    ptc::Contacts bad = c;
    bad.distance.pop_back();
    CHECK_THROWS_AS(ptc::conduction_intervals(bad, 1e-3, 1e-3), sparkdem::SetupError);
    bad = c;
    bad.opening[0] = std::numeric_limits<double>::quiet_NaN();
    CHECK_THROWS_AS(ptc::conduction_intervals(bad, 1e-3, 1e-3), sparkdem::SetupError);
  }
  SECTION("negative strain: a pair that opens under expansion closes on cooling") {
    c.opening = {0.0, 0.1, 1.0};
    const ptc::Intervals iv = ptc::conduction_intervals(c, 1e-3, 1e-3);
    CHECK(std::isinf(-iv.lo[2]));
    CHECK(iv.hi[2] == Approx(-0.018).epsilon(1e-12));
    CHECK(ptc::evaluate(3, c, iv, -0.01, 1.0, high, low, solver).conducting == 2);
    CHECK(ptc::evaluate(3, c, iv, -0.02, 1.0, high, low, solver).conducting == 3);
  }
}

TEST_CASE("ptc_matrix: compression closes a gap below h_min (1-D chain, both ends held)", "[ptc][cpc]") {
  // 0 -(h1)- 1 -(g)- 2 -(h3)- 3 along x, ends held. Every gap is polymer (g above the touch
  // tolerance), so every spring carries eps0 h_e; the middle one is capped at h_min > g. Series
  // springs, fixed length: T / (E_m A) = -eps0 (h1 + g + h3) / (h1 + h_min + h3), and the middle
  // gap opens by eps0 g + T h_min / (E_m A) = eps0 (g - h_min (h1 + g + h3) / (h1 + h_min + h3)) < 0:
  // it closes, and the pair joins the network at eps0 = (touch_gap_rel D - g) / delta.
  const double R = 1.0, h1 = 0.5, h3 = 0.5, g = 0.004, hmin = 0.01;
  const std::vector<Vec3> x = {Vec3(0, 0, 0), Vec3(2 * R + h1, 0, 0), Vec3(4 * R + h1 + g, 0, 0), Vec3(6 * R + h1 + g + h3, 0, 0)};
  const std::vector<double> r(4, R);
  ptc::MatrixParams p;
  p.min_gap_rel = hmin / (2 * R);
  p.cutoff_gap_rel = 0.5;
  p.touch_gap_rel = 1e-3;
  p.regularisation = 1e-12;
  const ptc::SpringNetwork net = ptc::build_network(x, r, p);
  REQUIRE(net.size() == 3);
  CHECK(net.eigen_gap[1] == Approx(g).epsilon(1e-12));
  const std::vector<Index> fixed = {0, 3};
  const ptc::UnitSolution s = ptc::solve_unit(4, net, p, fixed);
  const double delta = g - hmin * (h1 + g + h3) / (h1 + hmin + h3);
  REQUIRE(delta < 0.0);
  CHECK(test::relative_error(s.opening[1], delta) < 1e-8);
  const ptc::Contacts c = ptc::candidate_contacts(net, s, p.touch_gap_rel, 0.01);  // reach 1 % of D = 0.02 > g
  REQUIRE(c.size() == 1);
  CHECK(c.touching[0] == 0);
  const ptc::Intervals iv = ptc::conduction_intervals(c, p.touch_gap_rel, p.touch_gap_rel);
  const double join = (1e-3 * 2 * R - g) / delta;
  CHECK(test::relative_error(iv.lo[0], join) < 1e-8);
  const std::vector<Index> high = {1}, low = {2};
  CHECK(ptc::switching_strain(4, c, iv, high, low) == 0.0);  // does not span at eps0 = 0
  LaplacianSolver solver;
  CHECK_FALSE(ptc::evaluate(4, c, iv, 0.99 * join, 1.0, high, low, solver).spanning);
  CHECK(ptc::evaluate(4, c, iv, 1.01 * join, 1.0, high, low, solver).spanning);
  // Without closing candidates the pair is not followed.
  CHECK(ptc::candidate_contacts(net, s, p.touch_gap_rel, 0.0).size() == 0);
}

TEST_CASE("ptc_matrix: affine_volumetric_strain is tr A of an affine field, blind to rotation and translation", "[ptc][cpc]") {
  std::vector<Vec3> x;
  for (int i = 0; i < 30; ++i) x.emplace_back(std::sin(1.3 * i) * 5.0, std::cos(0.7 * i) * 3.0 + i * 0.1, std::sin(0.37 * i * i));
  Eigen::Matrix3d A;
  A << 0.011, 0.004, -0.002, 0.001, -0.003, 0.007, 0.005, 0.002, 0.02;
  const Vec3 b(0.3, -1.0, 2.0);
  Eigen::Matrix3d W;  // a small rotation (skew): no volume change
  W << 0.0, -0.01, 0.02, 0.01, 0.0, -0.03, -0.02, 0.03, 0.0;
  std::vector<Vec3> u, w;
  for (const Vec3& p : x) {
    u.push_back(A * p + b);
    w.push_back(W * p + b);
  }
  CHECK(std::abs(ptc::affine_volumetric_strain(x, u) - A.trace()) < 1e-13);
  CHECK(std::abs(ptc::affine_volumetric_strain(x, w)) < 1e-13);
  // Fillers on one plane cannot give a volume change: typed error.
  std::vector<Vec3> flat = x;
  for (Vec3& p : flat) p.z() = 1.0;
  CHECK_THROWS_AS(ptc::affine_volumetric_strain(flat, u), sparkdem::SetupError);
}

}  // namespace test_ptc_matrix
