/// Named particle sets: selection rules and prescribed-velocity boundary conditions.
#include <catch2/catch.hpp>

#include "engine/state/particle_set.hpp"
#include "physics/body/gravity.hpp"
#include "physics/contact/hertz_mindlin.hpp"
#include "support/scene.hpp"

namespace test_particle_sets {

using namespace sparkdem;

namespace {
/// A vertical column of `n` touching-free spheres (radius r, gap r/2) standing on a floor.
State column(int n, double r) {
  State s;
  for (int k = 0; k < n; ++k) test::add_sphere(s, Vec3(0, 0, r + k * 2.5 * r), r, 2500.0);
  s.walls.push_back(test::plane_wall("floor", Vec3::Zero(), Vec3::UnitZ()));
  return s;
}
}  // namespace

TEST_CASE("particle set selectors pick the documented particles", "[sets]") {
  State s = column(10, 1e-3);
  const double top = s.particles.position[9].z();
  SetSelector sel;
  sel.kind = SetSelector::Kind::TopLayer;
  sel.thickness = 3e-3;  // centres within 3 mm of the top centre: the top two (spacing 2.5 mm)
  CHECK(select_particles(s, sel) == std::vector<Index>{8, 9});
  sel.kind = SetSelector::Kind::BottomLayer;
  CHECK(select_particles(s, sel) == std::vector<Index>{0, 1});
  sel.kind = SetSelector::Kind::TouchingWall;
  sel.wall = "floor";
  sel.tolerance = 0.0;  // the bottom sphere touches the floor exactly (d = r)
  CHECK(select_particles(s, sel) == std::vector<Index>{0});
  sel.kind = SetSelector::Kind::Ids;
  sel.ids = {3, 7};
  CHECK(select_particles(s, sel) == std::vector<Index>{3, 7});
  sel.kind = SetSelector::Kind::Box;
  sel.lo = Vec3(-1, -1, top - 1e-9);
  sel.hi = Vec3(1, 1, 1);
  CHECK(select_particles(s, sel) == std::vector<Index>{9});
  sel.kind = SetSelector::Kind::TouchingWall;
  sel.wall = "roof";
  CHECK_THROWS_AS(select_particles(s, sel), SetupError);
}

TEST_CASE("a prescribed set moves at its velocity and the rest integrates", "[sets]") {
  // Column of 5 spheres under gravity; the top sphere is held at a constant downward speed.
  // Set particles: x(T) = x(0) + v T exactly (up to rounding, 1e-12 relative); free particles
  // fall as x(0) - g t^2 / 2 while they touch nothing (checked for the second one from the top,
  // 1e-9 relative: velocity Verlet is exact for constant acceleration).
  State s = column(5, 1e-3);
  SetSelector top;
  top.kind = SetSelector::Kind::TopLayer;
  top.thickness = 1e-4;
  REQUIRE(assign_set(s, "top", top) == 1);
  const Vec3 v(0.0, 0.0, -0.01);
  const Vec3 x_top0 = s.particles.position[4], x_mid0 = s.particles.position[3];
  physics::HertzMindlin::Params lp;
  lp.youngs_modulus = 1e7;
  ContactModelT<physics::HertzMindlin> law(lp);
  Simulation sim(s, law);
  physics::Gravity g(physics::Gravity::Params{Vec3(0, 0, -9.81)});
  sim.add_module(&g);
  StageConfig cfg = test::stage(1e-6, 5000, 1e-4);
  cfg.prescribed_sets["top"] = v;
  test::NullObserver obs;
  sim.run_stage(cfg, obs);
  const double T = 5000 * 1e-6;
  CHECK((s.particles.position[4] - (x_top0 + v * T)).norm() <= 1e-12 * x_top0.norm());
  const double expected = x_mid0.z() - 0.5 * 9.81 * T * T;  // 1.2e-4 m fall < 1.5 mm gap: no contact
  CHECK(s.particles.position[3].z() == Approx(expected).epsilon(1e-9));
  // After the stage the set is released: nothing stays fixed.
  for (auto f : s.particles.fixed) CHECK(f == 0);
  // The membership field exists and is written with the frames.
  REQUIRE(s.particles.fields.has("set/top"));
  CHECK(s.particles.fields.info("set/top").output);
}

TEST_CASE("cylinder set: centre-inside and overlap criteria, any axis", "[sets]") {
  // Spheres of radius 1 mm in the plane z = 0 at x = 0, 2, 4, 6 mm (y = 0); a cylinder of radius
  // 3 mm about the z axis through the origin. Centre criterion (d <= R): x = 0, 2 mm. Overlap
  // criterion (d < R + r = 4 mm): x = 0, 2 mm, and not x = 4 mm (it only touches, d = R + r).
  State s;
  for (int k = 0; k < 4; ++k) test::add_sphere(s, Vec3(2e-3 * k, 0, 0), 1e-3, 7900.0);
  SetSelector sel;
  sel.kind = SetSelector::Kind::Cylinder;
  sel.axis_point = Vec3(0, 0, 5e-3);  // any point of the axis
  sel.axis = Vec3(0, 0, -2);          // any non-zero length, either sense
  sel.radius = 3e-3;
  CHECK(select_particles(s, sel) == std::vector<Index>{0, 1});
  sel.overlap = true;
  CHECK(select_particles(s, sel) == std::vector<Index>{0, 1});
  sel.radius = 3.5e-3;  // now x = 4 mm reaches 0.5 mm into it; x = 6 mm does not
  CHECK(select_particles(s, sel) == std::vector<Index>{0, 1, 2});
  sel.overlap = false;
  CHECK(select_particles(s, sel) == std::vector<Index>{0, 1});
  // An axis along x through (0, 0, 0): every centre lies on it, distance 0.
  sel.axis_point = Vec3::Zero();
  sel.axis = Vec3(1, 0, 0);
  CHECK(select_particles(s, sel).size() == 4);
  // A tilted axis: along (1, 1, 0) through the origin, d = x / sqrt(2); R = 2 mm keeps x <= 2.83 mm.
  sel.axis = Vec3(1, 1, 0);
  sel.radius = 2e-3;
  CHECK(select_particles(s, sel) == std::vector<Index>{0, 1});
  sel.axis = Vec3::Zero();
  CHECK_THROWS_AS(select_particles(s, sel), SetupError);
  sel.axis = Vec3::UnitZ();
  sel.radius = 0.0;
  CHECK_THROWS_AS(select_particles(s, sel), SetupError);
}

}  // namespace test_particle_sets
