// Extreme sintering cases (issue 9; docs/extreme_cases.md).
//
//  S1 a sintering contact at zero neck radius: the dashpot eta = pi a^4 / (8 D_eff) vanishes;
//     the Maxwell update must take its limit (F -> 0, the dashpot takes the motion), never NaN.
//  S2 a neck larger than the smaller particle (a = 3 r_min, as a state from another law or an
//     old snapshot, and the Coble / constant-volume neck of a deep overlap): capped at r_min in
//     the law and in the electrical conductance, finite.
//  S3 0.99 of the melting point (NiAl, T_m = 1955 K) with the Arrhenius grain-boundary
//     diffusion: the free pair's neck growth follows dh/dt = F_s / eta within 5 % and stops at
//     the equilibrium neck.
#include <catch2/catch.hpp>

#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "engine/contact/contact_model.hpp"
#include "engine/simulation.hpp"
#include "physics/contact/sintering.hpp"
#include "physics/electrical/conductance_kernels.hpp"
#include "physics/electrical/branch_models.hpp"
#include "engine/graph/interaction_graph.hpp"
#include "engine/neighbor/neighbor_search.hpp"
#include "tests/extreme/extreme_figures.hpp"
#include "tests/support/nial_sintering.hpp"
#include "tests/support/scene.hpp"

