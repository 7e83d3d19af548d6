// The contact laws over SIMD lanes (engine/contact/lanes.hpp, issue 63) against their scalar path:
// every lane path must give the scalar path's bits, on random rows that take every branch of the
// laws (touching and apart, sticking and sliding, the history rotated or not, a tail block shorter
// than the lanes), for the serial force pass, the pass that stores rows, the inertia-free pass and
// the two-thread split.
#include <omp.h>

#include <catch2/catch.hpp>
#include <cstring>
#include <random>
#include <vector>

#include "engine/contact/contact_model.hpp"
#include "engine/integrate/velocity_verlet.hpp"
#include "physics/contact/hertz_mindlin.hpp"
#include "physics/contact/hooke.hpp"
#include "physics/contact/lammps_granular.hpp"
#include "physics/contact/sintering.hpp"
#include "tests/support/nial_sintering.hpp"

namespace test_contact_lanes {

using namespace sparkdem;
using namespace sparkdem::physics;

namespace {

/// A cluster of spheres (radii 0.7-1.3 mm in a 4.5 mm cube: most neighbours overlap, some do not,
/// one pair coincides) with random velocities and spins, every pair within reach as a row with a
/// random history, some of it along the normal.
struct Cluster {
  ParticleStore p;
  ContactTable t;
  explicit Cluster(std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const int n = 70;
    for (int k = 0; k < n; ++k) {
      const double r = 0.7e-3 + 0.6e-3 * u(rng);
      p.add(Vec3(u(rng), u(rng), u(rng)) * 4.5e-3, r, 7800.0 * 4.0 / 3.0 * 3.14159 * r * r * r);
      p.velocity[k] = Vec3(u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5);
      p.omega[k] = Vec3(u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5) * 200.0;
    }
    p.position[n - 1] = p.position[n - 2];  // a pair at distance 0: never touching
    std::vector<std::array<Index, 2>> pairs;
    for (Index i = 0; i < n; ++i)
      for (Index j = i + 1; j < n; ++j)
        if ((p.position[i] - p.position[j]).norm() < p.radius[i] + p.radius[j] + 0.4e-3) pairs.push_back({i, j});
    if (pairs.size() % 8 == 0) pairs.pop_back();  // a tail block shorter than the widest lanes
    t.set_state_columns({"shear_x", "shear_y", "shear_z"});
    t.rebuild(pairs, p.id, p.size());
    for (std::size_t r = 0; r < t.size(); ++r) {
      if (r % 5 == 0) continue;  // a fresh row: no history
      const double scale = (r % 3 == 0 ? 1e-4 : 1e-7);
      for (int c = 0; c < 3; ++c) t.state(r)[c] = (u(rng) - 0.5) * scale;
    }
  }
};

bool same_bits(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec3)) == 0;
}
bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}
std::vector<double> states(const ContactTable& t) {
  std::vector<double> s;
  for (std::size_t r = 0; r < t.size(); ++r) s.insert(s.end(), t.state(r), t.state(r) + 3);
  return s;
}

/// Three steps of one pass kind under the given lane path; the cluster's state after them.
struct Outcome {
  std::vector<Vec3> force, torque, rows;
  std::vector<double> overlap, state;
};
template <class Law>
Outcome run(const ContactModelT<Law>& model, LaneIsa isa, int kind, std::uint64_t seed) {
  set_lane_isa(isa);
  Cluster c(seed);
  for (int step = 0; step < 3; ++step) {
    for (auto& f : c.p.force) f.setZero();
    for (auto& q : c.p.torque) q.setZero();
    if (kind == 0) {
      model.pair_forces(c.p, c.t, 1e-6);
    } else {
      model.pair_pass(c.p, c.t, 1e-6, 1.0, kind == 2);
      c.t.gather(c.p.force, c.p.torque);
    }
  }
  set_lane_isa(detected_lane_isa());
  return {c.p.force, c.p.torque, c.t.force(), c.t.overlap(), states(c.t)};
}

/// Every lane path the processor has against the scalar path, for the three pass kinds on 1 and 2
/// threads; `run(isa, kind)` gives one path's outcome.
template <class Run>
void check_paths(Run run) {
  for (int kind = 0; kind < 3; ++kind)
    for (int threads : {1, 2}) {
      omp_set_num_threads(threads);
      const Outcome ref = run(LaneIsa::scalar, kind);
      for (LaneIsa isa : {LaneIsa::avx2, LaneIsa::avx512}) {
        if (static_cast<int>(isa) > static_cast<int>(detected_lane_isa())) continue;
        const Outcome got = run(isa, kind);
        INFO("lanes " << lane_isa_name(isa) << ", pass kind " << kind << ", threads " << threads);
        CHECK(same_bits(got.force, ref.force));
        CHECK(same_bits(got.torque, ref.torque));
        CHECK(same_bits(got.rows, ref.rows));
        CHECK(same_bits(got.overlap, ref.overlap));
        CHECK(same_bits(got.state, ref.state));
      }
    }
}

