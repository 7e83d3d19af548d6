// Contact laws: Hertz force and stiffness against closed forms, action = reaction and moment
// balance of the generic pair/wall passes, zero force without overlap, and binary impacts
// (sphere-sphere and sphere-wall) run through Simulation against the closed-form restitution
// and contact duration of the Hertz and linear spring-dashpot models.
#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>
#include <vector>

#include "engine/contact/contact_model.hpp"
#include "engine/simulation.hpp"
#include "physics/contact/contact_kernels.hpp"
#include "physics/contact/hertz_mindlin.hpp"
#include "physics/contact/hooke.hpp"
#include "physics/contact/lammps_granular.hpp"
#include "tests/support/scene.hpp"
#include "tests/support/tolerance.hpp"

namespace test_contact_laws {

using namespace sparkdem;
using namespace sparkdem::physics;
using sparkdem::test::relative_error;

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kR = 1e-3;      // sphere radius [m]
constexpr double kRho = 2500.0;  // density [kg/m^3]
constexpr double kE = 1e8;       // Young's modulus [Pa]
constexpr double kNu = 0.3;

/// E* of two identical bodies, written out independently of the kernel (Johnson eq. 4.22).
double e_star(double E, double nu) { return 1.0 / (2.0 * (1.0 - nu * nu) / E); }

HertzMindlin::Params hm(double e, double mu) { return {kE, kNu, e, mu}; }

/// Static geometry of a contact with overlap delta along +z.
ContactGeometry geometry(double r_eff, double m_eff, double delta) {
  ContactGeometry g;
  g.n = Vec3::UnitZ();
  g.overlap = delta;
  g.r_eff = r_eff;
  g.m_eff = m_eff;
  g.arm_i = g.arm_j = 2.0 * r_eff - 0.5 * delta;
  return g;
}

/// Normal force of a law at rest (no damping contribution, zero history).
template <class Law>
double static_normal_force(const Law& law, const ContactGeometry& g) {
  RelativeMotion m;
  m.v = m.vt = Vec3::Zero();
  m.vn = 0.0;
  double xi[3] = {0.0, 0.0, 0.0};
  return law(g, m, 1e-7, xi).force.dot(g.n);
}

/// Hertz contact duration of an elastic impact at relative normal speed v:
///   t_c = 2 Int_0^1 du / sqrt(1 - u^{5/2}) * (15/16)^{2/5} (m*^2 / (R* E*^2 v))^{1/5}
///       = 2.868 (m*^2 / (R* E*^2 v))^{1/5}   (Johnson, Contact Mechanics, sec. 11.4)
/// with Int = (2/5) B(2/5, 1/2) written through Gamma functions.
double hertz_duration(double m_eff, double r_eff, double es, double v) {
  const double integral = 0.4 * std::tgamma(0.4) * std::tgamma(0.5) / std::tgamma(0.9);
  const double c = 2.0 * integral * std::pow(15.0 / 16.0, 0.4);
  return c * std::pow(m_eff * m_eff / (r_eff * es * es * v), 0.2);
}

/// Linear spring-dashpot: gamma for restitution e and the damped half period.
double lsd_gamma(double e, double m_eff, double k) {
  const double l = std::log(e);
  return 2.0 * std::sqrt(m_eff * k) * (-l) / std::sqrt(kPi * kPi + l * l);
}
double lsd_duration(double e, double m_eff, double k) {
  const double g = lsd_gamma(e, m_eff, k);
  return kPi / std::sqrt(k / m_eff - (g / (2.0 * m_eff)) * (g / (2.0 * m_eff)));
}

struct Impact {
  double restitution;  ///< measured normal restitution
  double duration;     ///< measured contact duration [s] (interpolated overlap zero crossings)
};

/// Head-on impact at normal speed v (sphere-sphere: equal spheres, each moving v/2; sphere-wall:
/// sphere moving at v onto a floor), run through Simulation with step dt for long enough to
/// cover an expected contact duration t_est. No gravity.
Impact impact(const ContactModel& law, bool wall, double v, double dt, double t_est) {
  State s;
  // Contact starts after 20.5 steps: half-way between two steps, so that the onset step does not
  // depend on the rounding of an overlap of exactly zero.
  const double gap = 10.25 * v * dt;
  if (wall) {
    test::add_sphere(s, Vec3(0, 0, kR + 2.0 * gap), kR, kRho, Vec3(0, 0, -v));
    s.walls.push_back(test::plane_wall("floor", Vec3::Zero(), Vec3::UnitZ()));
  } else {
    test::add_sphere(s, Vec3(-kR - gap, 0, 0), kR, kRho, Vec3(0.5 * v, 0, 0));
    test::add_sphere(s, Vec3(kR + gap, 0, 0), kR, kRho, Vec3(-0.5 * v, 0, 0));
  }
  std::vector<double> t, ov;
  test::StepObserver obs([&](const State& st, Step) {
    const auto& p = st.particles;
    t.push_back(st.time);
    if (wall)
      ov.push_back(p.radius[0] - p.position[0].z());
    else
      ov.push_back(p.radius[0] + p.radius[1] - (p.position[0] - p.position[1]).norm());
  });
  Simulation sim(s, law);
  const Step steps = static_cast<Step>(std::ceil((1.5 * t_est + 40.0 * dt) / dt)) + 40;
  sim.run_stage(test::stage(dt, steps), obs);
  const auto& p = s.particles;
  double vrel_after;
  if (wall)
    vrel_after = p.velocity[0].z();
  else {
    const Index a = test::local_index(p, 0), b = test::local_index(p, 1);
    vrel_after = -(p.velocity[a] - p.velocity[b]).x();
  }
  const double on = test::zero_crossing(t, ov, true);
  const double off = test::zero_crossing(t, ov, false, on);
  REQUIRE(std::isfinite(on));
  REQUIRE(std::isfinite(off));
  REQUIRE(ov.back() < 0.0);  // separated at the end: velocities are the free-flight ones
  return {vrel_after / v, off - on};
}

}  // namespace