namespace test_extreme_sintering {

using namespace sparkdem;
using physics::Sintering;
namespace kernel = physics::kernel;

namespace {
/// NiAl (configs/materials/nial_sintering.json).
Sintering::Params nial() { return test_support::nial_sintering(); }
constexpr double kTm = 1955.0, kRho = 5900.0;
/// S3: physical seconds per mechanical second and steps (the late stage, eta ~ a^4, takes ~1 s).
constexpr double kTimeScale = 2e5;
constexpr Step kSteps = 300000;
}  // namespace

TEST_CASE("extreme S1: sintering contact at zero neck radius - the Maxwell update takes its eta -> 0 limit, never NaN",
          "[extreme][sintering]") {
  // Expectation: kernel at eta = 0: F' = 0 and du = v dt + F/k exactly (the limit of the exact
  // exponential update; before this case it returned NaN: 0 x inf). The law on a hot pair at
  // overlap 0, 1e-300 m and 1e-15 r: finite forces; no neck at 0, a neck of at least
  // min_neck_fraction r_min otherwise; the first step's Maxwell force equals k v dt phi(x)
  // (relative 1e-12) with eta from that neck.
  const auto z = kernel::maxwell_step(5.0, 2e4, 0.0, 0.7, 1e-6);
  CHECK(z.force == 0.0);
  CHECK(z.flow == Approx(0.7e-6 + 5.0 / 2e4).epsilon(1e-15));
  const auto z0 = kernel::maxwell_step(5.0, 0.0, 0.0, 0.7, 1e-6);
  CHECK(std::isfinite(z0.flow));
  const auto f0 = kernel::maxwell_factors(2e4, 0.0, 1e-6);
  CHECK(f0.decay == 0.0);
  CHECK(f0.phi == 0.0);
  // Continuity: eta -> 0+ tends to the eta = 0 values.
  const auto tiny = kernel::maxwell_step(5.0, 2e4, 1e-30, 0.7, 1e-6);
  CHECK(tiny.force < 1e-20);
  CHECK(tiny.flow == Approx(z.flow).epsilon(1e-12));
  CHECK(kernel::neck_viscosity(0.0, 1e-27) == 0.0);

  Sintering::Params p = nial();
  p.min_neck_fraction = 1e-6;  // the smallest allowed
  p.temperature = 1600.0;
  const Sintering law(p);
  const double r = 1e-6;
  int finite = 0;
  for (double h : {0.0, 1e-300, 1e-15 * r, 1e-9 * r}) {
    ContactGeometry g;
    g.n = Vec3::UnitX();
    g.r_i = g.r_j = r;
    g.r_eff = 0.5 * r;
    g.m_eff = 0.5 * test::sphere_mass(r, kRho);
    g.temperature = 1600.0;
    g.time_scale = 1.0;
    g.overlap = h;
    RelativeMotion m;
    m.vn = -1e-3;  // approaching
    m.v = m.vn * g.n;
    m.vt = Vec3::Zero();
    std::vector<double> st(Sintering::state_columns().size(), 0.0);
    const double dt = 1e-10;
    const ContactForces f = law(g, m, dt, st.data());
    INFO("overlap " << h << " m: force " << f.force.transpose() << ", neck " << st[Sintering::kNeck]);
    finite += f.force.allFinite() && std::isfinite(st[Sintering::kViscous]);
    if (h == 0.0) {
      CHECK(st[Sintering::kNeck] == 0.0);
      CHECK(f.force.norm() == 0.0);
      continue;
    }
    const double a = st[Sintering::kNeck];
    CHECK(a >= 1e-6 * r);
    const double eta = law.viscosity(a, 1600.0);
    const double kn = 2.0 * law.params().youngs_modulus / (2 * (1 - 0.31 * 0.31)) * std::sqrt(g.r_eff * h);
    const auto mf = kernel::maxwell_factors(kn, eta, dt);
    CHECK(st[Sintering::kElastic] == Approx(kn * 1e-3 * dt * mf.phi).epsilon(1e-12).margin(1e-300));
  }
  CHECK(finite == 4);
  // A dynamic run from exact touching (h = 0) with an approach velocity: the neck forms at
  // contact and sinters; no NaN in 20,000 steps (the watchdog would stop the run otherwise).
  State s;
  test::add_sphere(s, Vec3(-r, 0, 0), r, kRho, Vec3(1e-3, 0, 0));
  test::add_sphere(s, Vec3(r, 0, 0), r, kRho, Vec3(-1e-3, 0, 0));
  const ContactModelT<Sintering> cl(p);
  Simulation sim(s, cl);
  test::NullObserver none;
  StageConfig c = test::stage(0.0, 20000, 0.2 * r);
  c.dt_fraction = 0.3;
  sim.run_stage(c, none);
  REQUIRE(s.contacts.size() == 1);
  const double h_end = 2 * r - (s.particles.position[0] - s.particles.position[1]).norm();
  CHECK(std::isfinite(h_end));
  CHECK(h_end > 0.0);
  CHECK(s.contacts.state(0)[Sintering::kNeck] >= 1e-6 * r);
  EXTREME_FIGURE("S1 zero neck radius", "finite evaluations at h = 0 .. 1e-9 r", finite, "of 4");
  EXTREME_FIGURE("S1 zero neck radius", "overlap after 20000 steps from touching", h_end / r, "r");
}

TEST_CASE("extreme S2: a neck larger than the smaller particle is capped at r_min in the law and the conductance", "[extreme][sintering]") {
  // Expectation: a small sphere (r) on a large one (10 r) with a neck state of 3 r: after one
  // step the neck is r (the cap) and the force finite; the Coble neck of a deep overlap exceeds
  // r (the kernel does not cap: documented), the constant-volume neck returns exactly r; the
  // sintered-neck branch of such a pair (Coble neck, no grain-boundary-fraction correction) has
  // the conductance of a = r (relative 1e-14; before this case it took the uncapped 1.8 r).
  const double r = 1e-6, R = 10 * r;
  Sintering::Params p = nial();
  p.temperature = 1600.0;
  const Sintering law(p);
  ContactGeometry g;
  g.n = Vec3::UnitX();
  g.r_i = r;
  g.r_j = R;
  g.r_eff = r * R / (r + R);
  g.m_eff = test::sphere_mass(r, kRho) * test::sphere_mass(R, kRho) / (test::sphere_mass(r, kRho) + test::sphere_mass(R, kRho));
  g.temperature = 1600.0;
  g.time_scale = 1.0;
  g.overlap = 0.9 * r;
  RelativeMotion m;
  m.vn = 0.0;
  m.v = Vec3::Zero();
  m.vt = Vec3::Zero();
  std::vector<double> st(Sintering::state_columns().size(), 0.0);
  st[Sintering::kNeck] = 3.0 * r;
  const ContactForces f = law(g, m, 1e-10, st.data());
  CHECK(st[Sintering::kNeck] == r);
  CHECK(f.force.allFinite());
  const double coble = physics::electrical::coble_neck_radius(r, R, 0.9 * r);
  const double cv = physics::electrical::cv_neck_radius(r, R, 1.5 * r);
  CHECK(coble > r);
  CHECK(cv == r);
  // The kernel leaves the cap to its caller (a = 3 r gives more than a = r through the large
  // particle's hemisphere); the branch model must cap: a pair overlapping by 0.9 r with the
  // Coble neck (1.8 r) and no grain-boundary-fraction correction gets the conductance of a = r.
  using physics::electrical::GrainBoundaryLayer;
  using physics::electrical::HemisphereLaw;
  const double kappa = 1e6;
  const double g_cap = physics::electrical::sintered_neck_conductance(HemisphereLaw::reading_a(), GrainBoundaryLayer::none(), kappa, kappa,
                                                                      r, R, r);
  State two;
  test::add_sphere(two, Vec3(0, 0, 0), r, kRho);
  test::add_sphere(two, Vec3(r + R - 0.9 * r, 0, 0), R, kRho);
  two.contacts.rebuild(find_pairs(two.particles.position, two.particles.radius, 0.0), two.particles.id, two.particles.size());
  const InteractionGraph graph = build_interaction_graph(two, GraphOptions{});
  REQUIRE(graph.size() == 1);
  physics::BranchModel bm;
  bm.model = "sintered_neck";
  bm.neck = "coble";
  bm.gbf_correction = false;
  std::vector<double> share;
  const std::vector<double> gb = physics::branch_conductances(bm, two, graph, std::vector<double>(1, kappa), share);
  INFO("branch " << gb[0] << " S, capped neck " << g_cap << " S");
  CHECK(std::isfinite(gb[0]));
  CHECK(std::abs(gb[0] - g_cap) <= 1e-14 * g_cap);
  // corrected_neck_radii caps every neck at the smaller particle.
  const std::vector<Index> ea{0}, eb{1};
  const std::vector<double> a{3 * r}, radii{r, R};
  const auto corr = physics::electrical::corrected_neck_radii(ea, eb, a, radii);
  CHECK(corr[0] <= r);
  EXTREME_FIGURE("S2 neck > smaller particle", "neck after one step / r_min (state 3 r_min)", st[Sintering::kNeck] / r, "");
  EXTREME_FIGURE("S2 neck > smaller particle", "Coble neck at h = 0.9 r_min / r_min (uncapped)", coble / r, "");
}

TEST_CASE(
    "extreme S3: sintering at 0.99 of the melting point - Arrhenius neck growth follows the closed form, stops at "
    "the equilibrium neck",
    "[extreme][sintering]") {
  // Expectation: two free NiAl spheres (r = 1 um) at T = 0.99 T_m = 1935 K (time scale 2e5: the
  // late stage, eta ~ a^4, takes about a physical second): D_gb is exp(Q/R (1/T_1 - 1/T_2)) = 3.7e3 x the value at 0.6 T_m; the rate
  // dh/dt = F_s(a) / eta(a) of the closed form holds within 5 % on the growth phase, the neck
  // only grows and stops at a_eq = r sin(psi/2) (frozen, relative 1e-3), and nothing is NaN.
  const double r = 1e-6, T = 0.99 * kTm;
  Sintering::Params p = nial();
  p.temperature = T;
  p.min_neck_fraction = 0.01;
  const Sintering law(p);
  auto neck_of = [&](double h) { return 1.43 * std::sqrt(r * r - (r - 0.5 * h) * (r - 0.5 * h)); };
  const double d_eff = kernel::gb_effective_diffusivity(p.gb_diffusivity_prefactor, p.gb_activation_energy, p.gb_width, p.atomic_volume, T);
  auto rate = [&](double h) {
    const double a = neck_of(h);
    const double eta = std::numbers::pi * std::pow(a, 4) / (8.0 * d_eff);
    const double fs = std::numbers::pi * p.surface_energy *
                      (4.0 * r * (1.0 - std::cos(0.5 * p.dihedral_angle)) + a * std::sin(0.5 * p.dihedral_angle));
    return fs / eta;
  };
  const double arrhenius = std::exp(p.gb_activation_energy / kernel::kGasConstant * (1.0 / (0.6 * kTm) - 1.0 / T));
  State s;
  const double h0 = 0.002 * r;
  test::add_sphere(s, Vec3(-(r - 0.5 * h0), 0, 0), r, kRho);
  test::add_sphere(s, Vec3(r - 0.5 * h0, 0, 0), r, kRho);
  const ContactModelT<Sintering> cl(p);
  Simulation sim(s, cl);
  const double a_eq = r * std::sin(0.5 * p.dihedral_angle);
  const double time_scale = kTimeScale;
  double worst_rate = 0.0, prev_a = 0.0, t_eq = -1.0;
  int samples = 0, monotone = 1, growth_samples = 0;
  test::StepObserver obs([&](const State& st, Step) {
    const auto& q = st.particles;
    const double h = 2 * r - (q.position[0] - q.position[1]).norm();
    const double a = st.contacts.state(0)[Sintering::kNeck];
    // Approach rate in physical time.
    const double v = (q.velocity[0] - q.velocity[1]).dot((q.position[1] - q.position[0]).normalized()) / time_scale;
    if (!(std::isfinite(h) && std::isfinite(a))) monotone = 0;
    if (a < prev_a) monotone = 0;
    // Growth phase: past the start-up transient, a between 0.3 and 0.9 a_eq.
    if (samples > 2 && a > 0.3 * a_eq && a < 0.9 * a_eq) {
      worst_rate = std::max(worst_rate, std::abs(v / rate(h) - 1.0));
      ++growth_samples;
    }
    if (t_eq < 0.0 && a >= a_eq * (1 - 1e-3)) t_eq = st.physical_time;
    prev_a = a;
    ++samples;
  });
  StageConfig c = test::stage(0.0, kSteps, 0.2 * r);
  c.dt_fraction = 0.5;
  c.time_scale = time_scale;
  c.log_every = 500;
  const StageResult res = sim.run_stage(c, obs);
  const double a_end = s.contacts.state(0)[Sintering::kNeck];
  INFO("dt " << res.dt << " s, worst rate error " << worst_rate << " over " << growth_samples << " samples, a_end/a_eq " << a_end / a_eq
             << ", t(a_eq) " << t_eq << " s (physical)");
  CHECK(monotone == 1);
  CHECK(growth_samples >= 10);
  CHECK(worst_rate < 0.05);
  CHECK(a_end >= a_eq * (1 - 1e-3));
  CHECK(a_end <= a_eq * (1 + 1e-3) + 1e-15);
  CHECK(arrhenius > 1e3);
  EXTREME_FIGURE("S3 0.99 T_m sintering", "D_gb(0.99 T_m) / D_gb(0.6 T_m)", arrhenius, "");
  EXTREME_FIGURE("S3 0.99 T_m sintering", "worst rate error vs F_s/eta", worst_rate, "");
  EXTREME_FIGURE("S3 0.99 T_m sintering", "physical time to the equilibrium neck", t_eq, "s");
  EXTREME_FIGURE("S3 0.99 T_m sintering", "final neck / a_eq", a_end / a_eq, "");
  EXTREME_FIGURE("S3 0.99 T_m sintering", "wall time", res.wall_seconds, "s");
}

}  // namespace test_extreme_sintering