template <class Law>
void check_lanes(const typename Law::Params& params) {
  const ContactModelT<Law> model(params);
  const int threads_before = omp_get_max_threads();
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    // The scalar reference takes every branch the lanes must reproduce.
    set_lane_isa(LaneIsa::scalar);
    Cluster c(seed);
    model.pair_forces(c.p, c.t, 1e-6);
    int live = 0, apart = 0, sliding = 0, sticking = 0;
    for (std::size_t r = 0; r < c.t.size(); ++r) {
      if (c.t.overlap()[r] <= 0.0) {
        ++apart;
        continue;
      }
      ++live;
      const Vec3 n = (c.p.position[c.t.i(r)] - c.p.position[c.t.j(r)]).normalized();
      const Vec3 f = c.t.force()[r];
      const double fn = f.dot(n), ft = (f - fn * n).norm();
      if (ft >= 0.999999 * params.friction * std::abs(fn))
        ++sliding;
      else
        ++sticking;
    }
    INFO("seed " << seed << ": rows " << c.t.size() << ", live " << live << ", apart " << apart << ", sliding " << sliding);
    REQUIRE(c.t.size() % 8 != 0);
    REQUIRE(apart > 0);
    if (params.friction > 0.0) {
      REQUIRE(sticking > 0);
      REQUIRE(sliding > 0);
    }
    check_paths([&](LaneIsa isa, int kind) { return run(model, isa, kind, seed); });
  }
  omp_set_num_threads(threads_before);
}

}  // namespace

TEST_CASE("Lane paths of the contact laws give the scalar path's bits", "[contact_laws][lanes]") {
  INFO("this processor's widest lane path: " << lane_isa_name(detected_lane_isa()));
  SECTION("hertz_mindlin") {
    HertzMindlin::Params hm;
    hm.youngs_modulus = 2e8;
    hm.friction = 0.4;
    check_lanes<HertzMindlin>(hm);
    hm.friction = 0.0;  // the Coulomb cap zeroes every tangential force
    hm.restitution = 1.0;
    check_lanes<HertzMindlin>(hm);
  }
  SECTION("lammps_hertz_tsuji") {
    LammpsHertzTsuji::Params lp;
    lp.tangential_stiffness = 2e3;
    lp.friction = 0.5;
    check_lanes<LammpsHertzTsuji>(lp);
  }
  SECTION("linear_spring_dashpot") {
    LinearSpringDashpot::Params hp;
    hp.normal_stiffness = 2e5;
    check_lanes<LinearSpringDashpot>(hp);
    hp.restitution = 1.0;  // no dashpot
    check_lanes<LinearSpringDashpot>(hp);
  }
}

namespace {

/// A hot-pressed cluster for the sintering law: spheres of 1.5-3 um packed so that most neighbours
/// overlap, every pair within reach a row with a random history of all seven columns - necks on
/// touching and on separated pairs (persistent rows), fresh rows, elastic forces of either sign,
/// viscous approaches, tangential forces, a previous radius sum - and a temperature field across the
/// sintering start (uniform = false) or one temperature (uniform = true, the cached D_eff).
struct SinterCluster {
  ParticleStore p;
  ContactTable t;
  SinterCluster(std::uint64_t seed, bool uniform) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const int n = 70;
    std::vector<double> temp;
    for (int k = 0; k < n; ++k) {
      const double r = 1.5e-6 + 1.5e-6 * u(rng);
      p.add(Vec3(u(rng), u(rng), u(rng)) * 13e-6, r, 5910.0 * 4.0 / 3.0 * 3.14159 * r * r * r * 1e6);
      p.velocity[k] = Vec3(u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5) * 1e-3;
      p.omega[k] = Vec3(u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5) * 1e2;
      temp.push_back(uniform ? 1300.0 : 940.0 + 450.0 * u(rng));
    }
    p.position[n - 1] = p.position[n - 2];  // a pair at distance 0: never live
    p.fields.declare({"temperature", 1, "K"}, p.size());
    p.fields.data("temperature") = temp;
    std::vector<double> dense(n);
    for (int k = 0; k < n; ++k) dense[k] = k % 9 == 0 ? 1.0 : 0.0;
    p.fields.declare({"mass_conserving_radii/dense", 1, "1"}, p.size());
    p.fields.data("mass_conserving_radii/dense") = dense;
    std::vector<std::array<Index, 2>> pairs;
    for (Index i = 0; i < n; ++i)
      for (Index j = i + 1; j < n; ++j)
        if ((p.position[i] - p.position[j]).norm() < p.radius[i] + p.radius[j] + 1e-6) pairs.push_back({i, j});
    if (pairs.size() % 8 == 0) pairs.pop_back();  // a tail block shorter than the widest lanes
    t.set_state_columns(Sintering::state_columns());
    t.rebuild(pairs, p.id, p.size());
    for (std::size_t r = 0; r < t.size(); ++r) {
      double* st = t.state(r);
      if (r % 5 == 0) continue;  // a fresh row: no history
      const double r_min = std::min(p.radius[t.i(r)], p.radius[t.j(r)]);
      st[Sintering::kNeck] = r % 7 == 0 ? 0.0 : r_min * u(rng);
      st[Sintering::kElastic] = (u(rng) - 0.3) * 1e-3;
      st[Sintering::kViscous] = (u(rng) - 0.2) * 0.3 * r_min;
      for (int c = 0; c < 3; ++c) st[Sintering::kTangential + c] = r % 3 == 0 ? 0.0 : (u(rng) - 0.5) * 1e-4;
      st[Sintering::kRadiusSum] = r % 4 == 0 ? 0.0 : (p.radius[t.i(r)] + p.radius[t.j(r)]) * (1.0 + (u(rng) - 0.5) * 1e-6);
    }
  }
};