TEST_CASE("Hertz normal force matches 4/3 E* sqrt(R* delta) delta", "[contact_laws]") {
  // Same formula evaluated two ways: tolerance 1e-12 relative (rounding only).
  // (e = 1 keeps the law's construction cheap; damping does not act at rest anyway.)
  for (double E : {1e6, 1e8, 7e10})
    for (double nu : {0.0, 0.25, 0.45}) {
      const HertzMindlin law({E, nu, 1.0, 0.5});
      const double es = e_star(E, nu);
      CHECK(relative_error(kernel::effective_modulus(E, nu), es) < 1e-12);
      for (double r_eff : {1e-5, 5e-4, 2e-2})
        for (double ratio : {1e-6, 1e-3, 2e-2}) {
          const double delta = ratio * r_eff;
          const double ref = 4.0 / 3.0 * es * std::sqrt(r_eff * delta) * delta;
          CHECK(relative_error(kernel::hertz_force(es, r_eff, delta), ref) < 1e-12);
          CHECK(relative_error(static_normal_force(law, geometry(r_eff, 1e-6, delta)), ref) < 1e-12);
        }
    }
}

TEST_CASE("Hertz and Mindlin stiffnesses match finite differences of the forces", "[contact_laws]") {
  const double es = e_star(kE, kNu);
  const double G = kE / (2.0 * (1.0 + kNu));
  const double g_star = 1.0 / (2.0 * (2.0 - kNu) / G);  // 1/G* = 2 (2 - nu)/G (Mindlin)
  const HertzMindlin law(hm(1.0, 10.0));                // e = 1: no damping in either direction
  for (double ratio : {1e-5, 1e-3, 3e-2}) {
    const double r_eff = 0.5 * kR, delta = ratio * r_eff;
    const ContactGeometry g = geometry(r_eff, 1e-6, delta);
    // Normal: central difference with h = 1e-4 delta; truncation ~ h^2 F'''/6 ~ 1e-9 relative.
    const double h = 1e-4 * delta;
    const double fd = (static_normal_force(law, geometry(r_eff, 1e-6, delta + h)) -
                       static_normal_force(law, geometry(r_eff, 1e-6, delta - h))) /
                      (2.0 * h);
    CHECK(relative_error(law.normal_stiffness(g), fd) < 1e-7);
    CHECK(relative_error(kernel::hertz_stiffness(es, r_eff, delta), 2.0 * es * std::sqrt(r_eff * delta)) < 1e-12);
    // Tangential: a tangential displacement xi = vt dt from zero history (sticking, mu large)
    // gives F_t = -k_t xi exactly; its slope is k_t = 8 G* sqrt(R* delta). Tolerance 1e-9.
    RelativeMotion m;
    const double dt = 1e-7, xi_len = 1e-4 * delta;
    m.vt = Vec3(xi_len / dt, 0, 0);
    m.vn = 0.0;
    m.v = m.vt;
    double xi[3] = {0.0, 0.0, 0.0};
    const ContactForces f = law(g, m, dt, xi);
    CHECK(relative_error(-f.tangential.x() / xi_len, law.tangential_stiffness(g)) < 1e-9);
    CHECK(relative_error(law.tangential_stiffness(g), 8.0 * g_star * std::sqrt(r_eff * delta)) < 1e-12);
    CHECK(xi[0] == Approx(xi_len).epsilon(1e-12));  // history stores the displacement
  }
}

