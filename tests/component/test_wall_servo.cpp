/// Pressure-controlled wall (hot-press punch): the servo drives the punch until the force of the
/// particles on it equals the target pressure times the loaded area.
#include <catch2/catch.hpp>

#include <cmath>
#include <map>

#include "engine/state/particle_set.hpp"
#include "physics/contact/hertz_mindlin.hpp"
#include "support/scene.hpp"

namespace test_wall_servo {

using namespace sparkdem;

namespace {
/// One frozen sphere (r = 1 mm, set "all") on a floor under a punch plane at height z_punch [m],
/// and the Hertz law (E = 1 GPa) of the servo tests.
ContactModelT<physics::HertzMindlin> frozen_sphere_under_punch(State& s, double z_punch) {
  test::add_sphere(s, Vec3(0, 0, 1e-3), 1e-3, 2500.0);
  s.walls.push_back(test::plane_wall("floor", Vec3::Zero(), Vec3::UnitZ()));
  s.walls.push_back(test::plane_wall("punch", Vec3(0, 0, z_punch), -Vec3::UnitZ()));
  SetSelector all;
  all.kind = SetSelector::Kind::Ids;
  all.ids = {0};
  assign_set(s, "all", all);
  physics::HertzMindlin::Params lp;
  lp.youngs_modulus = 1e9;
  return ContactModelT<physics::HertzMindlin>(lp);
}
}  // namespace

TEST_CASE("a pressure-controlled punch settles on its target force", "[walls]") {
  // One frozen sphere (r = 1 mm) on a floor; a punch starts 0.1 mm above it and is driven to
  // p = 1e5 Pa over A = 1e-6 m^2, i.e. F = 0.1 N. Servo: u_dot = v_max (F_t - F)/F_t.
  // At rest the punch force must equal F_t within 0.5 % (the servo's steady state is exact; the
  // band covers the residual oscillation of the undamped servo loop at the end of the run).
  State s;
  const auto law = frozen_sphere_under_punch(s, 2.1e-3);
  Simulation sim(s, law);
  StageConfig cfg = test::stage(1e-6, 40000, 1e-4);
  cfg.prescribed_sets["all"] = PrescribedMotion{};
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
  // Its work is that of the applied load, p A (u - u_start), whatever the servo's jitter (to rounding).
  CHECK(punch.work == Approx(0.1 * (punch.u - punch.u_start)).epsilon(1e-12));
  // Action = reaction: the force of the sphere on the punch is minus the contact force on the
  // (frozen, untouched-by-the-floor) sphere, to rounding (1e-12 relative).
  CHECK((s.particles.force[0] + punch.force).norm() <= 1e-12 * punch.force.norm());
}

TEST_CASE("wall tables in physical time are read at time_scale x stage time", "[walls]") {
  // Displacement table D = {0 s: 0, 10 s: 1 mm} (physical) with time_scale 100: at stage time
  // 0.05 s (5 physical seconds) u = u_start + 0.5 mm and u_dot = 1 mm / 0.1 s = 0.01 m/s
  // (mechanical rate), to rounding. The same table in mechanical time (physical_time = false,
  // the generators' own motions) is read at 0.05 s.
  Wall w = test::plane_wall("punch", Vec3::Zero(), Vec3::UnitZ());
  w.u_start = 2e-3;
  w.motion.kind = WallMotion::Kind::Table;
  w.motion.table_time = {0.0, 10.0};
  w.motion.table_disp = {0.0, 1e-3};
  w.motion.physical_time = true;
  advance_wall(w, 0.05, 1e-4, 0.0, 100.0);
  CHECK(w.u == Approx(2.5e-3).epsilon(1e-14));
  CHECK(w.u_dot == Approx(0.01).epsilon(1e-9));
  w.motion.physical_time = false;
  advance_wall(w, 0.05, 1e-4, 0.0, 100.0);
  CHECK(w.u == Approx(2e-3 + 0.005e-3).epsilon(1e-14));
  // Pressure servo: u_dot = v_max (F_t - F) / F_t with F_t = p(s t) A; with F = 0.5 N,
  // p = {0 s: 0, 50 s: 1e5 Pa}, A = 1e-5 m^2, s = 1000, t = 0.025 s: F_t = 0.5 N -> u_dot = 0;
  // at t = 0.0125 s: F_t = 0.25 N -> u_dot = -v_max.
  Wall q = test::plane_wall("top", Vec3::Zero(), -Vec3::UnitZ());
  q.motion.kind = WallMotion::Kind::Pressure;
  q.motion.pressure_time = {0.0, 50.0};
  q.motion.pressure_value = {0.0, 1e5};
  q.motion.area = 1e-5;
  q.motion.max_speed = 0.02;
  q.motion.physical_time = true;
  q.normal_force = 0.5;
  advance_wall(q, 0.025, 1e-6, 0.0, 1000.0);
  CHECK(std::abs(q.u_dot) <= 1e-12);
  advance_wall(q, 0.0125, 1e-6, 0.0, 1000.0);
  CHECK(q.u_dot == Approx(-0.02).epsilon(1e-12));
}

TEST_CASE("a pressure ramp in physical time reaches its target at time_scale x the mechanical time", "[walls]") {
  // The frozen sphere of the test above under a punch with p = {0 s: 0, 50 s: 1e5 Pa, held}
  // (physical), A = 1e-6 m^2 (F_final = 0.1 N) in a stage with time_scale = 1000: the ramp ends
  // at mechanical time 0.05 s. The punch force tracks the ramp (servo lag ~1e-3 relative, see
  // below), so it first reaches 98 % of F_final at 0.98 x 0.05 s = 0.049 s; we accept
  // [0.048, 0.051] s. (Read in mechanical time the same table would give 0.1 % of the force.)
  // Along the ramp the force equals F_final t / 0.05 s within 2 % at 0.02, 0.03, 0.04 s, and
  // 0.1 N within 0.5 % at the end (0.06 s). Lag: with contact stiffness k ~ 5e4 N/m and v_max =
  // 0.05 m/s the proportional servo trails a ramp of rate R = 2 N/s by a relative R / (k v_max).
  State s;
  const auto law = frozen_sphere_under_punch(s, 2.05e-3);
  Simulation sim(s, law);
  StageConfig cfg = test::stage(1e-6, 60000, 1e-4);
  cfg.time_scale = 1000.0;
  cfg.prescribed_sets["all"] = PrescribedMotion{};
  WallMotion m;
  m.kind = WallMotion::Kind::Pressure;
  m.pressure_time = {0.0, 50.0};
  m.pressure_value = {0.0, 1e5};
  m.area = 1e-6;
  m.max_speed = 0.05;
  m.physical_time = true;
  cfg.motions["punch"] = m;
  double t98 = -1.0;
  std::map<Step, double> force;
  test::StepObserver obs([&](const State& st, Step k) {
    const double F = st.walls[1].normal_force;
    if (t98 < 0.0 && F >= 0.98 * 0.1) t98 = static_cast<double>(k) * 1e-6;
    if (k % 10000 == 0) force[k] = F;
  });
  sim.run_stage(cfg, obs);
  INFO("98 % of the final force first reached at mechanical t = " << t98 << " s");
  CHECK(t98 >= 0.048);
  CHECK(t98 <= 0.051);
  for (Step k : {20000, 30000, 40000}) {
    INFO("t = " << k * 1e-6 << " s: F = " << force.at(k) << " N");
    CHECK(force.at(k) == Approx(0.1 * (static_cast<double>(k) * 1e-6) / 0.05).epsilon(0.02));
  }
  CHECK(force.at(60000) == Approx(0.1).epsilon(5e-3));
}

TEST_CASE("a plane placed at a clearance above a packing touches its highest sphere", "[walls]") {
  // Spheres whose tops are at z = 1.0, 2.5 and 1.9 mm; a punch (normal -z) placed with
  // clearance 0.1 mm must end 0.1 mm above the highest top, z = 2.6 mm, whatever its point was;
  // a floor (normal +z) with clearance 0 touches the lowest bottom, z = 0.
  const std::vector<Vec3> x = {Vec3(0, 0, 0.5e-3), Vec3(1e-3, 0, 2.0e-3), Vec3(0, 2e-3, 1.6e-3)};
  const std::vector<double> r = {0.5e-3, 0.5e-3, 0.3e-3};
  Wall punch = test::plane_wall("punch", Vec3(5, 5, 40e-3), -Vec3::UnitZ());
  place_plane_at_clearance(punch, x, r, 0.1e-3);
  CHECK(std::get<PlaneShape>(punch.shape).point.z() == Approx(2.6e-3).epsilon(1e-12));
  Wall floor = test::plane_wall("floor", Vec3(0, 0, -7e-3), Vec3::UnitZ());
  place_plane_at_clearance(floor, x, r, 0.0);
  CHECK(std::abs(std::get<PlaneShape>(floor.shape).point.z()) < 1e-15);
}

TEST_CASE("wall work: a punch squeezing a frozen sphere does the Hertz energy it stores", "[walls]") {
  // The frozen sphere of the tests above (r = 1 mm on the floor; restitution 1: no damping) and a
  // punch starting at its top moving down 10 um at 1 mm/s: the punch's work sum F_n du
  // (wall_<name>_work) equals the elastic energy of the punch contact, int F d delta = 2/5 F delta
  // for Hertz (F ~ delta^(3/2); the sphere is frozen, so the floor does no work), within the
  // first-order error of the left sum: 1.5 du / delta = 0.075 % at 2000 steps (band 0.3 %).
  State s;
  (void)frozen_sphere_under_punch(s, 2e-3);
  physics::HertzMindlin::Params lp;
  lp.youngs_modulus = 1e9;
  lp.restitution = 1.0;
  const ContactModelT<physics::HertzMindlin> law(lp);
  Simulation sim(s, law);
  StageConfig cfg = test::stage(5e-6, 2000, 1e-4);
  cfg.prescribed_sets["all"] = PrescribedMotion{};
  WallMotion m;
  m.kind = WallMotion::Kind::Velocity;
  m.speed = 1e-3;
  cfg.motions["punch"] = m;
  test::NullObserver obs;
  sim.run_stage(cfg, obs);
  const Wall& punch = *s.find_wall("punch");
  const double delta = punch.u, energy = 0.4 * punch.normal_force * delta;
  INFO("punch travel " << delta << " m, work " << punch.work << " J, Hertz energy " << energy << " J");
  CHECK(delta == Approx(1e-5).epsilon(1e-9));
  CHECK(punch.work == Approx(energy).epsilon(3e-3));
  CHECK(s.find_wall("floor")->work == 0.0);
}

}  // namespace test_wall_servo