std::vector<double> all_states(const ContactTable& t) {
  return std::vector<double>(t.state(0), t.state(0) + t.size() * t.state_width());
}

/// Three steps of one pass kind (0 the serial force pass, 1 the stored rows, 2 inertia-free) with the
/// sintering law under the given lane path, at time scale 2e5 and dt 1e-7 s.
Outcome run_sintering(const ContactModelT<Sintering>& model, LaneIsa isa, int kind, std::uint64_t seed, bool uniform) {
  set_lane_isa(isa);
  SinterCluster c(seed, uniform);
  for (int step = 0; step < 3; ++step) {
    for (auto& f : c.p.force) f.setZero();
    for (auto& q : c.p.torque) q.setZero();
    if (kind == 0) {
      model.pair_forces(c.p, c.t, 1e-7, 2e5);
    } else {
      model.pair_pass(c.p, c.t, 1e-7, 2e5, kind == 2);
      c.t.gather(c.p.force, c.p.torque);
    }
  }
  set_lane_isa(detected_lane_isa());
  return {c.p.force, c.p.torque, c.t.force(), c.t.overlap(), all_states(c.t)};
}

void check_sintering_lanes(const Sintering::Params& params) {
  static_assert(requires(const Sintering& l, PairLanes<8, Sintering::kLaneState>& b) { l.template lanes<8>(b, 0.0); },
                "the sintering law has a lane path (ContactModelT::kLanes)");
  const ContactModelT<Sintering> model(params);
  const int threads_before = omp_get_max_threads();
  for (std::uint64_t seed : {1u, 2u}) {
    for (bool uniform : {false, true}) {
      // The scalar reference reaches the branches the lanes must reproduce.
      set_lane_isa(LaneIsa::scalar);
      SinterCluster c(seed, uniform);
      model.pair_forces(c.p, c.t, 1e-7, 2e5);
      int necked = 0, separated_necks = 0, neckless = 0;
      for (std::size_t r = 0; r < c.t.size(); ++r) {
        const double a = c.t.state(r)[Sintering::kNeck];
        necked += a > 0.0;
        separated_necks += a > 0.0 && c.t.overlap()[r] <= 0.0;
        neckless += a == 0.0 && c.t.overlap()[r] > 0.0;
      }
      INFO("seed " << seed << (uniform ? ", one temperature" : ", temperatures across the start") << ": rows " << c.t.size()
                   << ", necks " << necked << " (" << separated_necks << " apart), touching without a neck " << neckless);
      REQUIRE(c.t.size() % 8 != 0);
      REQUIRE(necked > 0);
      REQUIRE(separated_necks > 0);
      if (!uniform) REQUIRE(neckless > 0);
      check_paths([&](LaneIsa isa, int kind) { return run_sintering(model, isa, kind, seed, uniform); });
    }
  }
  omp_set_num_threads(threads_before);
}

}  // namespace