namespace {

/// Two spheres of different sizes in an oblique contact with arbitrary velocities and spins,
/// after a few passes (so the tangential history is non-zero).
struct PairScene {
  ParticleStore p;
  ContactTable t;
  template <class Law>
  void run(const ContactModelT<Law>& law) {
    p.add(Vec3(0.1e-3, -0.2e-3, 0.05e-3), 1.0e-3, 1.0e-5);
    p.add(Vec3(0.1e-3, -0.2e-3, 0.05e-3) + Vec3(0.6, -0.3, 1.1).normalized() * (1.0e-3 + 0.7e-3 - 2e-6), 0.7e-3, 0.4e-5);
    p.velocity[0] = Vec3(0.03, 0.11, -0.02);
    p.velocity[1] = Vec3(-0.05, 0.02, 0.07);
    p.omega[0] = Vec3(40.0, -15.0, 25.0);
    p.omega[1] = Vec3(-10.0, 60.0, 5.0);
    t.set_state_columns(law.state_columns());
    t.rebuild({{{0, 1}}}, p.id, p.size());
    for (int k = 0; k < 5; ++k) law.pair_pass(p, t, 1e-6);
    for (auto& f : p.force) f.setZero();
    for (auto& q : p.torque) q.setZero();
    t.gather(p.force, p.torque);
  }
};

}  // namespace

TEMPLATE_TEST_CASE("Pair and wall forces: action = reaction, zero net moment", "[contact_laws]", HertzMindlin, LinearSpringDashpot,
                   LammpsHertzTsuji) {
  typename TestType::Params params;
  params.friction = 0.3;
  const ContactModelT<TestType> law(params);
  PairScene sc;
  sc.run(law);
  const auto& p = sc.p;
  const double F = p.force[0].norm();
  REQUIRE(F > 0.0);
  REQUIRE(sc.t.state_width() == 3);
  REQUIRE(Vec3(sc.t.state(0)[0], sc.t.state(0)[1], sc.t.state(0)[2]).norm() > 0.0);  // history active
  // Newton's third law: gathered forces are opposite; tolerance 1e-14 |F| (rounding).
  CHECK((p.force[0] + p.force[1]).norm() <= 1e-14 * F);
  // The tangential part is non-trivial (otherwise the moment test below is empty).
  const Vec3 n = (p.position[0] - p.position[1]).normalized();
  CHECK((p.force[0] - p.force[0].dot(n) * n).norm() > 1e-3 * F);
  // Moment balance about the contact point c = x_i - arm_i n (no external moment):
  //   T_i + T_j + (x_i - c) x F_i + (x_j - c) x F_j = 0; tolerance 1e-12 |F| r.
  const double delta = p.radius[0] + p.radius[1] - (p.position[0] - p.position[1]).norm();
  const Vec3 c = p.position[0] - (p.radius[0] - 0.5 * delta) * n;
  const Vec3 m = p.torque[0] + p.torque[1] + (p.position[0] - c).cross(p.force[0]) + (p.position[1] - c).cross(p.force[1]);
  CHECK(m.norm() <= 1e-12 * F * p.radius[0]);

  // Wall: the load reported for the wall is minus the force on the particle (1e-14 relative),
  // and the moment about the contact point vanishes the same way.
  ParticleStore q;
  q.add(Vec3(0.3, -0.2, 1.0e-3 - 3e-6), 1.0e-3, 1.0e-5);
  q.velocity[0] = Vec3(0.05, -0.02, -0.03);
  q.omega[0] = Vec3(20.0, 30.0, -5.0);
  std::vector<Wall> walls{test::plane_wall("floor", Vec3::Zero(), Vec3::UnitZ())};
  const std::vector<std::vector<Index>> cand{{0}};
  WallHistory history;
  history.reset(3, walls.size());
  history.follow(cand, q.id);
  WallLoads loads;
  for (int k = 0; k < 5; ++k) {
    q.force[0].setZero();
    q.torque[0].setZero();
    loads = law.wall_pass(q, walls, cand, history, 1e-6);
  }
  const double Fw = q.force[0].norm();
  REQUIRE(Fw > 0.0);
  CHECK((loads.force[0] + q.force[0]).norm() <= 1e-14 * Fw);
  CHECK(loads.normal[0] == Approx(q.force[0].z()).epsilon(1e-14));
  const Vec3 cw(q.position[0].x(), q.position[0].y(), 0.0);
  const Vec3 mw = q.torque[0] + (q.position[0] - cw).cross(q.force[0]);
  // The wall takes -F at c, so the particle's own moment about c must vanish: 1e-12 |F| r.
  CHECK(mw.norm() <= 1e-12 * Fw * q.radius[0]);
}

