// tension_test module (issue 7, calibration tool; physics/mechanics/tension_test.hpp):
// closed forms of the strain fits and the stress, and the reaction of a prescribed set under
// local_damping.
#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>
#include <random>

#include "engine/state/particle_set.hpp"
#include "physics/body/gravity.hpp"
#include "physics/mechanics/tension_test.hpp"
#include "support/scene.hpp"

namespace test_tension_test {

using namespace sparkdem;

namespace {

/// Random centres in a cylinder of radius R and length L whose axis starts at p along unit a.
State random_cylinder(int n, double R, double L, const Vec3& p, const Vec3& a, unsigned seed) {
  State s;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  // An orthonormal frame (b, c, a).
  const Vec3 b = a.unitOrthogonal(), c = a.cross(b);
  for (int k = 0; k < n; ++k) {
    const double rho = R * std::sqrt(u(rng)), phi = 2.0 * std::numbers::pi * u(rng), z = L * u(rng);
    test::add_sphere(s, p + z * a + rho * (std::cos(phi) * b + std::sin(phi) * c), 0.05 * R, 7060.0);
  }
  return s;
}

/// Members of the set: centres within `h` of the end z = 0 (fixed) or z = L (pulled).
void end_sets(State& s, const Vec3& p, const Vec3& a, double L, double h) {
  auto& P = s.particles;
  P.fields.declare({"set/bottom", 1, "1", 0.0, true}, P.size());
  P.fields.declare({"set/top", 1, "1", 0.0, true}, P.size());
  auto& fb = P.fields.data("set/bottom");
  auto& ft = P.fields.data("set/top");
  for (std::size_t i = 0; i < P.size(); ++i) {
    const double z = (P.position[i] - p).dot(a);
    fb[i] = z < h ? 1.0 : 0.0;
    ft[i] = z > L - h ? 1.0 : 0.0;
  }
}

physics::TensionTest make_module(const Vec3& p, const Vec3& axis, double R, double f) {
  physics::TensionTest::Params tp;
  tp.axis_point = p;
  tp.axis = axis;
  tp.radius = R;
  tp.pulled = "top";
  tp.fixed = "bottom";
  tp.middle_fraction = f;
  return physics::TensionTest(tp);
}

}  // namespace

TEST_CASE("tension_test: an affine deformation returns its axial and lateral strains and nu exactly", "[tension][mechanics]") {
  // x = p + F (x0 - p) + t a with F = I + eps_a a a^T + eps_l (I - a a^T): the axial fit (with
  // intercept) returns eps_a whatever the rigid axial translation t, the radial fit eps_l; both
  // are exact in exact arithmetic, so the tolerance is rounding: |error| <= 1e-12 on the
  // strains (they are 1e-3 and -2.9e-4; the displacements are differences of coordinates ~1e-2 m).
  const double R = 1e-3, L = 4e-3;
  const Vec3 p(0.01, -0.02, 0.005);
  const Vec3 axis(1.0, 2.0, 2.0);  // oblique, not unit length
  const Vec3 a = axis.normalized();
  State s = random_cylinder(600, R, L, p, a, 7);
  end_sets(s, p, a, L, 2e-4);
  physics::TensionTest m = make_module(p, axis, R, 0.5);
  Declarations d;
  m.declare(d);
  for (const auto& f : d.particle_fields) s.particles.fields.declare(f, s.particles.size());
  m.bind(s);  // captures the reference positions
  const double eps_a = 1e-3, eps_l = -2.9e-4, t = 3.7e-6;
  const Eigen::Matrix3d F = Eigen::Matrix3d::Identity() + eps_a * a * a.transpose() +
                            eps_l * (Eigen::Matrix3d::Identity() - a * a.transpose());
  for (auto& x : s.particles.position) x = p + F * (x - p) + t * a;
  const auto r = m.measure(s);
  // Middle half of the length of 600 uniform centres: about 300 particles.
  CHECK(r.middle > 200);
  CHECK(r.middle < 400);
  CHECK(std::abs(r.axial_strain - eps_a) <= 1e-12);
  CHECK(std::abs(r.lateral_strain - eps_l) <= 1e-12);
  CHECK(std::abs(r.poisson_ratio - 0.29) <= 1e-9);
  // Capturing again (a later stage binds) keeps the first reference.
  m.bind(s);
  CHECK(std::abs(m.measure(s).axial_strain - eps_a) <= 1e-12);

  SECTION("the stress is the pulled set's axial force over pi R^2, tension positive") {
    // Forces: the pulled members share -F0 a (the sample pulls them back) plus transverse parts
    // (normal to a: not counted); the fixed members share +F0' a. Expected: stress = F0 / (pi R^2) to
    // rounding (1e-12 relative), E = stress / eps_a.
    const double F0 = 2.5, F0f = 2.4;
    const auto& ft = s.particles.fields.data("set/top");
    const auto& fb = s.particles.fields.data("set/bottom");
    double nt = 0, nb = 0;
    for (std::size_t i = 0; i < s.particles.size(); ++i) {
      nt += ft[i];
      nb += fb[i];
    }
    REQUIRE(nt > 5);
    REQUIRE(nb > 5);
    const Vec3 b = a.unitOrthogonal();
    int k = 0;
    for (std::size_t i = 0; i < s.particles.size(); ++i) {
      s.particles.force[i] = Vec3(1.0, -3.0, 0.5) * 1e-3;  // others: ignored
      if (ft[i] > 0.5) s.particles.force[i] = -(F0 / nt) * a + ((k++ % 2) ? 1.0 : -1.0) * 0.1 * b;
      if (fb[i] > 0.5) s.particles.force[i] = (F0f / nb) * a;
    }
    const auto r2 = m.measure(s);
    const double area = std::numbers::pi * R * R;
    CHECK(r2.force == Approx(F0).epsilon(1e-12));
    CHECK(r2.force_fixed == Approx(F0f).epsilon(1e-12));
    CHECK(r2.stress == Approx(F0 / area).epsilon(1e-12));
    CHECK(r2.young_modulus == Approx(F0 / area / eps_a).epsilon(1e-9));
    // The columns report the same figures in the documented order.
    const auto cols = m.columns();
    const auto vals = m.column_values(s);
    REQUIRE(cols.size() == vals.size());
    CHECK(cols[2] == "tension_stress");
    CHECK(vals[2] == r2.stress);
    CHECK(cols[6] == "tension_poisson_ratio");
    CHECK(vals[6] == r2.poisson_ratio);
    // Swapping the roles (pull the bottom, fix the top) keeps tension positive.
    physics::TensionTest::Params swapped;
    swapped.axis_point = p;
    swapped.axis = axis;
    swapped.radius = R;
    swapped.pulled = "bottom";
    swapped.fixed = "top";
    const auto r3 = physics::TensionTest(swapped).measure(s);
    CHECK(r3.force == Approx(F0f).epsilon(1e-12));
    CHECK(r3.force_fixed == Approx(F0).epsilon(1e-12));
  }
}

TEST_CASE("tension_test: configuration and set-up errors", "[tension][mechanics]") {
  physics::TensionTest::Params tp;
  tp.radius = 1e-3;
  tp.pulled = "top";
  tp.fixed = "bottom";
  tp.axis = Vec3::Zero();
  CHECK_THROWS_AS(physics::TensionTest(tp), ConfigError);
  tp.axis = Vec3::UnitZ();
  physics::TensionTest m(tp);
  State s = random_cylinder(20, 1e-3, 4e-3, Vec3::Zero(), Vec3::UnitZ(), 1);
  Declarations d;
  m.declare(d);
  for (const auto& f : d.particle_fields) s.particles.fields.declare(f, s.particles.size());
  CHECK_THROWS_AS(m.bind(s), SetupError);  // the sets are not defined
}

TEST_CASE("local_damping leaves prescribed particles alone: their force is the reported reaction", "[tension][mechanics][damping]") {
  // One free and one prescribed particle with the same force and velocity: the free one loses
  // alpha |F| sign(v) per component, the prescribed one keeps its force exactly.
  State s;
  test::add_sphere(s, Vec3::Zero(), 1e-3, 7060.0, Vec3(0.0, 0.0, 0.01));
  test::add_sphere(s, Vec3(0.0, 0.0, 1e-2), 1e-3, 7060.0, Vec3(0.0, 0.0, 0.01));
  s.particles.fixed[1] = 1;
  const Vec3 f(0.3, -0.2, -1.0);
  s.particles.force[0] = s.particles.force[1] = f;
  s.particles.torque[0] = s.particles.torque[1] = Vec3::Zero();
  physics::LocalDamping ld(physics::LocalDamping::Params{0.7});
  ld.advance(s, StepInfo{0, 0.0, 1e-6, 0});
  CHECK(s.particles.force[0].z() == Approx(-1.7));  // -1 - 0.7 |-1| sign(+0.01)
  CHECK(s.particles.force[0].x() == 0.3);           // v_x = 0: no damping
  CHECK(s.particles.force[1] == f);
}

}  // namespace test_tension_test
