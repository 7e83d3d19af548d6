/// Stage mass scaling: `mass_scaling` multiplies every mass and inertia during the stage, and
/// `mass_floor_radius` (density scaling of the fines) gives every smaller particle the mass of a
/// sphere of that radius and its own density on top; both are undone at the stage end.
/// Checked exactly: masses inside the stage against the closed form, momentum conserved by the
/// scaled dynamics (action = reaction), masses and inertias restored after the stage.
#include <catch2/catch.hpp>

#include <cmath>

#include "engine/contact/contact_model.hpp"
#include "engine/simulation.hpp"
#include "physics/contact/hooke.hpp"
#include "support/scene.hpp"

namespace test_mass_scaling {

using namespace sparkdem;

TEST_CASE("mass_scaling and mass_floor_radius scale the fines during the stage and are undone after it", "[mass_scaling]") {
  constexpr double kRho = 2500.0, kPi = 3.14159265358979323846;
  State s;
  test::add_sphere(s, Vec3(0, 0, 0), 1e-3, kRho, Vec3(0.01, 0, 0));        // fine
  test::add_sphere(s, Vec3(3.9e-3, 0, 0), 3e-3, kRho, Vec3(-0.01, 0, 0));  // coarse, overlapping the fine
  const std::vector<double> m0 = s.particles.mass, i0 = s.particles.inertia;
  physics::LinearSpringDashpot::Params hp;
  hp.normal_stiffness = 1e3;
  const ContactModelT<physics::LinearSpringDashpot> law(hp);
  Simulation sim(s, law);
  StageConfig cfg = test::stage(1e-5, 50, 1e-3);
  cfg.mass_scaling = 10.0;
  cfg.mass_floor_radius = 2e-3;
  const double m_floor = 10.0 * kRho * 4.0 / 3.0 * kPi * 8e-9;
  const Vec3 p0 = m_floor * Vec3(0.01, 0, 0) + 10.0 * m0[1] * Vec3(-0.01, 0, 0);  // momentum in the stage's masses
  int seen = 0;
  test::StepObserver obs([&](const State& st, Step) {
    const auto& p = st.particles;
    CHECK(p.mass[0] == Approx(m_floor).epsilon(1e-14));
    CHECK(p.inertia[0] == Approx(i0[0] * m_floor / m0[0]).epsilon(1e-14));
    CHECK(p.mass[1] == Approx(10.0 * m0[1]).epsilon(1e-14));
    const Vec3 mom = p.mass[0] * p.velocity[0] + p.mass[1] * p.velocity[1];
    CHECK((mom - p0).norm() <= 1e-12 * p0.norm() + 1e-18);
    ++seen;
  });
  sim.run_stage(cfg, obs);
  CHECK(seen == 50);
  for (std::size_t i = 0; i < 2; ++i) {
    CHECK(s.particles.mass[i] == Approx(m0[i]).epsilon(1e-14));
    CHECK(s.particles.inertia[i] == Approx(i0[i]).epsilon(1e-14));
  }
  CHECK_FALSE(s.particles.fields.has("mass_factor"));

  // A state saved inside a scaled stage (a snapshot) carries the factors with scaled masses: the
  // next stage starts from the true masses, whatever its own scaling.
  auto& p = s.particles;
  p.fields.declare(FieldInfo{"mass_factor", 1, "1", 1.0, false}, p.size());
  p.fields.data("mass_factor") = {7.0, 3.0};
  p.mass[0] *= 7.0;
  p.inertia[0] *= 7.0;
  p.mass[1] *= 3.0;
  p.inertia[1] *= 3.0;
  StageConfig plain = test::stage(1e-5, 1, 1e-3);
  test::StepObserver check([&](const State& st, Step) {
    for (std::size_t i = 0; i < 2; ++i) CHECK(st.particles.mass[i] == Approx(m0[i]).epsilon(1e-14));
  });
  sim.run_stage(plain, check);
  CHECK_FALSE(p.fields.has("mass_factor"));
}

}  // namespace test_mass_scaling