TEMPLATE_TEST_CASE("Zero or negative overlap gives zero force and clears the history", "[contact_laws]", HertzMindlin, LinearSpringDashpot,
                   LammpsHertzTsuji) {
  typename TestType::Params params;
  const ContactModelT<TestType> law(params);
  for (double gap : {0.0, 1e-9, 1e-4}) {  // exactly touching, a tiny gap, a clear gap
    ParticleStore p;
    p.add(Vec3::Zero(), 1e-3, 1e-5);
    p.add(Vec3(1e-3 + 0.5e-3 + gap, 0, 0), 0.5e-3, 2e-6);
    p.velocity[0] = Vec3(-0.2, 0.3, 0.1);  // moving apart and sliding (damping would act if touching)
    p.omega[1] = Vec3(0.0, 0.0, 50.0);
    ContactTable t;
    t.set_state_columns(law.state_columns());
    t.rebuild({{{0, 1}}}, p.id, p.size());
    for (int k = 0; k < 3; ++k) t.state(0)[k] = 1e-6;  // stale history must be cleared
    law.pair_pass(p, t, 1e-6);
    t.gather(p.force, p.torque);
    // Exact zeros (no arithmetic happens outside contact).
    CHECK(p.force[0].norm() == 0.0);
    CHECK(p.force[1].norm() == 0.0);
    CHECK(p.torque[0].norm() == 0.0);
    CHECK(p.torque[1].norm() == 0.0);
    CHECK(t.overlap()[0] == Approx(-gap).margin(1e-18));
    for (int k = 0; k < 3; ++k) CHECK(t.state(0)[k] == 0.0);
  }
  CHECK(kernel::hertz_force(1e8, 1e-3, 0.0) == 0.0);
}

TEST_CASE("Head-on impact of equal spheres, Hertz e = 1: restitution and duration", "[contact_laws][impact]") {
  const double m = test::sphere_mass(kR, kRho), m_eff = 0.5 * m, r_eff = 0.5 * kR;
  const ContactModelT<HertzMindlin> law(hm(1.0, 0.0));
  for (double v : {0.2, 2.0}) {
    const double tc = hertz_duration(m_eff, r_eff, e_star(kE, kNu), v);
    const Impact im = impact(law, false, v, tc / 200.0, tc);
    INFO("v = " << v << " t_c = " << tc << " measured " << im.duration << " e = " << im.restitution);
    // Tolerances (issue): restitution 1 within 1 %, duration within 1 % of the Hertz closed form.
    CHECK(relative_error(im.restitution, 1.0) < 0.01);
    CHECK(relative_error(im.duration, tc) < 0.01);
    WARN("pair Hertz e=1 v=" << v << ": restitution error " << relative_error(im.restitution, 1.0) << ", duration error "
                             << relative_error(im.duration, tc));
  }
}

