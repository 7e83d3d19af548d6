// The necks the sintered_neck network conducts through, as seed 000's Fig. 6 reads them
// (physics::network_necks, issue 59): after the grain-boundary-fraction correction (Eqs. 22-25)
// a small particle with six deep necks to large neighbours has its necks scaled to
// sum a^2 = 4 r^2 exactly, so each a / r_min = 2 / sqrt(6) whatever the overlap; the large
// particles (one neck each) are never bound.
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "engine/graph/interaction_graph.hpp"
#include "engine/neighbor/neighbor_search.hpp"
#include "physics/electrical/branch_models.hpp"
#include "physics/electrical/conductance_kernels.hpp"
#include "physics/packing/neck_statistics.hpp"
#include "tests/support/scene.hpp"

namespace test_network_necks {

using namespace sparkdem;

namespace {
/// A sphere of radius r at the origin with six spheres of radius 3 r on the axes, each overlapping
/// it by h; the contact list holds only those six pairs (the large spheres' overlaps with each
/// other are left out, so that the small sphere's necks are the only ones).
State star(double r, double h) {
  State s;
  test::add_sphere(s, Vec3(0, 0, 0), r, 5910.0);
  const double d = r + 3.0 * r - h;
  for (int axis = 0; axis < 3; ++axis)
    for (double sign : {-1.0, 1.0}) {
      Vec3 x = Vec3::Zero();
      x[axis] = sign * d;
      test::add_sphere(s, x, 3.0 * r, 5910.0);
    }
  auto pairs = find_pairs(s.particles.position, s.particles.radius, 0.0);
  std::erase_if(pairs, [](const auto& pr) { return pr[0] != 0 && pr[1] != 0; });
  s.contacts.rebuild(pairs, s.particles.id, s.particles.size());
  return s;
}
}  // namespace

TEST_CASE("network necks: Eq. 25 scales a bound particle's necks to sum a^2 = 4 r^2 (a / r_min = 2 / sqrt 6)", "[electrical][sintering]") {
  const double r = 2e-6;
  physics::BranchModel m;
  m.model = "sintered_neck";
  m.neck = "cv";
  for (double h : {0.4 * r, 0.7 * r}) {
    const State s = star(r, h);
    const InteractionGraph g = build_interaction_graph(s, GraphOptions{});
    REQUIRE(g.size() == 6);
    const double a_cv = physics::electrical::cv_neck_radius(r, 3.0 * r, h);
    REQUIRE(6.0 * a_cv * a_cv > 4.0 * r * r);  // the geometry binds Eq. 25 at the small particle
    m.gbf_correction = true;
    const physics::NetworkNecks n = physics::network_necks(m, s, g);
    REQUIRE(n.ratios.size() == 6);
    for (double x : n.ratios) CHECK(std::abs(x - 2.0 / std::sqrt(6.0)) <= 1e-14);
    CHECK(std::abs(n.bound_share - 1.0 / 7.0) <= 1e-15);
    // The same as the network's own neck radii (one code path for both).
    const std::vector<double> a = physics::sintered_neck_radii(m, s, g);
    for (std::size_t e = 0; e < a.size(); ++e) CHECK(a[e] / r == n.ratios[e]);
    // Fig. 6's statistics on them: all six in the bin [0.8, 0.9).
    const physics::NeckStatistics st = physics::neck_statistics(n.ratios, 10);
    CHECK(st.necks == 6.0);
    CHECK(st.max_bin_percent == 100.0);
    CHECK(st.last_bin_percent == 0.0);
    // Without the correction the necks are the CV necks themselves; the share still reports Eq. 25.
    m.gbf_correction = false;
    const physics::NetworkNecks raw = physics::network_necks(m, s, g);
    for (double x : raw.ratios) CHECK(std::abs(x - a_cv / r) <= 1e-14);
    CHECK(std::abs(raw.bound_share - 1.0 / 7.0) <= 1e-15);
  }
}

TEST_CASE("network necks: a shallow pair binds nothing and keeps its CV neck", "[electrical][sintering]") {
  const double r = 2e-6;
  State s;
  test::add_sphere(s, Vec3(0, 0, 0), r, 5910.0);
  test::add_sphere(s, Vec3(2.0 * r - 0.1 * r, 0, 0), r, 5910.0);
  s.contacts.rebuild(find_pairs(s.particles.position, s.particles.radius, 0.0), s.particles.id, s.particles.size());
  const InteractionGraph g = build_interaction_graph(s, GraphOptions{});
  physics::BranchModel m;
  m.model = "sintered_neck";
  m.neck = "cv";
  const physics::NetworkNecks n = physics::network_necks(m, s, g);
  REQUIRE(n.ratios.size() == 1);
  CHECK(std::abs(n.ratios[0] - physics::electrical::cv_neck_radius(r, r, 0.1 * r) / r) <= 1e-14);
  CHECK(n.bound_share == 0.0);
}

}  // namespace test_network_necks