TEST_CASE("Lane paths of the sintering law give the scalar path's bits", "[contact_laws][lanes][sintering]") {
  INFO("this processor's widest lane path: " << lane_isa_name(detected_lane_isa()));
  Sintering::Params sp = test_support::nial_sintering();  // NiAl, with the main scenario's choices:
  sp.youngs_modulus = 22.2e9;
  sp.dihedral_angle = 2.6877;
  sp.damping_ratio = 0.5;
  sp.after_equilibrium = "creep";
  SECTION("kratos neck, creep, bonded cold necks") {
    REQUIRE(Sintering(sp).lanes_enabled());
    check_sintering_lanes(sp);
  }
  SECTION("coble neck, frozen, cold necks as contacts, neck strength, r_eff driving radius") {
    sp.neck = "coble";
    sp.after_equilibrium = "frozen";
    sp.cold_necks = "contact";
    sp.neck_strength = 2e8;
    sp.sintering_radius = "r_eff";
    sp.tangential_factor = 0.3;
    check_sintering_lanes(sp);
  }
  SECTION("intersection neck, neck-radius spring, stop at dense, two_r_eff") {
    sp.neck = "intersection";
    sp.neck_stiffness = "neck_radius";
    sp.stop_flow_at_dense = true;
    sp.sintering_radius = "two_r_eff";
    sp.min_neck_fraction = 0.2;
    check_sintering_lanes(sp);
  }
  SECTION("grain-boundary-fraction stop") {
    sp.creep_stop_gb_fraction = 0.3;
    sp.creep_overlap_limit = 0.4;
    check_sintering_lanes(sp);
  }
  SECTION("power-law creep and the constant-volume neck run row by row") {
    sp.powerlaw_creep_rate = 1e-3;
    CHECK_FALSE(Sintering(sp).lanes_enabled());
    sp.powerlaw_creep_rate = 0.0;
    sp.neck = "cv";
    CHECK_FALSE(Sintering(sp).lanes_enabled());
  }
}

TEST_CASE("Lane paths of the Verlet kick and drift give the scalar path's bits", "[lanes]") {
  // 1,003 particles (a tail shorter than the lanes) with forces, torques and orientations at random;
  // spins at rest, slow (the Taylor branch) and fast (sin and cos), whole blocks without spin or
  // torque; a few prescribed (1: moved, 2: a rotating set); steps of 1e-5 s and 0.
  auto scene = [](std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    ParticleStore p;
    for (int k = 0; k < 1003; ++k) {
      p.add(Vec3(u(rng), u(rng), u(rng)), 1e-3 * (1.5 + u(rng)), 1e-5 * (1.5 + u(rng)));
      p.velocity[k] = Vec3(u(rng), u(rng), u(rng));
      p.force[k] = Vec3(u(rng), u(rng), u(rng)) * 1e-3;
      p.torque[k] = Vec3(u(rng), u(rng), u(rng)) * 1e-9;
      const double spin = k % 7 == 0 ? 0.0 : (k % 11 == 0 ? 5e3 : 50.0);
      p.omega[k] = Vec3(u(rng), u(rng), u(rng)) * spin;
      p.orientation[k] = Quat(u(rng), u(rng), u(rng), u(rng)).normalized();
      if (k % 97 == 0) p.fixed[k] = 1 + k % 2;
      if (k >= 16 && k < 48) {  // whole blocks that do not spin: their orientations are not read
        p.omega[k].setZero();
        p.torque[k].setZero();
      }
    }
    return p;
  };
  for (double dt : {1e-5, 0.0}) {
    set_lane_isa(LaneIsa::scalar);
    ParticleStore ref = scene(5);
    for (int s = 0; s < 3; ++s) verlet_first_half(ref, dt);
    int fast = 0;
    for (std::size_t k = 0; k < ref.size(); ++k) fast += 0.25 * ref.omega[k].squaredNorm() * dt * dt >= 1e-4;
    if (dt > 0.0) REQUIRE(fast > 0);  // the sin / cos branch is taken
    for (LaneIsa isa : {LaneIsa::avx2, LaneIsa::avx512}) {
      if (static_cast<int>(isa) > static_cast<int>(detected_lane_isa())) continue;
      set_lane_isa(isa);
      ParticleStore got = scene(5);
      for (int s = 0; s < 3; ++s) verlet_first_half(got, dt);
      INFO("lanes " << lane_isa_name(isa) << ", dt " << dt);
      CHECK(same_bits(got.position, ref.position));
      CHECK(same_bits(got.velocity, ref.velocity));
      CHECK(same_bits(got.omega, ref.omega));
      CHECK(same_bits(got.force, ref.force));
      CHECK(same_bits(got.torque, ref.torque));
      CHECK(std::memcmp(got.orientation.data(), ref.orientation.data(), ref.size() * sizeof(Quat)) == 0);
    }
    set_lane_isa(detected_lane_isa());
  }
}

}  // namespace test_contact_lanes