TEST_CASE("Head-on impact of equal spheres, Hertz-Mindlin e = 0.5, 0.8: calibrated restitution", "[contact_laws][impact]") {
  const double m = test::sphere_mass(kR, kRho), m_eff = 0.5 * m, r_eff = 0.5 * kR;
  for (double e : {0.5, 0.8}) {
    const ContactModelT<HertzMindlin> law(hm(e, 0.0));
    for (double v : {0.2, 2.0}) {
      // The elastic t_c sets the step (dt = t_c / 200); damping lengthens the contact by ~10 %.
      const double tc = hertz_duration(m_eff, r_eff, e_star(kE, kNu), v);
      const Impact im = impact(law, false, v, tc / 200.0, 1.5 * tc);
      INFO("e = " << e << " v = " << v << " measured e = " << im.restitution);
      // Tolerance (issue): measured restitution within 1 % of the requested one, at both speeds.
      CHECK(relative_error(im.restitution, e) < 0.01);
      WARN("pair Hertz e=" << e << " v=" << v << ": restitution error " << relative_error(im.restitution, e));
    }
  }
}

TEST_CASE("Head-on impact of equal spheres, linear spring-dashpot: restitution and duration", "[contact_laws][impact]") {
  const double m = test::sphere_mass(kR, kRho), m_eff = 0.5 * m;
  const double k = 2e3;  // [N/m]
  for (double e : {0.5, 0.9}) {
    LinearSpringDashpot::Params lp;
    lp.normal_stiffness = k;
    lp.restitution = e;
    lp.friction = 0.0;
    const ContactModelT<LinearSpringDashpot> law(lp);
    const double tc = lsd_duration(e, m_eff, k);
    for (double v : {0.2, 2.0}) {
      const Impact im = impact(law, false, v, tc / 200.0, tc);
      INFO("e = " << e << " v = " << v << " t_c = " << tc << " measured " << im.duration << ", e " << im.restitution);
      // Tolerances (issue): restitution within 1 %, duration pi / sqrt(k/m* - (gamma/2m*)^2) within 1 %.
      CHECK(relative_error(im.restitution, e) < 0.01);
      CHECK(relative_error(im.duration, tc) < 0.01);
      WARN("pair LSD e=" << e << " v=" << v << ": restitution error " << relative_error(im.restitution, e) << ", duration error "
                         << relative_error(im.duration, tc));
    }
  }
}

TEST_CASE("Sphere-wall bounce: restitution and duration with R* = r, m* = m", "[contact_laws][impact]") {
  const double m = test::sphere_mass(kR, kRho);
  const double v = 0.5;
  SECTION("Hertz, e = 1 and e = 0.5") {
    const double tc = hertz_duration(m, kR, e_star(kE, kNu), v);
    for (double e : {1.0, 0.5}) {
      const ContactModelT<HertzMindlin> law(hm(e, 0.0));
      const Impact im = impact(law, true, v, tc / 200.0, 1.5 * tc);
      INFO("e = " << e << " t_c = " << tc << " measured " << im.duration << ", e " << im.restitution);
      // Tolerances (issue): restitution within 1 %; elastic duration within 1 % of the closed form.
      CHECK(relative_error(im.restitution, e) < 0.01);
      if (e == 1.0) CHECK(relative_error(im.duration, tc) < 0.01);
      WARN("wall Hertz e=" << e << ": restitution error " << relative_error(im.restitution, e) << ", duration error vs elastic "
                           << relative_error(im.duration, tc));
    }
  }
  SECTION("linear spring-dashpot, e = 0.7") {
    LinearSpringDashpot::Params lp;
    lp.normal_stiffness = 2e3;
    lp.restitution = 0.7;
    lp.friction = 0.0;
    const ContactModelT<LinearSpringDashpot> law(lp);
    const double tc = lsd_duration(0.7, m, lp.normal_stiffness);
    const Impact im = impact(law, true, v, tc / 200.0, tc);
    // Tolerances (issue): restitution and duration within 1 %.
    CHECK(relative_error(im.restitution, 0.7) < 0.01);
    CHECK(relative_error(im.duration, tc) < 0.01);
    WARN("wall LSD e=0.7: restitution error " << relative_error(im.restitution, 0.7) << ", duration error "
                                              << relative_error(im.duration, tc));
  }
}

}  // namespace test_contact_laws
