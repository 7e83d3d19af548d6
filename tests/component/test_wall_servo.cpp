/// Pressure-controlled wall (hot-press punch): the servo drives the punch until the force of the
/// particles on it equals the target pressure times the loaded area.
#include <catch2/catch.hpp>

#include "engine/state/particle_set.hpp"
#include "physics/contact/hertz_mindlin.hpp"
#include "support/scene.hpp"

using namespace sparkdem;

TEST_CASE("a pressure-controlled punch settles on its target force", "[walls]") {
  // One frozen sphere (r = 1 mm) on a floor; a punch starts 0.1 mm above it and is driven to
  // p = 1e5 Pa over A = 1e-6 m^2, i.e. F = 0.1 N. Servo: u_dot = v_max (F_t - F)/F_t.
  // At rest the punch force must equal F_t within 0.5 % (the servo's steady state is exact; the
  // band covers the residual oscillation of the undamped servo loop at the end of the run).
  State s;
  test::add_sphere(s, Vec3(0, 0, 1e-3), 1e-3, 2500.0);
  s.walls.push_back(test::plane_wall("floor", Vec3::Zero(), Vec3::UnitZ()));
  s.walls.push_back(test::plane_wall("punch", Vec3(0, 0, 2.1e-3), -Vec3::UnitZ()));
  SetSelector all;
  all.kind = SetSelector::Kind::Ids;
  all.ids = {0};
  assign_set(s, "all", all);
  physics::HertzMindlin::Params lp;
  lp.youngs_modulus = 1e9;
  ContactModelT<physics::HertzMindlin> law(lp);
  Simulation sim(s, law);
  StageConfig cfg = test::stage(1e-6, 40000, 1e-4);
  cfg.prescribed_sets["all"] = Vec3::Zero();
  WallMotion m;
  m.kind = WallMotion::Kind::Pressure;
  m.pressure_time = {0.0, 1.0};
  m.pressure_value = {1e5, 1e5};
  m.area = 1e-6;
  m.max_speed = 0.05;
  cfg.motions["punch"] = m;
  test::NullObserver obs;
  sim.run_stage(cfg, obs);
  const Wall& punch = *s.find_wall("punch");
  CHECK(punch.normal_force == Approx(0.1).epsilon(5e-3));
  // Action = reaction: the force of the sphere on the punch is minus the contact force on the
  // (frozen, untouched-by-the-floor) sphere, to rounding (1e-12 relative).
  CHECK((s.particles.force[0] + punch.force).norm() <= 1e-12 * punch.force.norm());
}
